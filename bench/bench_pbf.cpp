// PBF paper claims and issue targets:
//  - a 4×4×4 gyroid of 2.5 mm cells, 20 µm layers (500 layers), to a CLI file in < 10 s on 2 cores;
//  - direct (field) route vs STL route (marching cubes → mesh → slice), same gyroid, 0.01 mm
//    resolution: time and peak memory side by side, for 1 to 5 cells a side (5: ~1 min and
//    ~12 GB for the STL route; the paper's O(n⁴) baseline, where each layer scans the whole
//    mesh, to 4 cells: ~85 s); and at the default 0.025 mm for 2 to 4 cells. Each route runs
//    in its own forked process so its peak RSS and CPU time are its own (wait4's rusage).
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>

#include "trellis/machine/laser.hpp"
#include "trellis/slice/pbf.hpp"

using namespace trellis;

namespace {

PbfDesign gyroid_cube(double side) {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.15"};
  d.envelope = rectprism({side, side, side});
  return d;
}

void BM_Pbf4x4x4GyroidToCli(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const PbfDesign d = gyroid_cube(10);
  PbfOptions o;  // 20 µm layers, 0.02 mm grid
  const LaserProfile prof;
  for (auto _ : state) {
    const PbfResult r = plan_pbf(d, o);
    const Toolpath tp =
        pbf_toolpath(r, prof.contour_power, prof.contour_speed, prof.hatch_power, prof.hatch_speed);
    const std::string cli = write_cli(tp, prof);
    state.counters["layers"] = static_cast<double>(r.layers.size());
    state.counters["vectors"] = static_cast<double>(r.contour_vectors + r.hatch_vectors);
    state.counters["cli_MB"] = static_cast<double>(cli.size()) / 1e6;
  }
}

// Runs one route in a child process; reports its wall time and peak RSS.
enum class Route { Direct, Stl, StlScanAll };
void route(benchmark::State& state, Route which, double resolution = 0.01) {
  const double side = 2.5 * static_cast<double>(state.range(0));
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = fork();
    if (pid == 0) {
      PbfOptions o;
      o.resolution = resolution;
      o.stl_route = which != Route::Direct;
      o.test.stl_scan_all = which == Route::StlScanAll;
      const PbfResult r = plan_pbf(gyroid_cube(side), o);
      std::_Exit(r.layers.empty() ? 1 : 0);
    }
    int status = 0;
    rusage ru{};
    wait4(pid, &status, 0, &ru);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(s);
    state.counters["peak_MB"] = static_cast<double>(ru.ru_maxrss) / 1024.0;
    // The child's CPU time (user + system, all its threads): steadier than wall time on a
    // shared machine.
    state.counters["cpu_s"] = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                              1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) state.SkipWithError("child failed");
  }
}
void BM_DirectRoute(benchmark::State& state) {
  route(state, Route::Direct);
}
void BM_StlRoute(benchmark::State& state) {
  route(state, Route::Stl);
}
// The STL route as the paper counts it: each layer scans the whole mesh.
void BM_StlRouteScanAll(benchmark::State& state) {
  route(state, Route::StlScanAll);
}
// At the default resolution (0.025 mm), where the shared per-layer work weighs more.
void BM_DirectRouteDefault(benchmark::State& state) {
  route(state, Route::Direct, 0.025);
}
void BM_StlRouteDefault(benchmark::State& state) {
  route(state, Route::Stl, 0.025);
}

}  // namespace

// The forked benchmarks run first, before anything starts oneTBB's threads in this process.
BENCHMARK(BM_DirectRoute)
    ->DenseRange(1, 5)
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);
BENCHMARK(BM_StlRoute)->DenseRange(1, 5)->Iterations(1)->UseManualTime()->Unit(benchmark::kSecond);
BENCHMARK(BM_StlRouteScanAll)
    ->DenseRange(1, 4)
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);
BENCHMARK(BM_DirectRouteDefault)
    ->DenseRange(2, 4)
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);
BENCHMARK(BM_StlRouteDefault)
    ->DenseRange(2, 4)
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);
BENCHMARK(BM_Pbf4x4x4GyroidToCli)->Arg(2)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

BENCHMARK_MAIN();
