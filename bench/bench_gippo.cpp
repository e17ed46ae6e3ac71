// Target (issue 2): GIPPO, 500 iterations on a 10,000-edge honeycomb, under 0.5 s on 2 cores.
#include <benchmark/benchmark.h>

#include "trellis/lattice/atlas.hpp"
#include "trellis/plan/gippo.hpp"

using namespace trellis;

static Graph honeycomb_edges(std::size_t target) {
  AtlasParams a;
  a.cell_size = 1.0;
  double w = 20;
  Graph g;
  for (int i = 0; i < 40; ++i) {
    a.region.width = a.region.height = w;
    g = make_lattice2d(a);
    if (g.edges.size() >= target) break;
    w *= 1.05;
  }
  return g;
}

static void BM_Gippo500(benchmark::State& state) {
  static const Graph g = honeycomb_edges(10000);
  GippoParams p;
  p.iterations = 500;
  RunContext context;
  context.threads = static_cast<int>(state.range(0));
  p.mode = GippoMode::Max;
  for (auto _ : state) benchmark::DoNotOptimize(plan_gippo(g, p, context).best.trails.size());
  state.counters["edges"] = static_cast<double>(g.edges.size());
  state.counters["iterations/s"] =
      benchmark::Counter(500.0 * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Gippo500)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
