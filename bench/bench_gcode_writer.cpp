// Targets: issue 2, G-code writing at 100 MB/s or more; issue 23, G-code and CLI writing at
// 500 MB/s or more on one core; issue 40, 1 GB/s or more, next to the floor of copying the same
// bytes (BM_CopySameBytes: memcpy into a kept buffer; BM_WriteSameBytes: write() into a file,
// i.e. into the page cache). The load average is printed with the context. Rates are per CPU second
// of the whole process (page faults of the fresh output included; a large print's time estimate
// runs on a second thread, whose CPU counts too): the bench machine is shared, so wall time
// measures the neighbours (the Time column). Before/after side by side: bench/compare_io.sh.
#include <benchmark/benchmark.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

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
BENCHMARK(BM_WriteMarlin)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

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
BENCHMARK(BM_WriteMarlinReused)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

// The bytes BM_WriteMarlin writes, made once.
static const std::string& marlin_bytes() {
  static const std::string g = [] {
    MachineProfile p;
    p.retract_length = 0.8;
    p.z_hop = 0.2;
    return write_gcode(bench::random_toolpath(20, 0.148, 1), p);
  }();
  return g;
}

// The floor: the same bytes copied into a buffer kept across iterations.
static void BM_CopySameBytes(benchmark::State& state) {
  const std::string& g = marlin_bytes();
  std::string out(g.size(), '\0');
  for (auto _ : state) {
    std::memcpy(out.data(), g.data(), g.size());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(g.size()) * state.iterations());
}
BENCHMARK(BM_CopySameBytes)->Unit(benchmark::kMillisecond);

// The same bytes written (1 MB write() calls) into a file in $TMPDIR, unlinked at once: what
// the kernel takes to copy them into the page cache.
static void BM_WriteSameBytes(benchmark::State& state) {
  const std::string& g = marlin_bytes();
  const char* tmp = std::getenv("TMPDIR");
  std::string name = std::string(tmp ? tmp : "/tmp") + "/trellis_bench_write_XXXXXX";
  const int fd = mkstemp(name.data());
  if (fd < 0) return state.SkipWithError("cannot create a temporary file");
  unlink(name.c_str());
  for (auto _ : state) {
    if (ftruncate(fd, 0) != 0 || lseek(fd, 0, SEEK_SET) != 0)
      return state.SkipWithError("cannot truncate the temporary file");
    for (std::size_t at = 0; at < g.size();) {
      const ssize_t n = write(fd, g.data() + at, std::min<std::size_t>(g.size() - at, 1 << 20));
      if (n <= 0) return state.SkipWithError("cannot write the temporary file");
      at += static_cast<std::size_t>(n);
    }
  }
  close(fd);
  state.SetBytesProcessed(static_cast<std::int64_t>(g.size()) * state.iterations());
}
BENCHMARK(BM_WriteSameBytes)->Unit(benchmark::kMillisecond);

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
BENCHMARK(BM_WriteCliAscii)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  double load[3] = {};
  if (getloadavg(load, 3) == 3) {
    char text[64];
    std::snprintf(text, sizeof text, "%.2f %.2f %.2f (%ld cores)", load[0], load[1], load[2],
                  sysconf(_SC_NPROCESSORS_ONLN));
    benchmark::AddCustomContext("load average", text);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
