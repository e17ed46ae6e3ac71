// Targets: issue 5, reading and measuring G-code at 200 MB/s or more on one core; issue 23,
// scanning at 800 MB/s or more on one core, next to `wc -l` on the same file (the I/O ceiling);
// issue 40, within 2 x `cat` (BM_ScanFile / BM_Cat; bench/scan_vs_cat.sh prints the ratios).
// Rates of the file benchmarks are per CPU second (user + system) of the whole process (every
// thread the reader uses), and of the `wc -l` / `cat` child for the ceiling: the bench machine
// is shared, so wall time measures the neighbours (it is reported beside, as the counter
// wall_ms). BM_ScanFile is analyze's pass, BM_ViewScan view's (counts and the IR in one pass),
// BM_CheckScan check's (the IR layer by layer); bench/io_vs_cat.sh runs them against cat. The large
// file is TRELLIS_BENCH_GCODE if set, else a ~213 MB file of Trellis' own Marlin G-code (travels,
// retractions, ;TYPE: and ;WIDTH: comments) written once into $TMPDIR (and unlinked at once).
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>

#include "random_toolpath.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"

extern char** environ;

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

namespace {

struct LargeFile {
  std::string path;
  int fd = -1;
  std::uintmax_t bytes = 0;
  LargeFile() {
    if (const char* env = std::getenv("TRELLIS_BENCH_GCODE")) {
      path = env;
    } else {
      // Written, then unlinked at once: read through /proc/self/fd (the wc child inherits the
      // descriptor), so no file is left behind however the benchmark ends.
      const char* tmp = std::getenv("TMPDIR");
      const std::string name = std::string(tmp ? tmp : "/tmp") + "/trellis_bench_gcode_" +
                               std::to_string(getpid()) + ".gcode";
      {
        std::ofstream out(name, std::ios::binary);
        MachineProfile p;
        p.retract_length = 0.8;
        p.z_hop = 0.2;
        // 16 pieces of 8 layers, each its own seed: ~213 MB.
        for (std::uint64_t seed = 1; seed <= 16; ++seed)
          out << write_gcode(bench::random_toolpath(8, 0.2, seed), p);
      }
      fd = open(name.c_str(), O_RDONLY);
      std::remove(name.c_str());
      path = "/proc/self/fd/" + std::to_string(fd);
    }
    bytes = std::filesystem::file_size(path);
  }
  ~LargeFile() {
    if (fd >= 0) close(fd);
  }
};

const LargeFile& large_file() {
  static const LargeFile f;
  return f;
}

double clock_seconds(clockid_t clock) {
  timespec t{};
  clock_gettime(clock, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Times `fn` per iteration as the process' CPU time (all threads), wall time as a counter.
template <class Fn>
void timed_file_pass(benchmark::State& state, Fn fn) {
  const LargeFile& f = large_file();
  double wall = 0;
  for (auto _ : state) {
    const double c0 = clock_seconds(CLOCK_PROCESS_CPUTIME_ID), w0 = clock_seconds(CLOCK_MONOTONIC);
    fn(f.path);
    wall += clock_seconds(CLOCK_MONOTONIC) - w0;
    state.SetIterationTime(clock_seconds(CLOCK_PROCESS_CPUTIME_ID) - c0);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(f.bytes) * state.iterations());
  state.counters["MB"] = static_cast<double>(f.bytes) / 1e6;
  state.counters["wall_ms"] = 1e3 * wall / static_cast<double>(state.iterations());
}

double seconds(const timeval& t) {
  return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
}

}  // namespace

// The whole file through the streaming reader into the counts (trellis analyze's pass).
static void BM_ScanFile(benchmark::State& state) {
  timed_file_pass(state, [](const std::string& path) {
    Diagnostics d;
    CountingSink sink;
    scan_gcode_file(path, sink, {}, d);
    sink.finish();
    benchmark::DoNotOptimize(sink.counts.extruded_length);
  });
}
BENCHMARK(BM_ScanFile)->Unit(benchmark::kMillisecond)->UseManualTime();

// trellis view's pass: the counts and the IR (commanded mixtures kept beside) in one pass.
static void BM_ViewScan(benchmark::State& state) {
  timed_file_pass(state, [](const std::string& path) {
    Diagnostics d;
    CountingSink counter;
    GcodeRead r = read_gcode_file(path, {}, d, &counter, true);
    counter.finish();
    benchmark::DoNotOptimize(r.toolpath.layers.size());
  });
}
BENCHMARK(BM_ViewScan)->Unit(benchmark::kMillisecond)->UseManualTime();

// trellis check's pass: the IR layer by layer (each let go once visited).
static void BM_CheckScan(benchmark::State& state) {
  timed_file_pass(state, [](const std::string& path) {
    Diagnostics d;
    std::size_t paths = 0;
    scan_gcode_layers(path, {}, d, [&](std::size_t, const Layer& l) { paths += l.paths.size(); });
    benchmark::DoNotOptimize(paths);
  });
}
BENCHMARK(BM_CheckScan)->Unit(benchmark::kMillisecond)->UseManualTime();

// The I/O ceilings: `wc -l` and `cat > /dev/null` on the same file, their CPU time (user +
// system) from wait4. Issue 40's target: BM_ScanFile within 2 x BM_Cat.
static void run_child(benchmark::State& state, const char* tool, const char* flag) {
  const LargeFile& f = large_file();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  for (auto _ : state) {
    std::string arg0 = tool, arg1 = flag ? flag : "", file = f.path;
    char* argv[] = {arg0.data(), flag ? arg1.data() : file.data(), flag ? file.data() : nullptr,
                    nullptr};
    pid_t pid = 0;
    if (posix_spawnp(&pid, tool, &actions, nullptr, argv, environ) != 0) {
      state.SkipWithError("cannot run the tool");
      break;
    }
    int status = 0;
    rusage usage{};
    wait4(pid, &status, 0, &usage);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      state.SkipWithError("the tool failed");
      break;
    }
    state.SetIterationTime(seconds(usage.ru_utime) + seconds(usage.ru_stime));
  }
  posix_spawn_file_actions_destroy(&actions);
  state.SetBytesProcessed(static_cast<std::int64_t>(f.bytes) * state.iterations());
  state.counters["MB"] = static_cast<double>(f.bytes) / 1e6;
}
static void BM_WcL(benchmark::State& state) {
  run_child(state, "wc", "-l");
}
BENCHMARK(BM_WcL)->Unit(benchmark::kMillisecond)->UseManualTime();
static void BM_Cat(benchmark::State& state) {
  run_child(state, "cat", nullptr);
}
BENCHMARK(BM_Cat)->Unit(benchmark::kMillisecond)->UseManualTime();

BENCHMARK_MAIN();
