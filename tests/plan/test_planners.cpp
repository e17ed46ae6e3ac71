#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "support/random_graphs.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/plan/euler.hpp"
#include "trellis/plan/gippo.hpp"
#include "trellis/plan/order.hpp"

using namespace trellis;
using test::random_graph;
using test::random_planar_graph;

namespace {

// The paper's Algorithm 1 written plainly from its text, sharing nothing with the planner but
// the documented random stream: O(E) scans, no adjacency lists, no cursors, no Fenwick tree.
struct Reference {
  double best = -1;
  std::size_t best_k = 0;
  std::size_t best_paths = 0;
};

// Eq. 1 written out: Σ (trail length × its struts) / (total length × trails), the lengths
// measured from the graph's nodes along each trail's edges.
double score_from_graph(const Graph& g, const PathSet& s) {
  double weighted = 0, total = 0;
  for (const auto& t : s.trails) {
    double len = 0;
    for (std::size_t i = 0; i < t.edges.size(); ++i) {
      const Edge& e = g.edges[t.edges[i]];
      len += std::sqrt(dot(g.nodes[e.b] - g.nodes[e.a], g.nodes[e.b] - g.nodes[e.a]));
    }
    weighted += len * static_cast<double>(t.edges.size());
    total += len;
  }
  return weighted / (total * static_cast<double>(s.trails.size()));
}

Reference reference_gippo(const Graph& g, bool max_mode, std::uint64_t seed, int iterations) {
  const double total = g.total_length();
  Reference ref;
  for (int k = 0; k < iterations; ++k) {
    Rng rng = Rng::stream(seed, static_cast<std::uint64_t>(k));
    std::vector<bool> used(g.edges.size(), false);
    auto key = [&](EdgeId e) { return gippo_length_key(g.edge_length(e)); };
    // Every unused edge at v with the best length, in ascending edge id.
    auto best_at = [&](NodeId v) {
      std::vector<EdgeId> out;
      for (EdgeId e = 0; e < g.edges.size(); ++e) {
        if (used[e] || (g.edges[e].a != v && g.edges[e].b != v)) continue;
        if (out.empty() || key(e) == key(out[0])) {
          out.push_back(e);
        } else if (max_mode ? key(e) > key(out[0]) : key(e) < key(out[0])) {
          out = {e};
        }
      }
      return out;
    };
    double weighted = 0;
    std::size_t paths = 0;
    while (true) {
      std::vector<NodeId> incomplete;
      for (NodeId v = 0; v < g.nodes.size(); ++v)
        if (!best_at(v).empty()) incomplete.push_back(v);
      if (incomplete.empty()) break;
      NodeId front = incomplete[rng.uniform_index(incomplete.size())], back = front;
      double len = 0;
      std::size_t edges = 0;
      while (true) {
        const auto cf = best_at(front), cb = best_at(back);
        if (cf.empty() && cb.empty()) break;
        std::int64_t best_key = cf.empty() ? key(cb[0]) : key(cf[0]);
        if (!cf.empty() && !cb.empty())
          best_key = max_mode ? std::max(key(cf[0]), key(cb[0])) : std::min(key(cf[0]), key(cb[0]));
        std::vector<std::pair<EdgeId, bool>> cand;  // (edge, at the back)
        if (!cf.empty() && key(cf[0]) == best_key)
          for (EdgeId e : cf) cand.push_back({e, false});
        if (!cb.empty() && key(cb[0]) == best_key && back != front)
          for (EdgeId e : cb)
            if (std::none_of(cand.begin(), cand.end(), [&](auto& c) { return c.first == e; }))
              cand.push_back({e, true});
        const auto [e, at_back] = cand.size() == 1 ? cand[0] : cand[rng.uniform_index(cand.size())];
        used[e] = true;
        len += g.edge_length(e);
        ++edges;
        if (at_back)
          back = g.edges[e].other(back);
        else
          front = g.edges[e].other(front);
      }
      weighted += len * static_cast<double>(edges);
      ++paths;
    }
    const double score = weighted / (total * static_cast<double>(paths));
    if (score > ref.best) {
      ref.best = score;
      ref.best_k = static_cast<std::size_t>(k);
      ref.best_paths = paths;
    }
  }
  return ref;
}

Graph honeycomb(double width) {
  AtlasParams a;
  a.region.width = a.region.height = width;
  a.rotation_deg = 13;  // equal struts now differ in their last bits: ties must still be ties
  return make_lattice2d(a);
}

}  // namespace

TEST(Euler, ExactlyTheLowerBoundOnManyGraphs) {
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const Graph g = seed % 2 ? random_planar_graph(seed, 3 + seed % 7, 4 + seed % 5)
                             : random_graph(seed, 5 + seed % 30, 4 + seed % 60);
    if (g.edges.empty()) continue;
    const PathSet s = plan_euler(g);
    ASSERT_EQ(validate_paths(g, s), "") << "seed " << seed;
    ASSERT_EQ(s.trails.size(), lower_bound_paths(g)) << "seed " << seed;
  }
}

TEST(Euler, ClosedCircuitForEvenGraphAndAllAtlasPatterns) {
  Graph square;
  square.nodes = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  square.edges = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
  const PathSet s = plan_euler(square);
  ASSERT_EQ(s.trails.size(), 1u);
  EXPECT_EQ(s.trails[0].nodes.front(), s.trails[0].nodes.back());
  for (const auto& name : pattern_names()) {
    AtlasParams a;
    a.pattern = pattern_from_string(name);
    a.contour = true;
    const Graph g = make_lattice2d(a);
    const PathSet p = plan_euler(g);
    ASSERT_EQ(validate_paths(g, p), "") << name;
    EXPECT_EQ(p.trails.size(), lower_bound_paths(g)) << name;
  }
}

TEST(Gippo, EveryIterationCoversEveryEdgeOnce) {
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    const Graph g = seed % 2 ? random_planar_graph(seed) : random_graph(seed, 20, 45);
    for (auto mode : {GippoMode::Max, GippoMode::Min}) {
      const PathSet s = gippo_iteration(g, mode, seed, 3);
      ASSERT_EQ(validate_paths(g, s), "") << "seed " << seed;
      ASSERT_GE(s.trails.size(), lower_bound_paths(g));
      // Eq. 1 from the graph's geometry, not from the trails' cached lengths.
      EXPECT_NEAR(gippo_score(s), score_from_graph(g, s), 1e-12 * gippo_score(s));
    }
  }
}

TEST(Gippo, BestScoreMatchesAnIndependentImplementation) {
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    const Graph g = seed % 3 == 0   ? honeycomb(5)
                    : seed % 3 == 1 ? random_planar_graph(seed, 6, 5)
                                    : random_graph(seed, 15, 30);
    for (bool max_mode : {true, false}) {
      GippoParams p;
      p.mode = max_mode ? GippoMode::Max : GippoMode::Min;
      p.iterations = 40;
      p.seed = seed;
      const GippoResult r = plan_gippo(g, p);
      const Reference ref = reference_gippo(g, max_mode, seed, p.iterations);
      ASSERT_DOUBLE_EQ(*std::max_element(r.scores.begin(), r.scores.end()), ref.best)
          << "seed " << seed;
      EXPECT_EQ(r.best_iteration, ref.best_k) << "seed " << seed;
      EXPECT_EQ(r.best.trails.size(), ref.best_paths);
      EXPECT_DOUBLE_EQ(gippo_score(r.best), ref.best);
      EXPECT_EQ(validate_paths(g, r.best), "");
      EXPECT_LE(gippo_score(r.worst), gippo_score(r.best));
    }
  }
}

TEST(Gippo, TranslatedCopyIsPlannedAlike) {
  AtlasParams a;
  a.pattern = Pattern::Penrose;
  a.region.width = a.region.height = 8;
  const Graph g = make_lattice2d(a);
  Graph moved = g;  // the same struts, moved far away: lengths change in their last bits
  for (auto& n : moved.nodes) n = n + Vec3{123.456, -78.9, 0};
  GippoParams p;
  p.iterations = 50;
  const GippoResult a1 = plan_gippo(g, p), a2 = plan_gippo(moved, p);
  EXPECT_EQ(a1.best_iteration, a2.best_iteration);
  ASSERT_EQ(a1.best.trails.size(), a2.best.trails.size());
  for (std::size_t i = 0; i < a1.best.trails.size(); ++i)
    EXPECT_EQ(a1.best.trails[i].nodes, a2.best.trails[i].nodes);
  for (std::size_t k = 0; k < a1.scores.size(); ++k) EXPECT_NEAR(a1.scores[k], a2.scores[k], 1e-12);
}

TEST(Gippo, SameResultForAnyThreadCount) {
  const Graph g = honeycomb(12);
  GippoParams p;
  p.iterations = 64;
  p.seed = 99;
  RunContext context;
  context.threads = 1;
  const GippoResult one = plan_gippo(g, p, context);
  context.threads = 2;
  const GippoResult two = plan_gippo(g, p, context);
  context.threads = 4;
  const GippoResult four = plan_gippo(g, p, context);
  EXPECT_EQ(one.scores, two.scores);
  EXPECT_EQ(one.scores, four.scores);
  EXPECT_EQ(one.best_iteration, two.best_iteration);
  ASSERT_EQ(one.best.trails.size(), four.best.trails.size());
  for (std::size_t i = 0; i < one.best.trails.size(); ++i) {
    EXPECT_EQ(one.best.trails[i].nodes, two.best.trails[i].nodes);
    EXPECT_EQ(one.best.trails[i].nodes, four.best.trails[i].nodes);
  }
}

TEST(Gippo, MetricsFollowThePaperEquations) {
  Graph g;
  g.nodes = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}, {0, 5, 0}, {0, 7, 0}};
  g.edges = {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {5, 6}};
  PathSet s;
  s.trails.push_back({{0, 1, 2, 3, 4}, {0, 1, 2, 3}, 4.0});
  s.trails.push_back({{5, 6}, {4}, 2.0});
  const PathMetrics m = path_metrics(g, s);
  EXPECT_DOUBLE_EQ(m.score, (4.0 * 4 + 2.0 * 1) / (6.0 * 2));  // Eq. 1
  EXPECT_DOUBLE_EQ(m.lts, 100 * 4.0 / 6.0);                    // Eq. 2: one long path (5 nodes)
  EXPECT_DOUBLE_EQ(m.oe, 100 * (4.0 * 4) / (6.0 * 5));         // Eq. 3
  EXPECT_EQ(m.lower_bound_paths, 2u);
  EXPECT_EQ(m.medium_paths, 1u);
  EXPECT_EQ(m.short_paths, 1u);
}

TEST(Gippo, RejectsEmptyGraphsAndBadSettings) {
  Graph g;
  EXPECT_THROW(plan_gippo(g, {}), GeometryError);
  g = random_planar_graph(1);
  GippoParams p;
  p.iterations = 0;
  EXPECT_THROW(plan_gippo(g, p), SettingError);
}

TEST(Order, TravelOrderKeepsPathsValidAndBeatsLongestFirst) {
  int better = 0, total = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const Graph g = random_planar_graph(seed, 10, 10, 0.6);
    PathSet a = plan_euler(g), b = a;
    order_paths(g, a, PathOrder::LongestFirst, {0, 0, 0});
    order_paths(g, b, PathOrder::Travel, {0, 0, 0});
    ASSERT_EQ(validate_paths(g, a), "");
    ASSERT_EQ(validate_paths(g, b), "");
    for (std::size_t i = 1; i < a.trails.size(); ++i)
      ASSERT_GE(a.trails[i - 1].edges.size(), a.trails[i].edges.size());
    ++total;
    better += travel_length(g, b) < travel_length(g, a);
  }
  EXPECT_EQ(better, total);
}

// plan.merge_ends: joins trails that end at one node and splices closed trails into a trail
// through one of their nodes; the result still covers every edge once, and on GIPPO's trails of
// the atlas patterns it never adds paths and reaches the lower bound where GIPPO stopped above it.
TEST(MergeEnds, JoinsSharedEndsAndSplicesLoopsKeepingEveryEdgeOnce) {
  // A path 0-1-2 and a path 2-3 share node 2; a path 3-5 shares node 3 with that; a triangle
  // 4-5-6-4 hangs off node 5.
  Graph g;
  for (int i = 0; i < 7; ++i) g.nodes.push_back({static_cast<double>(i), 0, 0});
  auto edge = [&](int a, int b) {
    Edge e;
    e.a = static_cast<NodeId>(a);
    e.b = static_cast<NodeId>(b);
    g.edges.push_back(e);
    return static_cast<EdgeId>(g.edges.size() - 1);
  };
  const EdgeId e01 = edge(0, 1), e12 = edge(1, 2), e23 = edge(2, 3), e45 = edge(4, 5),
               e56 = edge(5, 6), e64 = edge(6, 4), e35 = edge(3, 5);
  PathSet set;
  set.trails.push_back({{0, 1, 2}, {e01, e12}, 2});
  set.trails.push_back({{3, 2}, {e23}, 1});
  set.trails.push_back({{4, 5, 6, 4}, {e45, e56, e64}, 3});
  set.trails.push_back({{3, 5}, {e35}, 1});
  ASSERT_EQ(validate_paths(g, set), "");
  EXPECT_EQ(merge_shared_ends(set), 3u);  // 0-1-2 + 3-2; the loop into 3-5; then both at 3
  EXPECT_EQ(set.trails.size(), 1u);
  EXPECT_EQ(validate_paths(g, set), "");
  // Random graphs: every edge once, count falls by the joins, never below the lower bound.
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    const Graph r = random_graph(seed, 40, 70);
    GippoParams gp;
    gp.iterations = 5;
    gp.seed = seed;
    PathSet s = plan_gippo(r, gp).best;
    const std::size_t before = s.trails.size();
    const std::size_t joins = merge_shared_ends(s);
    EXPECT_EQ(validate_paths(r, s), "") << seed;
    EXPECT_EQ(s.trails.size(), before - joins) << seed;
    EXPECT_GE(s.trails.size(), lower_bound_paths(r)) << seed;
  }
  // The Ø48 mm arrowhead: GIPPO stops above the bound, the merge reaches it.
  AtlasParams a;
  a.pattern = Pattern::Arrowhead;
  a.region.shape = RegionShape::Circle;
  a.region.diameter = 48;
  const Graph arrow = make_lattice2d(a);
  GippoParams gp;
  gp.iterations = 20;
  PathSet s = plan_gippo(arrow, gp).best;
  const std::size_t before = s.trails.size();
  merge_shared_ends(s);
  EXPECT_EQ(validate_paths(arrow, s), "");
  EXPECT_LT(s.trails.size(), before);
  EXPECT_EQ(s.trails.size(), lower_bound_paths(arrow));
}
