// Target (issue 2): Euler planner on a 1,000,000-edge lattice under 1 s.
#include <benchmark/benchmark.h>

#include "trellis/plan/euler.hpp"

using namespace trellis;

// A triangulated grid (degree 6 inside, odd nodes on the border) with about `edges` edges.
static Graph grid(std::size_t edges) {
  const auto n = static_cast<NodeId>(std::sqrt(edges / 3.0)) + 1;
  Graph g;
  for (NodeId j = 0; j < n; ++j)
    for (NodeId i = 0; i < n; ++i) g.nodes.push_back({double(i), double(j), 0});
  for (NodeId j = 0; j < n; ++j)
    for (NodeId i = 0; i < n; ++i) {
      const NodeId v = j * n + i;
      if (i + 1 < n) g.edges.push_back({v, v + 1});
      if (j + 1 < n) g.edges.push_back({v, v + n});
      if (i + 1 < n && j + 1 < n) g.edges.push_back({v, v + n + 1});
    }
  // Remove every 7th edge to make many odd nodes.
  std::vector<Edge> kept;
  for (std::size_t e = 0; e < g.edges.size(); ++e)
    if (e % 7 != 3) kept.push_back(g.edges[e]);
  g.edges = std::move(kept);
  return g;
}

static void BM_Euler(benchmark::State& state) {
  static const Graph g = grid(1'170'000);
  for (auto _ : state) benchmark::DoNotOptimize(plan_euler(g).trails.size());
  state.counters["edges"] = static_cast<double>(g.edges.size());
  state.counters["lower_bound"] = static_cast<double>(lower_bound_paths(g));
}
BENCHMARK(BM_Euler)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
