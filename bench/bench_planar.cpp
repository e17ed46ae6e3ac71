// Issue 40: the planar slicer at a fraction of PrusaSlicer's time (bench/continuous_paths.sh
// compares the two on the same meshes). Here the parts on their own:
// - BM_SliceMesh/threads: a mesh outlined, planned and linked (stream_slice, as `trellis slice`
//   does before writing), CPU and wall time;
// - BM_SliceScaling: the same with 1 and 2 threads, interleaved, the speed-up of the minima
//   (target: 2 threads at least 1.7 times as fast as one on a quiet machine);
// - BM_Thumbnails: the G-code thumbnails of the sliced mesh, as a share of its slicing CPU time
//   (target: 3 % or less);
// - BM_PlanarPlateHoles/holes: walls, skins and infill of a plate with many round holes (Clipper's
//   PolyTree nesting was quadratic in the holes).
// Every benchmark reads /proc/stat before and after: when other processes took more than 5 % of
// a core over the run, its label says the machine was not quiet and by how much.
// The mesh: $TRELLIS_BENCH_MESH (e.g. the half-scale TR12J_OCC.stl continuous_paths.sh makes),
// else examples/designs/Vase.stl.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <string>

#include "trellis/job/job.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/slice/pipeline.hpp"
#include "trellis/slice/slice.hpp"

using namespace trellis;

namespace {

std::string mesh_path() {
  const char* env = std::getenv("TRELLIS_BENCH_MESH");
  return env && *env ? env : std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/Vase.stl";
}

SliceJob mesh_job() {
  SliceJob job;
  job.input = mesh_path();
  job.planar.layer_height = 0.2;
  job.planar.bead_width = 0.4;
  return job;
}

double own_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// CPU seconds every process of the machine has run (the first line of /proc/stat).
double machine_cpu_seconds() {
  std::ifstream stat("/proc/stat");
  std::string cpu;
  double user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
  stat >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal;
  return (user + nice + system + irq + softirq + steal) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// What other processes ran while a benchmark did (CPU seconds), and the wall time it took.
class Neighbours {
 public:
  Neighbours() : machine_(machine_cpu_seconds()), own_(own_cpu_seconds()) {}
  double others() const {
    return std::max(0.0, machine_cpu_seconds() - machine_ - (own_cpu_seconds() - own_));
  }
  double wall() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }
  // Reported as counters, and a label when the machine was not quiet.
  void report(benchmark::State& state) const {
    const double o = others(), w = wall();
    state.counters["others_cpu_s"] = o;
    state.counters["cores"] = static_cast<double>(sysconf(_SC_NPROCESSORS_ONLN));
    if (o > 0.05 * w)
      state.SetLabel("NOT QUIET: other processes used " + std::to_string(o / w) +
                     " cores on average");
    else
      state.SetLabel("quiet");
  }

 private:
  double machine_, own_;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

// One streamed slice of the mesh with `threads` threads: (wall, CPU) seconds.
std::pair<double, double> slice_once(const SliceJob& job, int threads,
                                     std::size_t* layers = nullptr) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  const double cpu0 = own_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  const SliceResult r =
      stream_slice(job, [](std::size_t, Layer&& l) { benchmark::DoNotOptimize(l); });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (layers) *layers = r.layers;
  return {wall, own_cpu_seconds() - cpu0};
}

void BM_SliceMesh(benchmark::State& state) {
  const SliceJob job = mesh_job();
  const Neighbours n;
  double cpu = 0;
  std::size_t layers = 0;
  for (auto _ : state) {
    const auto [wall, c] = slice_once(job, static_cast<int>(state.range(0)), &layers);
    state.SetIterationTime(wall);
    cpu += c;
  }
  state.counters["cpu_s"] = cpu / static_cast<double>(state.iterations());
  state.counters["layers"] = static_cast<double>(layers);
  n.report(state);
}

void BM_SliceScaling(benchmark::State& state) {
  const SliceJob job = mesh_job();
  const int rounds = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const Neighbours n;
    double one = 1e300, two = 1e300;
    for (int r = 0; r < rounds; ++r) {
      one = std::min(one, slice_once(job, 1).first);
      two = std::min(two, slice_once(job, 2).first);
    }
    state.counters["one_thread_s"] = one;
    state.counters["two_threads_s"] = two;
    state.counters["speedup"] = one / two;
    n.report(state);
  }
}

void BM_Thumbnails(benchmark::State& state) {
  const SliceJob job = mesh_job();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
  const double cpu0 = own_cpu_seconds();
  const SliceResult r = run_slice(job);
  const double slice_cpu = own_cpu_seconds() - cpu0;
  MachineProfile machine;  // 16x16 and 220x124, as the profiles
  const Neighbours n;
  const double t0 = own_cpu_seconds();
  for (auto _ : state) benchmark::DoNotOptimize(gcode_thumbnails(r.toolpath, machine));
  const double each = (own_cpu_seconds() - t0) / static_cast<double>(state.iterations());
  state.counters["slice_cpu_s"] = slice_cpu;
  state.counters["share_of_slicing"] = each / slice_cpu;
  n.report(state);
}

// A 150 x 150 mm plate, `holes` round holes (2 mm, 24 sides) on a square grid, 10 layers.
std::vector<LayerOutline> holed_plate(int holes) {
  const int side = static_cast<int>(std::ceil(std::sqrt(holes)));
  Polygon2 plate;
  plate.outer = {{0, 0}, {150, 0}, {150, 150}, {0, 150}};
  const double pitch = 150.0 / side;
  for (int k = 0; k < holes; ++k) {
    const double cx = (k % side + 0.5) * pitch, cy = (k / side + 0.5) * pitch;
    std::vector<Vec2> hole;
    for (int j = 24; j-- > 0;) {
      const double a = 2 * std::numbers::pi * j / 24;
      hole.push_back({cx + std::cos(a), cy + std::sin(a)});
    }
    plate.holes.push_back(std::move(hole));
  }
  std::vector<LayerOutline> layers(10);
  for (std::size_t i = 0; i < layers.size(); ++i)
    layers[i] = {0.2 * (static_cast<double>(i) + 0.5), {plate}};
  return layers;
}

void BM_PlanarPlateHoles(benchmark::State& state) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
  const auto layers = holed_plate(static_cast<int>(state.range(0)));
  PlanarOptions o;
  const Neighbours n;
  PlanarStats st;
  for (auto _ : state) benchmark::DoNotOptimize(plan_planar(layers, o, &st));
  state.counters["paths"] = static_cast<double>(st.paths);
  n.report(state);
}

}  // namespace

BENCHMARK(BM_SliceMesh)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(3)->UseManualTime();
BENCHMARK(BM_SliceScaling)->Arg(3)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Thumbnails)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlanarPlateHoles)->Arg(100)->Arg(900)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
