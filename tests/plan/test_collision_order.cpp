#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

#include "support/random_graphs.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/lattice/collision.hpp"
#include "trellis/plan/aero.hpp"
#include "trellis/plan/collision_order.hpp"

using namespace trellis;

namespace {

// cost[s][u] = 1: printing s before u is a collision (u in blocks[s]).
using Matrix = std::vector<std::vector<char>>;

BlockingGraph from_matrix(const Matrix& cost) {
  const std::size_t m = cost.size();
  BlockingGraph b;
  b.blocks.offsets.assign(m + 1, 0);
  b.blocked_by.offsets.assign(m + 1, 0);
  for (EdgeId s = 0; s < m; ++s) {
    for (EdgeId u = 0; u < m; ++u)
      if (cost[s][u]) b.blocks.items.push_back(u);
    b.blocks.offsets[s + 1] = static_cast<std::uint32_t>(b.blocks.items.size());
  }
  for (EdgeId u = 0; u < m; ++u) {
    for (EdgeId s = 0; s < m; ++s)
      if (cost[s][u]) b.blocked_by.items.push_back(s);
    b.blocked_by.offsets[u + 1] = static_cast<std::uint32_t>(b.blocked_by.items.size());
  }
  return b;
}

Matrix to_matrix(const BlockingGraph& b, std::size_t m) {
  Matrix c(m, std::vector<char>(m, 0));
  for (EdgeId s = 0; s < m; ++s)
    for (const EdgeId* u = b.blocks.begin(s); u != b.blocks.end(s); ++u) c[s][*u] = 1;
  return c;
}

// Parts by mutual reachability (transitive closure, Floyd-Warshall): independent of the
// planner's Tarjan.
std::vector<std::vector<EdgeId>> parts_by_closure(const Matrix& cost) {
  const std::size_t m = cost.size();
  Matrix reach = cost;
  for (std::size_t k = 0; k < m; ++k)
    for (std::size_t i = 0; i < m; ++i)
      if (reach[i][k])
        for (std::size_t j = 0; j < m; ++j)
          if (reach[k][j]) reach[i][j] = 1;
  std::vector<int> part(m, -1);
  std::vector<std::vector<EdgeId>> parts;
  for (std::size_t i = 0; i < m; ++i) {
    if (part[i] >= 0) continue;
    std::vector<EdgeId> p{static_cast<EdgeId>(i)};
    part[i] = static_cast<int>(parts.size());
    for (std::size_t j = i + 1; j < m; ++j)
      if (reach[i][j] && reach[j][i]) {
        p.push_back(static_cast<EdgeId>(j));
        part[j] = part[i];
      }
    parts.push_back(p);
  }
  return parts;
}

// The fewest collisions over every order of a part's struts, by exhaustive dynamic programming
// over the sets printed first (each order is a path through the subsets; none is skipped).
std::size_t brute_force_minimum(const Matrix& cost, const std::vector<EdgeId>& part) {
  const std::size_t k = part.size();
  std::vector<std::uint32_t> before(k, 0);  // bit j: printing part[j] before part[i] costs
  for (std::size_t i = 0; i < k; ++i)
    for (std::size_t j = 0; j < k; ++j)
      if (cost[part[j]][part[i]]) before[i] |= 1u << j;
  std::vector<std::uint32_t> best(std::size_t{1} << k, UINT32_MAX);
  best[0] = 0;
  for (std::uint32_t mask = 0; mask < (1u << k); ++mask) {
    if (best[mask] == UINT32_MAX) continue;
    for (std::size_t i = 0; i < k; ++i) {
      if (mask >> i & 1) continue;
      const std::uint32_t c =
          best[mask] + static_cast<std::uint32_t>(std::popcount(before[i] & mask));
      best[mask | 1u << i] = std::min(best[mask | 1u << i], c);
    }
  }
  return best.back();
}

// The exhaustive minimum over all parts; false if a part has more than 12 struts.
bool brute_force_total(const Matrix& cost, std::size_t& total) {
  const auto parts = parts_by_closure(cost);
  for (const auto& p : parts)
    if (p.size() > 12) return false;
  total = 0;
  for (const auto& p : parts)
    if (p.size() > 1) total += brute_force_minimum(cost, p);
  return true;
}

// Random relations: a few blocks of up to 12 struts, dense inside, sparse between.
Matrix random_relation(std::uint64_t seed) {
  Rng rng(seed);
  const std::size_t blocks = 1 + rng.uniform_index(3);
  std::vector<std::size_t> block_of;
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t size = 2 + rng.uniform_index(11);
    for (std::size_t i = 0; i < size; ++i) block_of.push_back(b);
  }
  const std::size_t m = block_of.size();
  const double p_in = 0.15 + 0.5 * rng.uniform01();
  Matrix c(m, std::vector<char>(m, 0));
  for (std::size_t s = 0; s < m; ++s)
    for (std::size_t u = 0; u < m; ++u) {
      if (s == u) continue;
      // Between blocks only "lower block first" relations, so the blocks stay separate parts.
      const bool inside = block_of[s] == block_of[u];
      if (inside ? rng.uniform01() < p_in : (block_of[s] > block_of[u] && rng.uniform01() < 0.1))
        c[s][u] = 1;
    }
  return c;
}

// The order's relations broken are exactly `broken`, and dropping them leaves no cycle.
void expect_consistent(const BlockingGraph& b, const CollisionOrder& r, std::size_t m) {
  EXPECT_EQ(r.broken.size(), r.planned);
  const Matrix rest = to_matrix(without_relations(b, r.broken), m);
  for (const auto& p : parts_by_closure(rest)) EXPECT_EQ(p.size(), 1u);
  std::size_t planned = 0, lower = 0;
  for (const auto& part : r.parts) {
    planned += part.planned;
    lower += part.lower_bound;
    EXPECT_LE(part.lower_bound, part.planned);
  }
  EXPECT_EQ(planned, r.planned);
  EXPECT_EQ(lower, r.lower_bound);
}

}  // namespace

TEST(FewestCollisions, ProvenMinimalAgreesWithExhaustiveSearchOnRandomRelations) {
  std::size_t proven = 0, exact = 0, cases = 0;
  for (std::uint64_t seed = 1; seed <= 150; ++seed) {
    const Matrix cost = random_relation(seed);
    const BlockingGraph b = from_matrix(cost);
    std::size_t truth = 0;
    ASSERT_TRUE(brute_force_total(cost, truth));
    // Exact solver on; and off (local search and bounds only): claims must hold either way.
    for (std::size_t exact_max : {std::size_t{1500}, std::size_t{0}}) {
      CollisionOrderParams p;
      p.exact_max_struts = exact_max;
      p.restarts = 0;
      p.seed = seed;
      const CollisionOrder r = fewest_collisions(b, p);
      expect_consistent(b, r, cost.size());
      EXPECT_LE(r.lower_bound, truth) << seed;
      EXPECT_GE(r.planned, truth) << seed;
      if (r.proven()) {
        EXPECT_EQ(r.planned, truth) << seed;
        ++proven;
      }
      if (exact_max > 0) EXPECT_TRUE(r.proven()) << seed << ": every part is small";
      for (const auto& part : r.parts) exact += part.exact;
      ++cases;
    }
  }
  EXPECT_GT(exact, 20u) << "the integer program must be exercised, not only the bounds";
  EXPECT_GT(proven, cases / 2);
}

TEST(FewestCollisions, ProvenMinimalAgreesWithExhaustiveSearchOnLattices) {
  // Small random 3D lattices under the real nozzle model: the planner's order (checked count)
  // against the exhaustive minimum per strongly connected part of at most 12 struts.
  std::size_t compared = 0, with_collisions = 0;
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const Graph g = test::dense_lattice3d(seed, 3, 0.25 + 0.01 * static_cast<double>(seed % 20));
    AeroParams ap;
    ap.tries = 2;
    const BlockingGraph b = blocking_graph(g, ap.nozzle, 1);
    const Matrix cost = to_matrix(b, g.edges.size());
    std::size_t truth = 0;
    if (!brute_force_total(cost, truth)) continue;
    Diagnostics d;
    const AeroResult r = plan_aero(g, ap, d);
    EXPECT_LE(r.collisions_lower_bound, truth) << seed;
    EXPECT_GE(r.collisions_planned, truth) << seed;
    if (r.collisions_proven_minimal()) EXPECT_EQ(r.collisions_planned, truth) << seed;
    EXPECT_TRUE(r.collisions_proven_minimal()) << seed << ": parts of at most 12 struts";
    ++compared;
    with_collisions += truth > 0;
  }
  EXPECT_GE(compared, 30u);
  EXPECT_GE(with_collisions, 10u) << "the cases must include unavoidable collisions";
}

TEST(FewestCollisions, CountAndDropAreInverse) {
  // A 3-cycle s0 -> s1 -> s2 -> s0 of "must come first": any order breaks at least one; the
  // order 0,1,2 breaks exactly the relation closing the cycle.
  Matrix c(3, std::vector<char>(3, 0));
  c[1][0] = c[2][1] = c[0][2] = 1;  // 0 before 1 ok, ... 0 before 2 costs
  const BlockingGraph b = from_matrix(c);
  EXPECT_EQ(count_collisions(b, {0, 1, 2}), 1u);
  EXPECT_EQ(count_collisions(b, {2, 1, 0}), 2u);
  const CollisionOrder r = fewest_collisions(b, {});
  EXPECT_EQ(r.planned, 1u);
  EXPECT_EQ(r.lower_bound, 1u);
  ASSERT_EQ(r.parts.size(), 1u);
  EXPECT_EQ(r.parts[0].struts, 3u);
  const BlockingGraph rest = without_relations(b, r.broken);
  EXPECT_EQ(rest.relations(), 2u);
}
