// The Progress contract per planning route: a cancel flag set from the progress callback, or
// from another thread, stops the call with Cancelled; without it the same call finishes.
#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <thread>

#include "support/cancel.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/lattice/cells3d.hpp"
#include "trellis/plan/aero.hpp"
#include "trellis/plan/plan.hpp"

using namespace trellis;
using test::CancelAt;

namespace {

Graph honeycomb(double width) {
  AtlasParams a;
  a.region.width = a.region.height = width;
  return make_lattice2d(a);
}

// Two planar layers (the honeycomb and a copy 1 mm higher): plan_lattice plans two parts.
Graph two_layers() {
  Graph g = honeycomb(10);
  const std::size_t n = g.nodes.size(), m = g.edges.size();
  for (std::size_t i = 0; i < n; ++i) g.nodes.push_back(g.nodes[i] + Vec3{0, 0, 1});
  for (std::size_t e = 0; e < m; ++e) {
    Edge copy = g.edges[e];
    copy.a += static_cast<NodeId>(n);
    copy.b += static_cast<NodeId>(n);
    g.edges.push_back(copy);
  }
  return g;
}

}  // namespace

TEST(Cancel, GippoStopsWhenTheCallbackCancels) {
  GippoParams p;
  p.iterations = 5000;
  RunContext context;
  context.threads = 2;
  CancelAt c("gippo");
  context.progress = c.progress;
  EXPECT_THROW(plan_gippo(honeycomb(10), p, context), Cancelled);
  // Reported every n/50 iterations: cancelled at the first, it stops long before the end.
  for (const auto& [stage, f] : c.reports()) EXPECT_LT(f, 0.5);
  context.progress = {};
  EXPECT_EQ(plan_gippo(honeycomb(10), p, context).scores.size(), 5000u);
}

TEST(Cancel, GippoStopsWhenAnotherThreadCancels) {
  GippoParams p;
  p.iterations = 200000;  // far longer than the test waits
  RunContext context;
  context.threads = 1;
  std::atomic<bool> flag{false};
  std::promise<void> started;
  std::atomic<bool> once{false};
  context.progress.cancel = &flag;
  context.progress.report = [&](const std::string&, double) {
    if (!once.exchange(true)) started.set_value();
  };
  const Graph g = honeycomb(10);
  auto work = std::async(std::launch::async, [&] { return plan_gippo(g, p, context); });
  started.get_future().wait();
  const auto t0 = std::chrono::steady_clock::now();
  flag = true;
  EXPECT_THROW(work.get(), Cancelled);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(2));
}

TEST(Cancel, PlanLatticeStopsPerLayerForEulerAndGippo) {
  const Graph g = two_layers();
  for (Planner planner : {Planner::Euler, Planner::Gippo}) {
    PlanParams p;
    p.planner = planner;
    p.gippo.iterations = 50;
    Diagnostics d;
    CancelAt c;  // cancels at the first report, i.e. within the first layer
    EXPECT_THROW(plan_lattice(g, p, d, RunContext{c.progress}), Cancelled) << to_string(planner);
    for (const auto& [stage, f] : c.reports()) EXPECT_LE(f, 0.5) << stage;
    Diagnostics d2;
    EXPECT_EQ(plan_lattice(g, p, d2).layers.size(), 2u);
  }
}

TEST(Cancel, AeroStopsWhenTheCallbackCancels) {
  const Graph g = cell_lattice({unit_cell_from_string("octet"), 7, 3, 3, 3});
  AeroParams p;
  p.tries = 8;
  RunContext context;
  context.threads = 1;
  CancelAt c("tries");  // after the first of eight portfolio runs
  context.progress = c.progress;
  Diagnostics d;
  EXPECT_THROW(plan_aero(g, p, d, context), Cancelled);
  std::size_t runs = 0;
  for (const auto& [stage, f] : c.reports()) runs += stage == "tries";
  EXPECT_LT(runs, 8u);
  context.progress = {};
  Diagnostics d2;
  EXPECT_EQ(plan_aero(g, p, d2, context).runs, 8u);
}
