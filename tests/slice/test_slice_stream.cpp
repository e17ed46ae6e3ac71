// Planar slicing streamed through the bounded pipeline (issue 23): the layers handed to the sink
// are run_slice's layers, in order, byte for byte, for any run length and number of runs in
// flight (skins read the outlines around each run), on the field and the mesh route; the
// statistics are the whole run's; graded slicing refuses to stream.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "trellis/core/error.hpp"
#include "trellis/slice/fgm_process.hpp"
#include "trellis/slice/pipeline.hpp"
#include "trellis/toolpath/layer_spill.hpp"

using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;

void expect_same_layer(const Layer& a, const Layer& b, std::size_t i) {
  ASSERT_EQ(a.z, b.z) << "layer " << i;
  ASSERT_EQ(a.paths.size(), b.paths.size()) << "layer " << i;
  for (std::size_t k = 0; k < a.paths.size(); ++k) {
    const Path &p = a.paths[k], &q = b.paths[k];
    ASSERT_EQ(p.role, q.role) << "layer " << i << " path " << k;
    ASSERT_EQ(p.width, q.width);
    ASSERT_EQ(p.height, q.height);
    ASSERT_EQ(p.mixture, q.mixture) << "layer " << i << " path " << k;
    ASSERT_EQ(p.tool, q.tool) << "layer " << i << " path " << k;
    // Process fields (fprocess): what each piece is written with.
    ASSERT_EQ(p.speed, q.speed) << "layer " << i << " path " << k;
    ASSERT_TRUE(p.temperature == q.temperature ||
                (std::isnan(p.temperature) && std::isnan(q.temperature)))
        << "layer " << i << " path " << k;
    ASSERT_TRUE(p.flow == q.flow || (std::isnan(p.flow) && std::isnan(q.flow))) << "layer " << i;
    ASSERT_TRUE(p.fan == q.fan || (std::isnan(p.fan) && std::isnan(q.fan))) << "layer " << i;
    ASSERT_EQ(p.joined, q.joined) << "layer " << i << " path " << k;
    ASSERT_EQ(p.points.size(), q.points.size()) << "layer " << i << " path " << k;
    for (std::size_t m = 0; m < p.points.size(); ++m) {
      ASSERT_EQ(p.points[m].x, q.points[m].x) << "layer " << i << " path " << k;
      ASSERT_EQ(p.points[m].y, q.points[m].y);
      ASSERT_EQ(p.points[m].z, q.points[m].z);
    }
  }
}

// A graded job on `design`: with a prime tower for Strategy 1 and tool changers (every change
// purges, a 250 mm bed); four colours on `tools` tools, so the tools print the nearest of their
// mixes (not the palette's).
SliceJob graded_job(const std::string& design, int strategy, int tools,
                    FgmOrder order = FgmOrder::Faces) {
  SliceJob job;
  job.input = design;
  job.strategy_chosen = true;
  job.strategy = strategy;
  job.tools = tools;
  job.fgm.order = order;
  if (tools) job.fgm.palette.colors = 4;
  if (strategy == 1 || tools) {
    job.purge.melt_volume = 20;
    job.purge.bed_x = job.purge.bed_y = 250;
    job.purge.speed = 40;
  }
  return job;
}

// stream_slice's layers at runs of `chunk` layers, each checked against the whole run's; the
// streamed result (its statistics) for the caller to compare.
SliceResult streamed_as_whole(const SliceJob& job, const SliceResult& whole, std::size_t chunk,
                              const std::string& at) {
  std::vector<Layer> layers;
  SliceResult s = stream_slice(job, [&](std::size_t, Layer&& l) { layers.push_back(std::move(l)); },
                               {chunk, 4});
  EXPECT_EQ(layers.size(), whole.toolpath.layers.size()) << at;
  for (std::size_t i = 0; i < layers.size() && i < whole.toolpath.layers.size(); ++i)
    expect_same_layer(whole.toolpath.layers[i], layers[i], i);
  return s;
}

// The per-colour table and the travel of a whole toolpath (a streamed run sums them as it goes).
std::pair<std::map<std::vector<double>, std::pair<double, double>>, TravelStats> use_and_travel(
    const SliceJob& job, const Toolpath& tp) {
  std::map<std::vector<double>, std::pair<double, double>> use;
  for (const Layer& l : tp.layers) add_colour_use(job, l, use);
  return {use, travel_stats(tp)};
}

SliceJob bracket(double layer) {
  SliceJob job;
  job.input = kRoot + "/examples/designs/csg_bracket.vcad";
  job.planar.layer_height = layer;
  job.planar.walls = 2;
  job.planar.top_layers = 3;
  job.planar.bottom_layers = 5;  // unequal, so a window off by one side shows
  job.field.resolution = 0.2;
  return job;
}

void expect_streams_as_whole(const SliceJob& job, const SliceStreamOptions& options) {
  const SliceResult whole = run_slice(job);
  ASSERT_GT(whole.toolpath.layers.size(), 8u);
  std::vector<Layer> got;
  std::vector<std::size_t> order;
  const SliceResult s = stream_slice(
      job, [&](std::size_t i, Layer&& l) { order.push_back(i), got.push_back(std::move(l)); },
      options);
  ASSERT_EQ(got.size(), whole.toolpath.layers.size())
      << "chunk " << options.chunk_layers << " tokens " << options.tokens;
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(order[i], i);
    expect_same_layer(got[i], whole.toolpath.layers[i], i);
  }
  EXPECT_TRUE(s.streamed);
  EXPECT_TRUE(s.toolpath.layers.empty()) << "a stream keeps no toolpath";
  EXPECT_TRUE(s.outlines.empty()) << "a stream keeps no outlines";
  EXPECT_EQ(s.layers, whole.outlines.size());
  EXPECT_EQ(s.part_layers, whole.part_layers);
  EXPECT_EQ(s.planar.paths, whole.planar.paths);
  EXPECT_EQ(s.planar.walls, whole.planar.walls);
  EXPECT_EQ(s.planar.skin_lines, whole.planar.skin_lines);
  EXPECT_EQ(s.planar.infill_lines, whole.planar.infill_lines);
  EXPECT_EQ(s.planar.extruded_length, whole.planar.extruded_length);
  const TravelStats t = travel_stats(whole.toolpath);
  EXPECT_EQ(s.travel.moves, t.moves);
  EXPECT_EQ(s.travel.length, t.length);
  EXPECT_EQ(s.field_stats.samples, whole.field_stats.samples);
  EXPECT_EQ(s.field_stats.blocks, whole.field_stats.blocks);
}

TEST(SliceStream, FieldRouteLayersAreTheWholeRunsForAnyRunLengthAndTokens) {
  const SliceJob job = bracket(0.3);  // 60 layers
  for (const SliceStreamOptions o :
       {SliceStreamOptions{1, 1}, SliceStreamOptions{3, 2}, SliceStreamOptions{16, 0},
        SliceStreamOptions{7, 8}, SliceStreamOptions{1000, 2}})
    expect_streams_as_whole(job, o);
  // Runs of planned layers shorter and longer than the skins' reach (the windows slide across
  // their ends: SkinWindows).
  for (const SliceStreamOptions o :
       {SliceStreamOptions{1, 1, 1}, SliceStreamOptions{3, 2, 5}, SliceStreamOptions{5, 3, 64}})
    expect_streams_as_whole(job, o);
}

TEST(SliceStream, MeshRouteLayersAreTheWholeRuns) {
  SliceJob job;
  job.input = kRoot + "/examples/designs/concave_cylinder.obj";
  job.planar.layer_height = 0.2;
  for (const SliceStreamOptions o : {SliceStreamOptions{1, 2}, SliceStreamOptions{4, 3}})
    expect_streams_as_whole(job, o);
}

TEST(SliceStream, OneThreadAndManyAgree) {
  const SliceJob job = bracket(0.4);
  std::vector<Layer> one, many;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    stream_slice(job, [&](std::size_t, Layer&& l) { one.push_back(std::move(l)); });
  }
  stream_slice(job, [&](std::size_t, Layer&& l) { many.push_back(std::move(l)); }, {2, 6});
  ASSERT_EQ(one.size(), many.size());
  for (std::size_t i = 0; i < one.size(); ++i) expect_same_layer(one[i], many[i], i);
}

// Graded slicing streams run by run: Strategy 2 on a mixing hotend, Strategy 1 in path order
// (joined pieces, no tower), and with a prime tower (Strategy 1 in face order; either strategy on
// a five-tool changer, Strategy 1's pieces grouped by tool) the planned layers go to a temporary
// file and come back with the tower step and the tools' mixtures. The layers and every
// statistic the report prints (fill, tower, per-colour use, travel, gradient error) are
// run_slice's for any run length.
TEST(SliceStream, GradedSlicingStreamsAsWhole) {
  // A cylinder graded across X and up Z: several colours per layer, moving up the layers.
  const std::string design = (std::filesystem::temp_directory_path() /
                              ("trellis_graded_stream_" + std::to_string(::getpid()) + ".vcad"))
                                 .string();
  std::ofstream(design) << "fgrade([\"(x+8)/32 + z/16.8\", \"1 - (x+8)/32 - z/16.8\"], [\"blue\", "
                           "\"yellow\"]) {\n  cylinder(8, 8.4);\n}\n";
  struct Case {
    int strategy, tools;
    FgmOrder order;
  };
  for (const Case c :
       {Case{2, 0, FgmOrder::Paths}, Case{1, 0, FgmOrder::Faces}, Case{1, 0, FgmOrder::Paths},
        Case{1, 5, FgmOrder::Paths}, Case{2, 5, FgmOrder::Paths}}) {
    const SliceJob job = graded_job(design, c.strategy, c.tools, c.order);
    const std::string what = "strategy " + std::to_string(c.strategy) + ", " +
                             std::to_string(c.tools) + " tools, " + to_string(c.order) + " order";
    const SliceResult whole = run_slice(job);
    if ((c.strategy == 1 && c.order == FgmOrder::Faces) || c.tools) {
      ASSERT_TRUE(whole.fgm.tower.built) << what;
      EXPECT_GT(whole.fgm.purges, 10u) << what;
    } else {
      EXPECT_FALSE(whole.fgm.tower.built) << what;
    }
    if (c.strategy == 1 && c.order == FgmOrder::Paths && !c.tools)
      EXPECT_GT(whole.fgm.joined, 10u) << what;
    const auto [whole_use, whole_travel] = use_and_travel(job, whole.toolpath);
    for (const std::size_t chunk : {std::size_t{16}, std::size_t{3}, std::size_t{1}}) {
      const std::string at = what + ", runs of " + std::to_string(chunk);
      const SliceResult s = streamed_as_whole(job, whole, chunk, at);
      if (::testing::Test::HasFatalFailure()) return;
      EXPECT_GT(whole.fgm.paths, 0u);
      EXPECT_EQ(s.fgm.paths, whole.fgm.paths) << at;
      EXPECT_EQ(s.fgm.faces, whole.fgm.faces) << at;
      EXPECT_EQ(s.fgm.colour_changes, whole.fgm.colour_changes) << at;
      EXPECT_EQ(s.fgm.joined, whole.fgm.joined) << at;
      EXPECT_EQ(s.fgm.abrupt_changes, whole.fgm.abrupt_changes) << at;
      EXPECT_EQ(s.fgm.shortest_path, whole.fgm.shortest_path) << at;
      EXPECT_EQ(s.fgm.short_merged, whole.fgm.short_merged) << at;
      EXPECT_EQ(s.fgm.short_kept, whole.fgm.short_kept) << at;
      EXPECT_EQ(s.fgm.error_samples, whole.fgm.error_samples) << at;
      EXPECT_EQ(s.fgm.error_mean, whole.fgm.error_mean) << at << ": summed in the same order";
      EXPECT_EQ(s.fgm.error_max, whole.fgm.error_max) << at;
      EXPECT_EQ(s.fgm.error_bound, whole.fgm.error_bound) << at;
      EXPECT_EQ(s.fgm.colours_used, whole.fgm.colours_used) << at;
      EXPECT_EQ(s.fgm.purges, whole.fgm.purges) << at;
      EXPECT_EQ(s.fgm.purge_length, whole.fgm.purge_length) << at;
      EXPECT_EQ(s.fgm.tower.built, whole.fgm.tower.built) << at;
      EXPECT_EQ(s.fgm.tower.x, whole.fgm.tower.x) << at;
      EXPECT_EQ(s.fgm.tower.y, whole.fgm.tower.y) << at;
      EXPECT_EQ(s.fgm.tower.size_x, whole.fgm.tower.size_x) << at;
      EXPECT_EQ(s.fgm.tower.layers, whole.fgm.tower.layers) << at;
      EXPECT_EQ(s.fgm.tower.volume, whole.fgm.tower.volume) << at;
      EXPECT_EQ(s.fgm.tower.colours.size(), whole.fgm.tower.colours.size()) << at;
      EXPECT_EQ(s.planar.paths, whole.planar.paths) << at;
      EXPECT_EQ(s.planar.extruded_length, whole.planar.extruded_length) << at;
      EXPECT_EQ(s.planar.walls, whole.planar.walls) << at;
      EXPECT_EQ(s.planar.infill_lines, whole.planar.infill_lines) << at;
      EXPECT_EQ(s.colour_use, whole_use) << at;
      EXPECT_EQ(s.travel.moves, whole_travel.moves) << at;
      EXPECT_EQ(s.travel.length, whole_travel.length) << at;
      EXPECT_EQ(s.layers, whole.outlines.size()) << at;
    }
  }
  std::filesystem::remove(design);
}

// Process fields (fprocess) stream too: each layer is split where a rounded value changes as it
// passes (after the prime tower), and the written values are counted in print order; planar,
// Strategy 1 with its tower (face order) and with joined pieces (path order, the fields
// splitting the pieces further) and Strategy 2 give run_slice's layers and process statistics
// for any run length.
TEST(SliceStream, ProcessFieldsStreamAsWhole) {
  const std::string design = (std::filesystem::temp_directory_path() /
                              ("trellis_process_stream_" + std::to_string(::getpid()) + ".vcad"))
                                 .string();
  // Temperature up Z, speed across X, flow across Y, fan up Z; graded in material across X.
  std::ofstream(design)
      << "fprocess([\"200 + 2*z\", \"30 + 0.7*x\", \"1 + 0.02*y\", \"50 + 5*z\"],\n"
         "         [\"temperature\", \"speed\", \"flow\", \"fan\"]) {\n"
         "  fgrade([\"(x+8)/16\", \"1 - (x+8)/16\"], [\"blue\", \"yellow\"]) {\n"
         "    cylinder(8, 4);\n  }\n}\n";
  for (const auto& [strategy, order] :
       {std::pair{0, FgmOrder::Paths}, std::pair{1, FgmOrder::Faces}, std::pair{1, FgmOrder::Paths},
        std::pair{2, FgmOrder::Paths}}) {
    SliceJob job;
    job.input = design;
    job.strategy_chosen = true;
    job.strategy = strategy;
    job.fgm.order = order;
    job.process.max_temperature = 290;
    job.process.max_speed = 200;
    if (strategy == 1) {
      job.purge.melt_volume = 20;
      job.purge.bed_x = job.purge.bed_y = 250;
    }
    const std::string what =
        "strategy " + std::to_string(strategy) + ", " + to_string(order) + " order";
    const SliceResult whole = run_slice(job);
    ASSERT_TRUE(whole.process.active) << what;
    ASSERT_GT(whole.process.pieces, whole.process.paths) << what << ": the fields split paths";
    for (const std::size_t chunk : {std::size_t{16}, std::size_t{3}, std::size_t{1}}) {
      const std::string at = what + ", runs of " + std::to_string(chunk);
      const SliceResult s = streamed_as_whole(job, whole, chunk, at);
      if (::testing::Test::HasFatalFailure()) return;
      EXPECT_EQ(s.process.paths, whole.process.paths) << at;
      EXPECT_EQ(s.process.pieces, whole.process.pieces) << at;
      EXPECT_EQ(s.process.merged, whole.process.merged) << at;
      EXPECT_EQ(s.process.samples, whole.process.samples) << at;
      for (int k = 0; k < kProcessParams; ++k) {
        const ProcessParamStats &a = whole.process.param[k], &b = s.process.param[k];
        EXPECT_TRUE(a.set) << at << " param " << k;
        EXPECT_EQ(b.set, a.set) << at << " param " << k;
        EXPECT_EQ(b.min, a.min) << at << " param " << k;
        EXPECT_EQ(b.max, a.max) << at << " param " << k;
        EXPECT_EQ(b.changes, a.changes) << at << " param " << k;
        EXPECT_EQ(b.max_deviation, a.max_deviation) << at << " param " << k;
        EXPECT_EQ(b.node, a.node) << at << " param " << k;
      }
      EXPECT_EQ(s.travel.moves, travel_stats(whole.toolpath).moves) << at;
    }
  }
  std::filesystem::remove(design);
}

// Process fields on a five-tool changer (four colours: the tools' nearest mixes) with either
// strategy, after the tower step and the tools' mixtures: layers, process statistics, per-colour
// use and travel are run_slice's at any run length.
TEST(SliceStream, ProcessFieldsOnToolChangersStreamAsWhole) {
  const std::string design =
      (std::filesystem::temp_directory_path() /
       ("trellis_process_tools_stream_" + std::to_string(::getpid()) + ".vcad"))
          .string();
  // Speed across X, flow across Y, fan up Z: several pieces per path, changes inside layers and
  // across layer boundaries.
  std::ofstream(design)
      << "fprocess([\"30 + 0.7*x\", \"1 + 0.02*y\", \"40 + 12*z\"], [\"speed\", "
         "\"flow\", \"fan\"]) {\n  fgrade([\"(x+8)/32 + z/16.8\", \"1 - (x+8)/32 - "
         "z/16.8\"], [\"blue\", \"yellow\"]) {\n    cylinder(8, 4.2);\n  }\n}\n";
  struct Case {
    int strategy, tools;
  };
  for (const Case c : {Case{1, 5}, Case{2, 5}}) {
    const SliceJob job = graded_job(design, c.strategy, c.tools);
    const std::string what =
        "strategy " + std::to_string(c.strategy) + ", " + std::to_string(c.tools) + " tools";
    const SliceResult whole = run_slice(job);
    ASSERT_TRUE(whole.process.active) << what;
    EXPECT_GT(whole.process.pieces, whole.process.paths + 50) << what << ": paths are split";
    ASSERT_TRUE(whole.fgm.tower.built) << what;
    const auto [whole_use, whole_travel] = use_and_travel(job, whole.toolpath);
    for (const std::size_t chunk : {std::size_t{16}, std::size_t{3}, std::size_t{1}}) {
      const std::string at = what + ", runs of " + std::to_string(chunk);
      const SliceResult s = streamed_as_whole(job, whole, chunk, at);
      if (::testing::Test::HasFatalFailure()) return;
      const ProcessStats &a = whole.process, &b = s.process;
      EXPECT_TRUE(b.active) << at;
      EXPECT_EQ(b.paths, a.paths) << at;
      EXPECT_EQ(b.pieces, a.pieces) << at;
      EXPECT_EQ(b.merged, a.merged) << at;
      EXPECT_EQ(b.samples, a.samples) << at;
      EXPECT_EQ(b.short_slowed, a.short_slowed) << at;
      for (int k = 0; k < kProcessParams; ++k) {
        EXPECT_EQ(b.param[k].set, a.param[k].set) << at << " param " << k;
        EXPECT_EQ(b.param[k].min, a.param[k].min) << at << " param " << k;
        EXPECT_EQ(b.param[k].max, a.param[k].max) << at << " param " << k;
        EXPECT_EQ(b.param[k].changes, a.param[k].changes) << at << " param " << k;
        EXPECT_EQ(b.param[k].max_deviation, a.param[k].max_deviation) << at << " param " << k;
        EXPECT_EQ(b.param[k].node, a.param[k].node) << at << " param " << k;
      }
      EXPECT_GT(a.param[static_cast<int>(ProcessParam::Fan)].changes, 5u) << at;
      EXPECT_EQ(s.fgm.purges, whole.fgm.purges) << at;
      EXPECT_EQ(s.fgm.tower.volume, whole.fgm.tower.volume) << at;
      EXPECT_EQ(s.planar.paths, whole.planar.paths) << at;
      EXPECT_EQ(s.planar.extruded_length, whole.planar.extruded_length) << at;
      EXPECT_EQ(s.colour_use, whole_use) << at;
      EXPECT_EQ(s.travel.moves, whole_travel.moves) << at;
      EXPECT_EQ(s.travel.length, whole_travel.length) << at;
    }
  }
  std::filesystem::remove(design);
}

TEST(LayerSpill, LayersComeBackAsTheyWent) {
  Layer a;
  a.z = 0.3;
  Path p;
  p.points = {{1, 2, 0.3}, {4, 5, 0.3}, {7, 8.5, 0.3}};
  p.role = PathRole::Skin;
  p.tool = 2;
  p.part = 3;
  p.mixture = {0.25, 0.75};
  p.width = 0.45, p.height = 0.2, p.speed = 30, p.power = 1, p.filament = 2, p.temperature = 215;
  p.flow = 0.8, p.fan = 40, p.joined = true;  // process fields (fprocess)
  a.paths = {p, Path{}};
  Layer b;
  b.z = 0.6;
  LayerSpill spill;
  spill.append(a);
  spill.append(b);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<Layer> back;
    spill.visit([&](std::size_t i, const Layer& l) {
      EXPECT_EQ(i, back.size());
      back.push_back(l);
    });
    ASSERT_EQ(back.size(), 2u);
    EXPECT_EQ(back[0].z, 0.3);
    EXPECT_EQ(back[1].z, 0.6);
    EXPECT_TRUE(back[1].paths.empty());
    ASSERT_EQ(back[0].paths.size(), 2u);
    const Path& q = back[0].paths[0];
    EXPECT_EQ(q.role, PathRole::Skin);
    EXPECT_EQ(q.tool, 2);
    EXPECT_EQ(q.part, 3);
    EXPECT_EQ(q.mixture, p.mixture);
    EXPECT_EQ(q.width, 0.45);
    EXPECT_EQ(q.height, 0.2);
    EXPECT_EQ(q.speed, 30);
    EXPECT_EQ(q.power, 1);
    EXPECT_EQ(q.filament, 2);
    EXPECT_EQ(q.temperature, 215);
    EXPECT_EQ(q.flow, 0.8);
    EXPECT_EQ(q.fan, 40);
    EXPECT_TRUE(q.joined);
    EXPECT_FALSE(back[0].paths[1].joined);
    EXPECT_EQ(back[0].paths[1].fan, -1);
    ASSERT_EQ(q.points.size(), 3u);
    EXPECT_EQ(q.points[2].y, 8.5);
    EXPECT_TRUE(back[0].paths[1].points.empty());
  }
  EXPECT_THROW(spill.append(a), Error) << "appending after reading started";
}

// Once written, a spill is visited by two threads at once (the G-code writer and its thumbnails)
// and each sees every layer in order, as one visit alone does.
TEST(LayerSpill, TwoThreadsVisitAtOnce) {
  LayerSpill spill;
  for (int i = 0; i < 400; ++i) {
    Layer l;
    l.z = 0.2 * (i + 1);
    for (int k = 0; k <= i % 7; ++k) {
      Path p;
      for (int q = 0; q <= (i * 13 + k) % 50; ++q) p.points.push_back({q * 0.5, i + k * 0.25, l.z});
      l.paths.push_back(std::move(p));
    }
    spill.append(l);
  }
  const LayerSource source = spill.source();
  auto summary = [&] {
    std::vector<double> s;
    source([&](std::size_t i, const Layer& l) {
      s.push_back(static_cast<double>(i));
      s.push_back(l.z);
      for (const Path& p : l.paths)
        for (const Vec3& q : p.points) s.push_back(q.x + 3 * q.y);
    });
    return s;
  };
  const std::vector<double> alone = summary();
  ASSERT_EQ(alone.empty(), false);
  for (int round = 0; round < 5; ++round) {
    std::vector<double> a, b;
    std::thread t([&] { a = summary(); });
    b = summary();
    t.join();
    EXPECT_EQ(a, alone) << round;
    EXPECT_EQ(b, alone) << round;
  }
}

}  // namespace

// The spill file goes where TMPDIR says (a batch node's scratch disk), not always /tmp.
TEST(LayerSpill, HonoursTmpdir) {
  const char* old = std::getenv("TMPDIR");
  const std::string saved = old ? old : "";
  ::setenv("TMPDIR", "/nonexistent-trellis-tmpdir", 1);
  bool threw = false;
  try {
    LayerSpill spill;
  } catch (const IoError& e) {
    threw = std::string(e.what()).find("/nonexistent-trellis-tmpdir") != std::string::npos;
  }
  old ? ::setenv("TMPDIR", saved.c_str(), 1) : ::unsetenv("TMPDIR");
  EXPECT_TRUE(threw) << "LayerSpill ignored TMPDIR";
}
