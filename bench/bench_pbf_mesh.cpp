// Issue 44 target: making a solid part's PBF layer costs at most twice writing it, on one
// thread, measured side by side. The part is a 20 mm L bracket (5 mm arms' thickness, 10 mm
// tall) made here as a mesh; the default laser profile (40 µm hatch, 30 µm beam compensation,
// one contour). Per strategy:
//   BM_MakeLayer   the section cut from the mesh (slice_mesh_layers) and scanned (plan_pbf_layer);
//   BM_ScanLayer   the scan alone, from a section cut once;
//   BM_WriteLayer  the layer turned into the toolpath IR and written as ASCII CLI
//   (CliStreamWriter).
// The whole build as `trellis run examples/jobs/bracket_pbf_skin.toml` makes it
// (examples/designs/bracket_20mm.stl, 375 layers of 40 µm, islands, two contours with their own
// sets, core, up- and down-skin from the sliding window of layers):
//   BM_MakeBuild   every layer sliced, split into kinds and scanned (plan_pbf_solid);
//   BM_WriteBuild  the same layers turned into the IR with their parameter sets and written as
//   ASCII CLI with an id per set (CliStreamWriter, header and all).
// Both report the time per layer ("s/layer"); make / write is the target's ratio.
// Run: build/release/bench/bench_pbf_mesh
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>

#include "trellis/geom/mesh_io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/slice/pbf_mesh.hpp"

using namespace trellis;

namespace {

TriangleMesh bracket() {
  TriangleMesh m;
  const std::vector<Vec2> ring{{0, 0}, {20, 0}, {20, 5}, {5, 5}, {5, 20}, {0, 20}};
  const Vec2 c{2.5, 2.5};  // the fan's centre: every corner seen from it
  const auto n = static_cast<std::uint32_t>(ring.size());
  for (double z : {0.0, 10.0})
    for (Vec2 q : ring) m.vertices.push_back({q.x, q.y, z});
  m.vertices.push_back({c.x, c.y, 0});
  m.vertices.push_back({c.x, c.y, 10});
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    m.triangles.push_back({2 * n, j, i});
    m.triangles.push_back({2 * n + 1, n + i, n + j});
    m.triangles.push_back({i, j, n + j});
    m.triangles.push_back({i, n + j, n + i});
  }
  return m;
}

PbfSolidOptions options(int strategy) {
  const LaserProfile prof;
  PbfSolidOptions o;
  o.layer = prof.layer;
  o.beam_compensation = prof.beam_compensation;
  o.pattern.hatch_distance = prof.hatch_distance;
  o.pattern.strategy = static_cast<ScanStrategy>(strategy);
  o.timing = scan_timing(prof);
  return o;
}

void name(benchmark::State& state) {
  static const char* names[] = {"rectilinear", "meander", "stripe", "island"};
  state.SetLabel(names[state.range(0)]);
}

void BM_MakeLayer(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const TriangleMesh mesh = bracket();
  const PbfSolidOptions o = options(static_cast<int>(state.range(0)));
  std::size_t i = 0, vectors = 0;
  for (auto _ : state) {
    const auto outline = slice_mesh_layers(mesh, {0.01 + 0.02 * static_cast<double>(i % 500)});
    const PbfLayer L = plan_pbf_layer(outline[0].regions, i++, o);
    vectors += L.hatches.size() + L.contours.size();
    benchmark::DoNotOptimize(L.hatches.data());
  }
  state.counters["vectors/layer"] = static_cast<double>(vectors) / static_cast<double>(i);
  name(state);
}

void BM_ScanLayer(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const TriangleMesh mesh = bracket();
  const PbfSolidOptions o = options(static_cast<int>(state.range(0)));
  const Regions section = slice_mesh_layers(mesh, {5.01})[0].regions;
  std::size_t i = 0;
  for (auto _ : state) {
    const PbfLayer L = plan_pbf_layer(section, i++, o);
    benchmark::DoNotOptimize(L.hatches.data());
  }
  name(state);
}

void BM_WriteLayer(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const TriangleMesh mesh = bracket();
  const PbfSolidOptions o = options(static_cast<int>(state.range(0)));
  const LaserProfile prof;
  // Layers made once (as many as the rotation has distinct angles in a while), written in turn.
  std::vector<PbfLayer> layers;
  for (std::size_t i = 0; i < 16; ++i)
    layers.push_back(plan_pbf_layer(slice_mesh_layers(mesh, {5.01})[0].regions, i, o));
  const std::string path =
      (std::filesystem::temp_directory_path() / "bench_pbf_mesh_write.cli").string();
  CliStreamWriter writer(path, prof, CliWriteOptions{}, "bench", "");
  std::size_t i = 0;
  for (auto _ : state) {
    writer.add(pbf_layer_toolpath(layers[i % layers.size()], i % 1000, prof.layer,
                                  prof.contour_power, prof.contour_speed, prof.hatch_power,
                                  prof.hatch_speed));
    ++i;
  }
  name(state);
}

// The example job's part and settings (examples/jobs/bracket_pbf_skin.toml with
// profiles/pbf_316l_25um.toml).
PbfSolidOptions bracket_job() {
  PbfSolidOptions o;
  o.layer = 0.04;
  o.beam_compensation = 0.03;
  o.contours = 2;
  o.pattern.hatch_distance = 0.04;
  o.pattern.strategy = ScanStrategy::Island;
  o.pattern.island_size = 5;
  o.hatch_phase = HatchPhase::Origin;
  o.skin = {0.5, 0.12, 0.12};
  o.kind_hatch[static_cast<std::size_t>(HatchKind::Core)].distance = 0.08;
  o.exposures.contour = {60, 800};
  o.exposures.hatch = {100, 1000};
  o.exposures.contours = {{60, 800}, {80, 900}};
  o.exposures.core = {180, 1200};
  o.exposures.upskin = {100, 800};
  o.exposures.downskin = {60, 1000};
  LaserProfile prof;
  prof.jump_speed = 5000, prof.jump_delay = 250, prof.mark_delay = 100, prof.polygon_delay = 50;
  o.timing = scan_timing(prof);
  return o;
}

// The example's part (examples/designs/bracket_20mm.stl) and settings.
struct BracketBuild {
  TriangleMesh mesh =
      read_mesh(std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/bracket_20mm.stl");
  PbfSolidOptions options = bracket_job();
  PbfResult plan(const PbfLayerSink& sink) const {
    PbfSolid part;
    part.mesh = &mesh;
    return plan_pbf_solid(part, options, sink);
  }
};

void per_layer(benchmark::State& state, std::size_t layers) {
  // Seconds per layer (printed with an SI prefix: "1.5m" is 1.5 ms).
  state.counters["s/layer"] = benchmark::Counter(
      static_cast<double>(layers),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["layers"] = static_cast<double>(layers);
}

void BM_MakeBuild(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const BracketBuild b;
  std::size_t layers = 0;
  for (auto _ : state)
    layers = b.plan([](std::size_t, const PbfLayer& L) {
                benchmark::DoNotOptimize(L.hatches.data());
              }).layers.size();
  per_layer(state, layers);
}

void BM_WriteBuild(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const BracketBuild b;
  const PbfSolidOptions& o = b.options;
  std::vector<PbfLayer> layers;
  b.plan([&](std::size_t, const PbfLayer& L) { layers.push_back(L); });
  CliWriteOptions w;
  w.sets = cli_parameter_sets(named_parameter_sets(o.exposures, o.skin));
  LaserProfile prof;
  prof.layer = o.layer;
  const std::string path =
      (std::filesystem::temp_directory_path() / "bench_pbf_mesh_build.cli").string();
  for (auto _ : state) {
    CliStreamWriter writer(path, prof, w, "bench", "");
    for (std::size_t i = 0; i < layers.size(); ++i)
      writer.add(pbf_solid_layer_toolpath(layers[i], i, o.layer, o.exposures));
    writer.finish();
  }
  std::filesystem::remove(path);
  per_layer(state, layers.size());
}

}  // namespace

BENCHMARK(BM_MakeBuild)->Unit(benchmark::kMillisecond)->MinTime(2);
BENCHMARK(BM_WriteBuild)->Unit(benchmark::kMillisecond)->MinTime(2);
BENCHMARK(BM_MakeLayer)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ScanLayer)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WriteLayer)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
