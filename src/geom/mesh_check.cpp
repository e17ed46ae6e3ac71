// Is a mesh closed and manifold? Every undirected edge must be used exactly twice, once in each
// direction. The 3·T half-edges are grouped by their lower vertex (a counting sort into flat
// arrays, no node-based map; runs of triangles counted and filed in parallel, each run with its
// own counts), and each vertex's few edges are then sorted and counted, vertices in parallel. The
// counts and the first problem (the edge with the lowest pair of vertex numbers) do not depend on
// the thread count.
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstdint>

#include "trellis/core/error.hpp"
#include "trellis/core/memory.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis {

namespace {

// One half-edge, filed under its lower vertex: the other vertex, and its triangle with the
// direction in the low bit (1: from the lower vertex to the higher).
struct HalfEdge {
  std::uint32_t hi;
  std::uint32_t tri_dir;
};

struct Problem {
  std::uint64_t key = ~std::uint64_t{0};  // lo << 32 | hi; none while all ones
  std::size_t triangle = 0;
  bool open = false;
};

struct Tally {
  std::size_t open = 0, nonmanifold = 0;
  Problem first;
  void add(const Tally& o) {
    open += o.open;
    nonmanifold += o.nonmanifold;
    if (o.first.key < first.key) first = o.first;
  }
};

// The edges of vertex `lo`: e[0..n) sorted by the other vertex, then tallied run by run.
void tally_vertex(std::uint32_t lo, HalfEdge* e, std::size_t n, Tally& t) {
  auto by_hi = [](const HalfEdge& a, const HalfEdge& b) { return a.hi < b.hi; };
  if (n <= 12) {
    for (std::size_t i = 1; i < n; ++i)
      for (std::size_t j = i; j > 0 && e[j].hi < e[j - 1].hi; --j) std::swap(e[j], e[j - 1]);
  } else {
    std::sort(e, e + n, by_hi);
  }
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    std::uint32_t forward = 0, last = 0;
    for (; j < n && e[j].hi == e[i].hi; ++j) {
      forward += e[j].tri_dir & 1u;
      last = std::max(last, e[j].tri_dir >> 1);
    }
    const std::size_t uses = j - i, backward = uses - forward;
    const bool open = uses == 1;
    if (open || forward != 1 || backward != 1) {
      (open ? t.open : t.nonmanifold)++;
      const std::uint64_t key = (std::uint64_t{lo} << 32) | e[i].hi;
      if (key < t.first.key) t.first = {key, last, open};
    }
    i = j;
  }
}

}  // namespace

MeshCheck check_mesh(const TriangleMesh& mesh) {
  MeshCheck c;
  c.triangles = mesh.triangles.size();
  const std::size_t nv = mesh.vertices.size(), nt = mesh.triangles.size();
  if (3 * nt >= 0xffffffffull)
    throw GeometryError(
        fmt::format("mesh of {} triangles: too many to check (at most 1,431,655,764)", nt));
  // The triangles in `parts` runs, one per thread. at[p][v]: the half-edges of run p filed under
  // vertex v, counted; then where run p writes them (after runs 0 .. p-1, as one pass would).
  const std::size_t parts =
      nt < (1u << 16)
          ? 1
          : std::clamp<std::size_t>(
                static_cast<std::size_t>(tbb::this_task_arena::max_concurrency()), 1, 8);
  auto run = [&](std::size_t p) { return std::pair{p * nt / parts, (p + 1) * nt / parts}; };
  std::vector<std::vector<std::uint32_t>> at(parts);
  std::vector<std::size_t> bad(parts, nt);  // each run's first triangle naming no vertex
  tbb::parallel_for(std::size_t{0}, parts, [&](std::size_t p) {
    std::vector<std::uint32_t>& cnt = at[p];
    cnt.assign(nv, 0);
    for (auto [t, end] = run(p); t < end; ++t) {
      const auto& tri = mesh.triangles[t];
      if (std::max({tri[0], tri[1], tri[2]}) >= nv) {
        bad[p] = t;
        return;
      }
      for (int k = 0; k < 3; ++k) ++cnt[std::min(tri[k], tri[(k + 1) % 3])];
    }
  });
  for (const std::size_t t : bad)
    if (t < nt) {
      const auto& tri = mesh.triangles[t];
      for (int k = 0; k < 3; ++k)  // its first edge out of range
        if (const std::uint32_t v = std::max(tri[k], tri[(k + 1) % 3]); v >= nv)
          throw GeometryError(fmt::format("triangle {} refers to vertex {} of {}", t, v, nv));
    }
  std::vector<std::uint32_t> start(nv + 1, 0);  // vertex v's half-edges: start[v] .. start[v + 1]
  for (std::size_t v = 0, s = 0; v < nv; ++v) {
    for (std::size_t p = 0; p < parts; ++p) {
      const std::uint32_t n = at[p][v];
      at[p][v] = static_cast<std::uint32_t>(s);
      s += n;
    }
    start[v + 1] = static_cast<std::uint32_t>(s);
  }
  std::vector<HalfEdge> edges;
  resize_filled(edges, 3 * nt);
  tbb::parallel_for(std::size_t{0}, parts, [&](std::size_t p) {
    std::uint32_t* next = at[p].data();
    for (auto [t, end] = run(p); t < end; ++t) {
      const auto& tri = mesh.triangles[t];
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = tri[k], b = tri[(k + 1) % 3];
        const std::uint32_t tri_dir = static_cast<std::uint32_t>(t << 1) | (a < b ? 1u : 0u);
        edges[next[std::min(a, b)]++] = {std::max(a, b), tri_dir};
      }
    }
  });
  const Tally total = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, nv, 1 << 14), Tally{},
      [&](const tbb::blocked_range<std::size_t>& r, Tally t) {
        for (std::size_t v = r.begin(); v < r.end(); ++v)
          tally_vertex(static_cast<std::uint32_t>(v), edges.data() + start[v],
                       start[v + 1] - start[v], t);
        return t;
      },
      [](Tally a, const Tally& b) {
        a.add(b);
        return a;
      });
  c.open_edges = total.open;
  c.nonmanifold_edges = total.nonmanifold;
  if (total.open + total.nonmanifold > 0) {
    const Problem& p = total.first;
    const Vec3 a = mesh.vertices[p.key >> 32], b = mesh.vertices[p.key & 0xffffffffu];
    c.first_problem =
        fmt::format("{} edge ({:.4g}, {:.4g}, {:.4g})–({:.4g}, {:.4g}, {:.4g}) of triangle {}",
                    p.open ? "open" : "non-manifold", a.x, a.y, a.z, b.x, b.y, b.z, p.triangle);
  }
  return c;
}

}  // namespace trellis
