// check_mesh (counting sort of half-edges, vertices tallied in parallel) against a plain map of
// edge uses on random meshes: closed ones, and ones with holes, repeated triangles, flipped
// triangles, fans and degenerate triangles; the same result with one thread and two.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <map>
#include <random>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"

using namespace trellis;

namespace {

// The oracle: every undirected edge's uses counted per direction in an ordered map; the first
// problem is the lowest (lo, hi), its triangle the last one using the edge.
struct Oracle {
  std::size_t open = 0, nonmanifold = 0;
  bool has_problem = false;
  std::uint32_t lo = 0, hi = 0;
  std::size_t triangle = 0;
  bool first_open = false;
};

Oracle oracle(const TriangleMesh& m) {
  struct Use {
    int forward = 0, backward = 0;
    std::size_t triangle = 0;
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, Use> edges;
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = m.triangles[t][k], b = m.triangles[t][(k + 1) % 3];
      auto& u = edges[{std::min(a, b), std::max(a, b)}];
      (a < b ? u.forward : u.backward)++;
      u.triangle = t;
    }
  Oracle o;
  for (const auto& [key, u] : edges) {
    const bool open = u.forward + u.backward == 1;
    if (!open && u.forward == 1 && u.backward == 1) continue;
    (open ? o.open : o.nonmanifold)++;
    if (!o.has_problem) o = {o.open, o.nonmanifold, true, key.first, key.second, u.triangle, open};
  }
  return o;
}

// A closed surface: a torus of 2·nu·nv triangles, vertices numbered in a shuffled order.
TriangleMesh torus(int nu, int nv, std::mt19937& rng) {
  TriangleMesh m;
  std::vector<std::uint32_t> perm(static_cast<std::size_t>(nu * nv));
  for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = static_cast<std::uint32_t>(i);
  std::shuffle(perm.begin(), perm.end(), rng);
  m.vertices.resize(perm.size());
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) m.vertices[perm[i * nv + j]] = {double(i), double(j), 0};
  auto id = [&](int i, int j) { return perm[(i % nu) * nv + (j % nv)]; };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

// Damage of one kind at random places: drop, repeat or flip triangles, add a fan around a
// vertex (edges used many times), or degenerate triangles (a vertex twice).
void damage(TriangleMesh& m, std::mt19937& rng) {
  std::uniform_int_distribution<std::size_t> tri(0, m.triangles.size() - 1);
  std::uniform_int_distribution<std::uint32_t> vert(
      0, static_cast<std::uint32_t>(m.vertices.size() - 1));
  const int kind = static_cast<int>(rng() % 5), times = 1 + static_cast<int>(rng() % 6);
  for (int n = 0; n < times; ++n) {
    const std::size_t t = tri(rng);
    switch (kind) {
      case 0:
        m.triangles.erase(m.triangles.begin() + static_cast<long>(t));
        break;
      case 1:
        m.triangles.push_back(m.triangles[t]);
        break;
      case 2:
        std::swap(m.triangles[t][0], m.triangles[t][1]);
        break;
      case 3: {
        const std::uint32_t c = vert(rng);
        for (int k = 0; k < 40; ++k) m.triangles.push_back({c, vert(rng), vert(rng)});
        break;
      }
      default:
        m.triangles.push_back({m.triangles[t][0], m.triangles[t][0], m.triangles[t][1]});
    }
  }
}

void expect_matches(const TriangleMesh& m, const std::string& what) {
  const Oracle o = oracle(m);
  for (const std::size_t threads : {1u, 2u}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const MeshCheck c = check_mesh(m);
    EXPECT_EQ(c.triangles, m.triangles.size()) << what;
    EXPECT_EQ(c.open_edges, o.open) << what;
    EXPECT_EQ(c.nonmanifold_edges, o.nonmanifold) << what;
    EXPECT_EQ(c.closed(), !o.has_problem) << what;
    if (!o.has_problem) {
      EXPECT_TRUE(c.first_problem.empty()) << what;
      continue;
    }
    const Vec3 a = m.vertices[o.lo], b = m.vertices[o.hi];
    char expected[256];
    std::snprintf(expected, sizeof expected, "%s edge (%.4g, %.4g, %.4g)",
                  o.first_open ? "open" : "non-manifold", a.x, a.y, a.z);
    EXPECT_EQ(c.first_problem.rfind(expected, 0), 0u) << what << ": " << c.first_problem;
    std::snprintf(expected, sizeof expected, "(%.4g, %.4g, %.4g) of triangle %zu", b.x, b.y, b.z,
                  o.triangle);
    EXPECT_NE(c.first_problem.find(expected), std::string::npos) << what << ": " << c.first_problem;
  }
}

}  // namespace

TEST(MeshCheck, MatchesEdgeMapOnClosedAndDamagedMeshes) {
  std::mt19937 rng(40);
  for (int round = 0; round < 200; ++round) {
    const int nu = 3 + static_cast<int>(rng() % 30), nv = 3 + static_cast<int>(rng() % 30);
    TriangleMesh m = torus(nu, nv, rng);
    const std::string what = "round " + std::to_string(round);
    if (round % 4 == 0) {
      expect_matches(m, what + " (closed)");
      EXPECT_TRUE(check_mesh(m).closed()) << what;
      continue;
    }
    damage(m, rng);
    expect_matches(m, what);
  }
}

TEST(MeshCheck, LargeClosedMeshAndEdgeCases) {
  std::mt19937 rng(7);
  const TriangleMesh big = torus(400, 300, rng);  // 240,000 triangles: many parallel tasks
  expect_matches(big, "big torus");
  TriangleMesh open = big;
  open.triangles.erase(open.triangles.begin() + 12345);
  expect_matches(open, "big torus with a hole");
  EXPECT_EQ(check_mesh(open).open_edges, 3u);
  const MeshCheck empty = check_mesh(TriangleMesh{});
  EXPECT_TRUE(empty.closed());
  EXPECT_EQ(empty.triangles, 0u);
  // Damage anywhere in a mesh large enough to be counted in runs (one per thread): the runs'
  // counts add up to the map's, and the first problem is the lowest wherever it is.
  for (int round = 0; round < 6; ++round) {
    TriangleMesh damaged = big;
    damage(damaged, rng);
    expect_matches(damaged, "big torus, damage " + std::to_string(round));
  }
  // A triangle naming no vertex: the lowest such triangle is named, in either run.
  TriangleMesh bad = big;
  const auto nv = static_cast<std::uint32_t>(bad.vertices.size());
  bad.triangles[200000][1] = nv + 9;
  bad.triangles[7][2] = nv;
  for (const std::size_t threads : {1u, 2u}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    try {
      check_mesh(bad);
      ADD_FAILURE() << "no error";
    } catch (const GeometryError& e) {
      EXPECT_NE(std::string(e.what()).find("triangle 7 refers to vertex " + std::to_string(nv)),
                std::string::npos)
          << e.what();
    }
  }
}
