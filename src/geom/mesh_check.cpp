// Is a mesh closed and manifold? Every undirected edge must be used exactly twice, once in each
// direction. The 3·T half-edges are grouped by their lower vertex (a counting sort into flat
// arrays, no node-based map; runs of triangles counted and filed in parallel, each run with its
// own counts), and each vertex's few edges are then sorted and counted, vertices in parallel. A
// half-edge is filed as 4 bytes (its other vertex and its direction), so the sort moves 12 bytes a
// triangle. The counts and the first problem (the edge with the lowest pair of vertex numbers, and
// the last triangle using it) do not depend on the thread count.
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstdint>
#include <memory>

#include "trellis/core/error.hpp"
#include "trellis/core/memory.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis {

namespace {

// A half-edge is filed under its lower vertex as the other vertex shifted up one bit, the
// direction in the low bit (1: from the lower vertex to the higher): a uint32_t while the vertex
// numbers fit in 31 bits (short of 2^31 vertices), else a uint64_t. Its triangle is not kept: the
// first problem's triangle is looked up again, only when there is a problem.
struct Tally {
  std::size_t open = 0, nonmanifold = 0;
  std::uint64_t first = ~std::uint64_t{0};  // the lowest problem edge, lo << 32 | hi
  bool first_open = false;
  void add(const Tally& o) {
    open += o.open;
    nonmanifold += o.nonmanifold;
    if (o.first < first) {
      first = o.first;
      first_open = o.first_open;
    }
  }
};

// The edges of vertex `lo`: e[0..n) sorted (by the other vertex, then backward before forward),
// then tallied run by run: an edge is right when it is used once each way.
template <class E>
void tally_vertex(std::uint32_t lo, E* e, std::size_t n, Tally& t) {
  if (n <= 16) {
    for (std::size_t i = 1; i < n; ++i) {
      const E x = e[i];
      std::size_t j = i;
      for (; j > 0 && x < e[j - 1]; --j) e[j] = e[j - 1];
      e[j] = x;
    }
  } else {
    std::sort(e, e + n);
  }
  for (std::size_t i = 0; i < n;) {
    const E hi = e[i] >> 1;
    // The common case: a backward and a forward use, and nothing more.
    if (i + 1 < n && e[i + 1] == e[i] + 1 && (e[i] & 1) == 0 &&
        (i + 2 == n || e[i + 2] >> 1 != hi)) {
      i += 2;
      continue;
    }
    std::size_t j = i, forward = 0;
    for (; j < n && e[j] >> 1 == hi; ++j) forward += static_cast<std::size_t>(e[j] & 1);
    const std::size_t uses = j - i;
    const bool open = uses == 1;
    if (open || forward != 1 || uses - forward != 1) {
      (open ? t.open : t.nonmanifold)++;
      const std::uint64_t key = (std::uint64_t{lo} << 32) | static_cast<std::uint64_t>(hi);
      if (key < t.first) {
        t.first = key;
        t.first_open = open;
      }
    }
    i = j;
  }
}

// The half-edges filed under their lower vertex (a counting sort: `start`, `at` as set up by
// check_mesh), tallied vertex by vertex.
template <class E>
Tally tally(const TriangleMesh& mesh, std::size_t parts,
            std::vector<std::vector<std::uint32_t>>& at, const std::vector<std::uint32_t>& start) {
  const std::size_t nv = mesh.vertices.size(), nt = mesh.triangles.size();
  auto run = [&](std::size_t p) { return std::pair{p * nt / parts, (p + 1) * nt / parts}; };
  const std::unique_ptr<E[]> edges(new E[3 * nt]);  // every one written below: not zeroed first
  advise_huge_pages(edges.get(), 3 * nt * sizeof(E));
  tbb::parallel_for(std::size_t{0}, parts, [&](std::size_t p) {
    std::uint32_t* next = at[p].data();
    for (auto [t, end] = run(p); t < end; ++t) {
      const auto& tri = mesh.triangles[t];
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = tri[k], b = tri[(k + 1) % 3];
        const E e = a < b ? (E{b} << 1 | 1) : (E{a} << 1);
        edges[next[std::min(a, b)]++] = e;
      }
    }
  });
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, nv, 1 << 14), Tally{},
      [&](const tbb::blocked_range<std::size_t>& r, Tally t) {
        for (std::size_t v = r.begin(); v < r.end(); ++v)
          tally_vertex(static_cast<std::uint32_t>(v), edges.get() + start[v],
                       start[v + 1] - start[v], t);
        return t;
      },
      [](Tally a, const Tally& b) {
        a.add(b);
        return a;
      });
}

// The last triangle using the undirected edge lo-hi.
std::size_t last_triangle_of(const TriangleMesh& mesh, std::uint32_t lo, std::uint32_t hi) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 1 << 16), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t last) {
        for (std::size_t t = r.begin(); t < r.end(); ++t) {
          const auto& tri = mesh.triangles[t];
          for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = tri[k], b = tri[(k + 1) % 3];
            if (std::min(a, b) == lo && std::max(a, b) == hi) last = std::max(last, t);
          }
        }
        return last;
      },
      [](std::size_t a, std::size_t b) { return std::max(a, b); });
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
  struct Total {
    std::size_t open = 0, nonmanifold = 0;
    std::uint64_t first = 0;
    bool first_open = false;
  };
  auto totals = [](const auto& t) { return Total{t.open, t.nonmanifold, t.first, t.first_open}; };
  const Total total = nv < (std::size_t{1} << 31)
                          ? totals(tally<std::uint32_t>(mesh, parts, at, start))
                          : totals(tally<std::uint64_t>(mesh, parts, at, start));
  c.open_edges = total.open;
  c.nonmanifold_edges = total.nonmanifold;
  if (total.open + total.nonmanifold > 0) {
    const auto lo = static_cast<std::uint32_t>(total.first >> 32);
    const auto hi = static_cast<std::uint32_t>(total.first & 0xffffffffu);
    const Vec3 a = mesh.vertices[lo], b = mesh.vertices[hi];
    c.first_problem =
        fmt::format("{} edge ({:.4g}, {:.4g}, {:.4g})–({:.4g}, {:.4g}, {:.4g}) of triangle {}",
                    total.first_open ? "open" : "non-manifold", a.x, a.y, a.z, b.x, b.y, b.z,
                    last_triangle_of(mesh, lo, hi));
  }
  return c;
}

}  // namespace trellis
