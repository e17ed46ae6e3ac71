#include <gtest/gtest.h>

#include <cmath>

#include "support/random_graphs.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/lattice/collision.hpp"

using namespace trellis;

namespace {

// Brute force: sample both segments densely and test the definition point by point.
// margin > 0 asks for a clear hit, margin < 0 accepts a near one.
bool sampled_hit(const NozzleModel& m, Vec3 qa, Vec3 qb, Vec3 pa, Vec3 pb,
                 const std::vector<Vec3>& shared, double margin, int steps = 300) {
  for (int i = 0; i <= steps; ++i) {
    const Vec3 p = pa + (pb - pa) * (double(i) / steps);
    bool exempt = false;
    for (const Vec3 n : shared) exempt |= distance(p, n) < m.node_clearance + margin;
    if (exempt) continue;
    for (int j = 0; j <= steps; ++j) {
      const Vec3 q = qa + (qb - qa) * (double(j) / steps);
      if (p.z - q.z > m.tip_clearance + margin && distance_xy(p, q) < m.radius - margin)
        return true;
    }
  }
  return false;
}

}  // namespace

TEST(Collision, ExactPredicateAgreesWithDenseSampling) {
  NozzleModel m;
  Rng rng(7);
  int hits = 0, misses = 0;
  for (int k = 0; k < 600; ++k) {
    auto pt = [&] { return Vec3{rng.uniform01() * 3, rng.uniform01() * 3, rng.uniform01() * 3}; };
    const Vec3 qa = pt(), qb = pt();
    Vec3 pa = pt(), pb = pt();
    std::vector<Vec3> shared;
    if (k % 3 == 0) {  // share a node with the moving strut
      pa = qb;
      shared.push_back(qb);
    }
    if (k % 7 == 0) pb = pa + Vec3{0.01 * rng.uniform01(), 0, 2};  // nearly vertical
    const bool exact =
        nozzle_hits(m, qa, qb, pa, pb, shared.data(), static_cast<int>(shared.size()));
    if (sampled_hit(m, qa, qb, pa, pb, shared, 0.02)) EXPECT_TRUE(exact) << k;
    if (exact) EXPECT_TRUE(sampled_hit(m, qa, qb, pa, pb, shared, -0.02)) << k;
    (exact ? hits : misses)++;
  }
  EXPECT_GT(hits, 50);
  EXPECT_GT(misses, 50);
}

TEST(Collision, CylinderAboveTheTipOnlyAndNodesExempt) {
  NozzleModel m;
  const Vec3 n{0, 0, 0};
  // A vertical strut rising from the node the tip arrives at: hit above the node clearance.
  const Vec3 up{0, 0, 5};
  Contact c;
  EXPECT_TRUE(nozzle_hits(m, {-3, 0, 0}, n, n, up, &n, 1, &c));
  EXPECT_GE(distance(c.point, n), m.node_clearance - 1e-9);
  EXPECT_NEAR(c.tip.z, 0, 1e-9);
  // Only 0.9 mm tall: inside the node clearance, exempt.
  EXPECT_FALSE(nozzle_hits(m, {-3, 0, 0}, n, n, {0, 0, 0.9}, &n, 1));
  // Without the shared node it is hit.
  EXPECT_TRUE(nozzle_hits(m, {-3, 0, 0}, n, n, {0, 0, 0.9}, nullptr, 0));
  // Material below the tip, or beside it beyond R, is never hit.
  EXPECT_FALSE(nozzle_hits(m, {0, 0, 5}, {5, 0, 5}, {0, 0, 0}, {5, 0, 0}, nullptr, 0));
  EXPECT_FALSE(nozzle_hits(m, {0, 0, 0}, {5, 0, 0}, {0, 0.37, 3}, {5, 0.37, 3}, nullptr, 0));
  EXPECT_TRUE(nozzle_hits(m, {0, 0, 0}, {5, 0, 0}, {0, 0.35, 3}, {5, 0.35, 3}, nullptr, 0));
  // Within the tip clearance above: not hit.
  EXPECT_FALSE(nozzle_hits(m, {0, 0, 0}, {5, 0, 0}, {0, 0, 0.04}, {5, 0, 0.04}, nullptr, 0));
  EXPECT_TRUE(is_steep({0, 0, 0}, {0.5, 0, 2}, m));
  EXPECT_FALSE(is_steep({0, 0, 0}, {2, 0, 2}, m));
  NozzleModel bad;
  bad.radius = -1;
  EXPECT_THROW(bad.validate(), SettingError);
}

TEST(Collision, BlockingGraphEqualsAllPairs) {
  NozzleModel m;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const Graph g = test::random_lattice3d(seed, 4, 0.6, 0.8);
    const BlockingGraph b = blocking_graph(g, m, seed % 2 ? 1 : 0);
    std::size_t expected = 0;
    for (EdgeId u = 0; u < g.edges.size(); ++u)
      for (EdgeId s = 0; s < g.edges.size(); ++s) {
        if (s == u) continue;
        const Edge &es = g.edges[s], &eu = g.edges[u];
        std::vector<Vec3> shared;
        if (es.a == eu.a || es.a == eu.b) shared.push_back(g.nodes[es.a]);
        if (es.b == eu.a || es.b == eu.b) shared.push_back(g.nodes[es.b]);
        const bool hit = nozzle_hits(m, g.nodes[eu.a], g.nodes[eu.b], g.nodes[es.a], g.nodes[es.b],
                                     shared.data(), static_cast<int>(shared.size()));
        const bool listed = std::find(b.blocks.begin(s), b.blocks.end(s), u) != b.blocks.end(s);
        const bool listed_back =
            std::find(b.blocked_by.begin(u), b.blocked_by.end(u), s) != b.blocked_by.end(u);
        EXPECT_EQ(hit, listed) << "seed " << seed << " s " << s << " u " << u;
        EXPECT_EQ(hit, listed_back);
        expected += hit;
      }
    EXPECT_EQ(b.relations(), expected);
    EXPECT_GT(expected, 0u);
  }
}
