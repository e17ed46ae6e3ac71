// Targets (issue 6): a 44 x 16 mm corrugation, 6 layers, sliced in under 20 ms; a 100 x 100 mm
// surface mesh of 1M triangles, 10 layers, in under 5 s on 2 cores (here: reading the binary STL,
// the height-field check, the grid index and the slicing, end to end).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/nonplanar.hpp"

using namespace trellis;

namespace {

void counters(benchmark::State& state, const NonplanarResult& r) {
  std::size_t paths = 0, points = 0;
  for (const auto& l : r.toolpath.layers)
    for (const auto& p : l.paths) ++paths, points += p.points.size();
  state.counters["layers"] = static_cast<double>(r.layers.size());
  state.counters["paths"] = static_cast<double>(paths);
  state.counters["points"] = static_cast<double>(points);
}

// Slices `s` once per iteration and reports the result's size.
void slice_loop(benchmark::State& state, const HeightField& s, const NonplanarParams& prm) {
  NonplanarResult r;
  for (auto _ : state) {
    r = slice_nonplanar(s, prm);
    benchmark::DoNotOptimize(r.toolpath.layers.data());
  }
  counters(state, r);
}

// A wavy 100 x 100 mm surface as a grid mesh of 2 x 707 x 707 = 999,698 triangles, written once.
const std::string& big_stl() {
  static const std::string path = [] {
    const std::string p =
        (std::filesystem::temp_directory_path() / "trellis_bench_surface_1M.stl").string();
    auto make = []() -> HeightField::Eval {
      return [](double x, double y) {
        return 3 * std::sin(x / 7) * std::cos(y / 11) + 0.5 * std::sin((x + y) / 3);
      };
    };
    const HeightField s = HeightField::from_function(make, {{0, 0}, {100, 100}}, "wavy");
    write_stl(p, surface_mesh(s, 100.0 / 707));
    return p;
  }();
  return path;
}

}  // namespace

static void BM_Corrugation6Layers(benchmark::State& state) {
  slice_loop(state, corrugation({}), {});  // 0.4 mm, 0.3 mm layers, 6 layers, cross-hatch
}
BENCHMARK(BM_Corrugation6Layers)->Unit(benchmark::kMillisecond)->UseRealTime();

static void BM_Corrugation6LayersNormalOffset(benchmark::State& state) {
  NonplanarParams prm;
  prm.offset = OffsetMode::Normal;
  slice_loop(state, corrugation({}), prm);
}
BENCHMARK(BM_Corrugation6LayersNormalOffset)->Unit(benchmark::kMillisecond)->UseRealTime();

static void BM_CorrugationMesh6Layers(benchmark::State& state) {
  slice_loop(state, HeightField::from_mesh(surface_mesh(corrugation({}), 0.1), "mesh"), {});
}
BENCHMARK(BM_CorrugationMesh6Layers)->Unit(benchmark::kMillisecond)->UseRealTime();

static void BM_Mesh1M10LayersFromStl(benchmark::State& state) {
  const std::string& path = big_stl();
  NonplanarParams prm;
  prm.layers = 10;
  NonplanarResult r;
  std::size_t triangles = 0;
  for (auto _ : state) {
    const TriangleMesh m = read_mesh(path);
    triangles = m.triangles.size();
    const HeightField s = HeightField::from_mesh(m, path);
    r = slice_nonplanar(s, prm);
    benchmark::DoNotOptimize(r.toolpath.layers.data());
  }
  counters(state, r);
  state.counters["triangles"] = static_cast<double>(triangles);
}
BENCHMARK(BM_Mesh1M10LayersFromStl)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

static void BM_Mesh1MHeightFieldCheck(benchmark::State& state) {
  const TriangleMesh m = read_mesh(big_stl());
  for (auto _ : state) {
    const HeightField s = HeightField::from_mesh(m, "1M");
    benchmark::DoNotOptimize(s.domain());
  }
}
BENCHMARK(BM_Mesh1MHeightFieldCheck)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

static void BM_Mesh1M10LayersSliceOnly(benchmark::State& state) {
  NonplanarParams prm;
  prm.layers = 10;
  slice_loop(state, HeightField::from_mesh(read_mesh(big_stl()), "1M"), prm);
}
BENCHMARK(BM_Mesh1M10LayersSliceOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK_MAIN();
