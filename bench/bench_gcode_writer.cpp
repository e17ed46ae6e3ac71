// Target (issue 2): G-code writing at 100 MB/s or more.
#include <benchmark/benchmark.h>

#include "trellis/core/rng.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;

static Toolpath many_paths() {
  Toolpath tp;
  Rng rng(1);
  for (int l = 0; l < 20; ++l) {
    Layer layer{0.148 * (l + 1), {}};
    for (int p = 0; p < 2000; ++p) {
      Path path;
      path.height = 0.148;
      Vec3 q{rng.uniform01() * 200, rng.uniform01() * 200, layer.z};
      for (int k = 0; k < 25; ++k) {
        path.points.push_back(q);
        q = q + Vec3{rng.uniform01() - 0.5, rng.uniform01() - 0.5, 0};
      }
      layer.paths.push_back(std::move(path));
    }
    tp.layers.push_back(std::move(layer));
  }
  return tp;
}

static void BM_WriteMarlin(benchmark::State& state) {
  static const Toolpath tp = many_paths();
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
