// Target (issue 5): reading and measuring G-code at 200 MB/s or more on one core.
#include <benchmark/benchmark.h>

#include "trellis/analysis/metrics.hpp"
#include "random_toolpath.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;

static const std::string& sample_gcode() {
  static const std::string g = [] {
    const Toolpath tp = bench::random_toolpath(10, 0.2, 3);
    MachineProfile p;
    p.retract_length = 0.8;
    return write_gcode(tp, p);
  }();
  return g;
}

static void BM_ScanCounts(benchmark::State& state) {
  const std::string& g = sample_gcode();
  for (auto _ : state) {
    Diagnostics d;
    CountingSink sink;
    GcodeScanner scanner(sink, {}, d);
    scanner.feed(g);
    scanner.finish();
    benchmark::DoNotOptimize(sink.counts.extruded_length);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(g.size()) * state.iterations());
}
BENCHMARK(BM_ScanCounts)->Unit(benchmark::kMillisecond);

static void BM_ReadToIR(benchmark::State& state) {
  const std::string& g = sample_gcode();
  for (auto _ : state) {
    Diagnostics d;
    benchmark::DoNotOptimize(read_gcode(g, {}, d).layers.size());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(g.size()) * state.iterations());
}
BENCHMARK(BM_ReadToIR)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
