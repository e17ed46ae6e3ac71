// Targets: issue 2, G-code writing at 100 MB/s or more; issue 23, G-code and CLI writing at
// 500 MB/s or more on one core. Rates are per CPU second of the writing thread (page faults of
// the fresh output included): the bench machine is shared, so wall time measures the neighbours.
// Before/after side by side: bench/compare_io.sh.
#include <benchmark/benchmark.h>
#include <sys/prctl.h>

#include <cstdlib>

#include "random_toolpath.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;

// TRELLIS_BENCH_NO_THP=1: this process gets no transparent huge pages (prctl), as when the kernel
// has none to give: what a fresh output buffer then costs.
static const bool kNoThp = [] {
  const char* v = std::getenv("TRELLIS_BENCH_NO_THP");
  return v && *v == '1' && prctl(PR_SET_THP_DISABLE, 1, 0, 0, 0) == 0;
}();

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
BENCHMARK(BM_WriteMarlin)->Unit(benchmark::kMillisecond);

// The same into one buffer kept across files (write_gcode_into): the formatting alone, without
// the kernel faulting in and zeroing a fresh output buffer each time, which costs 10-20 % of
// BM_WriteMarlin and more when no huge pages are to be had.
static void BM_WriteMarlinReused(benchmark::State& state) {
  static const Toolpath tp = bench::random_toolpath(20, 0.148, 1);
  MachineProfile p;
  p.retract_length = 0.8;
  p.z_hop = 0.2;
  std::size_t bytes = 0;
  std::string g;
  for (auto _ : state) {
    write_gcode_into(g, tp, p);
    bytes += g.size();
    benchmark::DoNotOptimize(g.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes));
}
BENCHMARK(BM_WriteMarlinReused)->Unit(benchmark::kMillisecond);

// The same paths as a laser build file (ASCII CLI: µm coordinates with two decimals), placed on
// a 250 mm plate.
static void BM_WriteCliAscii(benchmark::State& state) {
  static const Toolpath tp = bench::random_toolpath(20, 0.02, 2);
  LaserProfile laser;
  std::size_t bytes = 0;
  for (auto _ : state) {
    const std::string c = write_cli(tp, laser, CliWriteOptions{});
    bytes += c.size();
    benchmark::DoNotOptimize(c.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes));
}
BENCHMARK(BM_WriteCliAscii)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
