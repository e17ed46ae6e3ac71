// Plan shards (issue 23): a lattice planned in layer ranges and joined is, to the bit, the
// toolpath of one plan_lattice call. The one state that crosses layers is the travel order's
// start (the end of the layer below); GIPPO's and Euler's trails do not depend on it, so a shard
// plans only its own layers and order_deferred_layers finishes the order when they are joined.
#include <gtest/gtest.h>

#include <cstring>

#include "trellis/plan/plan.hpp"

using namespace trellis;

namespace {

// `layers` planar grids of n × n cells (cell 1 mm) at z = 0, 0.2, …, each shifted a little so
// layers differ; edges alternate between materials 0 and 1 when `two_materials`.
Graph layered_grids(int layers, int n, bool two_materials) {
  Graph g;
  for (int l = 0; l < layers; ++l) {
    const auto base = static_cast<NodeId>(g.nodes.size());
    const double dx = 0.13 * l, dy = 0.07 * (l % 3);
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        g.nodes.push_back({i + dx + 0.01 * ((i * j) % 5), j + dy, 0.2 * l});
    auto id = [&](int i, int j) { return base + static_cast<NodeId>(j * (n + 1) + i); };
    int k = 0;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        // A few missing struts make odd nodes, so there are many trails to order.
        if (i < n && (i + j + l) % 7 != 3)
          g.edges.push_back({id(i, j), id(i + 1, j), two_materials ? (k++ / 3) % 2 : 0});
        if (j < n && (i * j + l) % 5 != 2)
          g.edges.push_back({id(i, j), id(i, j + 1), two_materials ? (k++ / 3) % 2 : 0});
      }
  }
  return g;
}

bool same_bits(const Toolpath& a, const Toolpath& b, std::string& why) {
  if (a.layers.size() != b.layers.size()) return why = "layer count", false;
  for (std::size_t l = 0; l < a.layers.size(); ++l) {
    const auto& pa = a.layers[l].paths;
    const auto& pb = b.layers[l].paths;
    if (std::memcmp(&a.layers[l].z, &b.layers[l].z, sizeof(double)) != 0)
      return why = "z of layer " + std::to_string(l), false;
    if (pa.size() != pb.size()) return why = "paths in layer " + std::to_string(l), false;
    for (std::size_t p = 0; p < pa.size(); ++p) {
      if (pa[p].tool != pb[p].tool || pa[p].points.size() != pb[p].points.size())
        return why = "path " + std::to_string(p) + " of layer " + std::to_string(l), false;
      for (std::size_t q = 0; q < pa[p].points.size(); ++q)
        if (std::memcmp(&pa[p].points[q], &pb[p].points[q], sizeof(Vec3)) != 0)
          return why = "point " + std::to_string(q) + " of path " + std::to_string(p) +
                       " of layer " + std::to_string(l),
                 false;
    }
  }
  return true;
}

// Plans `g` in `n` contiguous layer ranges as shards do and joins them as the merge does.
Toolpath sharded(const Graph& g, PlanParams p, int n) {
  Diagnostics diag;
  const std::size_t layers = plan_layer_work(g, p).size();
  Toolpath joined;
  joined.layers.resize(layers);
  p.defer_order = layers_carry_start(p);
  for (int k = 0; k < n; ++k) {
    p.first_layer = layers * static_cast<std::size_t>(k) / static_cast<std::size_t>(n);
    p.end_layer = layers * static_cast<std::size_t>(k + 1) / static_cast<std::size_t>(n);
    const PlanResult r = plan_lattice(g, p, diag);
    EXPECT_EQ(r.toolpath.layers.size(), layers);
    for (std::size_t l = 0; l < layers; ++l) {
      if (l >= p.first_layer && l < p.end_layer)
        joined.layers[l] = r.toolpath.layers[l];
      else
        EXPECT_TRUE(r.toolpath.layers[l].paths.empty())
            << "shard " << k + 1 << " planned layer " << l;
    }
  }
  if (p.defer_order) order_deferred_layers(joined, p);
  return joined;
}

}  // namespace

TEST(PlanShard, LayerRangesJoinToTheWholePlanForEveryPlannerAndOrder) {
  for (bool two : {false, true}) {
    const Graph g = layered_grids(7, 9, two);
    for (Planner planner : {Planner::Euler, Planner::Gippo})
      for (PathOrder order : {PathOrder::Travel, PathOrder::LongestFirst}) {
        PlanParams p;
        p.planner = planner;
        p.order = order;
        p.layer_height = 0.2;
        p.gippo.iterations = 20;
        p.gippo.seed = 5;
        Diagnostics diag;
        const Toolpath whole = plan_lattice(g, p, diag).toolpath;
        ASSERT_EQ(whole.layers.size(), 7u);
        for (int n : {1, 2, 3, 7}) {
          std::string why;
          EXPECT_TRUE(same_bits(whole, sharded(g, p, n), why))
              << to_string(planner) << " " << to_string(order) << (two ? " two materials" : "")
              << ", " << n << " shards: " << why;
        }
      }
  }
}

// The travel order really carries the start across layers: ordering every layer from the
// lattice's corner instead gives another toolpath (so the test above can tell them apart).
TEST(PlanShard, TravelOrderDependsOnTheLayerBelow) {
  const Graph g = layered_grids(4, 9, false);
  PlanParams p;
  p.planner = Planner::Euler;
  p.order = PathOrder::Travel;
  p.layer_height = 0.2;
  Diagnostics diag;
  const Toolpath whole = plan_lattice(g, p, diag).toolpath;
  Toolpath independent;
  for (std::size_t l = 0; l < 4; ++l) {
    PlanParams one = p;
    one.first_layer = l, one.end_layer = l + 1;
    const PlanResult r = plan_lattice(g, one, diag);  // each layer from the corner
    independent.layers.push_back(r.toolpath.layers[l]);
  }
  std::string why;
  EXPECT_FALSE(same_bits(whole, independent, why));
}

TEST(PlanShard, LayerWorkIsEdgesPerLayer) {
  const Graph g = layered_grids(3, 4, true);
  PlanParams p;
  const auto work = plan_layer_work(g, p);
  ASSERT_EQ(work.size(), 3u);
  double sum = 0;
  for (double w : work) sum += w;
  EXPECT_EQ(sum, static_cast<double>(g.edges.size()));
}
