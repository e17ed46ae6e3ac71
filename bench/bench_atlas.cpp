// Lattice generation speed per pattern on a 50 x 50 mm region with 1 mm cells.
#include <benchmark/benchmark.h>

#include "trellis/lattice/atlas.hpp"

using namespace trellis;

static void BM_Atlas(benchmark::State& state) {
  AtlasParams a;
  a.pattern = static_cast<Pattern>(state.range(0));
  a.region.width = a.region.height = 50;
  std::size_t edges = 0;
  for (auto _ : state) edges = make_lattice2d(a).edges.size();
  state.SetLabel(to_string(a.pattern));
  state.counters["edges"] = static_cast<double>(edges);
}
BENCHMARK(BM_Atlas)->DenseRange(0, 8)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
