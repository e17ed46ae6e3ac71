// Target (issue 2): G-code writing at 100 MB/s or more.
#include <benchmark/benchmark.h>

#include "random_toolpath.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;

static void BM_WriteMarlin(benchmark::State& state) {
  static const Toolpath tp = bench::random_toolpath(20, 0.148, 1);
  MachineProfile p;
  p.retract_length = 0.8;
  p.z_hop = 0.2;
  std::size_t bytes = 0;
  for (auto _ : state) {
    const std::string g = write_gcode(tp, p);
    bytes += g.size();
    benchmark::DoNotOptimize(g.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes));
}
BENCHMARK(BM_WriteMarlin)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
