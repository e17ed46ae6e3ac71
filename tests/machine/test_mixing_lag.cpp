// A graded print on a mixing hotend with a look-ahead, written and read back: the mixture read
// as commanded is off over the look-ahead after every change; undone (deposit_mixtures, with the
// distance from the file's header), every point has the mixture the toolpath gave it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "trellis/analysis/metrics.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/mixing_lag.hpp"
#include "trellis/settings/settings.hpp"
#include "trellis/slice/fgm.hpp"

using namespace trellis;

namespace {

// 40 lines along X at y = i (30 mm, three segments each), mixture stepping 0 .. 1 every 4 lines.
Toolpath gradient() {
  Toolpath tp;
  Layer layer{0.2, {}};
  for (int i = 0; i < 40; ++i) {
    Path p;
    p.points = {
        {0, double(i), 0.2}, {10, double(i), 0.2}, {20, double(i), 0.2}, {30, double(i), 0.2}};
    p.role = PathRole::Infill;
    const double f = (i / 4) / 9.0;
    p.mixture = {f, 1 - f};
    layer.paths.push_back(p);
  }
  tp.layers.push_back(layer);
  return tp;
}

struct Lookahead : GcodeSink {
  void mixture_lookahead(double mm) override { mm_ = mm; }
  double mm_ = -1;
};

// Length of read-back path whose mixture differs from the planned one of the line it lies on
// (the file is placed on the bed: the first points give the offset).
double wrong_length(const Toolpath& back, const Toolpath& planned) {
  double wrong = 0;
  const Vec3 offset = back.layers[0].paths[0].points[0] - planned.layers[0].paths[0].points[0];
  for (const auto& p : back.layers[0].paths) {
    const Vec3 mid = (p.points.front() + p.points.back()) * 0.5 - offset;
    const int line = static_cast<int>(std::lround(mid.y));
    const auto& want = planned.layers[0].paths.at(static_cast<std::size_t>(line)).mixture;
    if (p.mixture.empty() || std::abs(p.mixture[0] - want[0]) > 1e-3) wrong += p.length();
  }
  return wrong;
}

}  // namespace

TEST(MixingLag, DepositedMixtureIsThePlannedOne) {
  Settings st;
  st.load_toml_file(std::string(TRELLIS_SOURCE_DIR) + "/profiles/geeetech_mizar_m_mixing.toml");
  st.set_text("gradient.lookahead", "95", SettingOrigin{"test"});
  const MachineProfile m = st.config().machine;
  const Toolpath planned = gradient();
  const std::string gcode = write_gcode(planned, m);
  ASSERT_NE(gcode.find("; mixture lookahead = 95 mm"), std::string::npos);

  Toolpath back;
  auto builder = make_toolpath_builder(back);
  Lookahead header;
  TeeSink both(*builder, header);
  Diagnostics diag;
  GcodeScanner scanner(both, {}, diag, "graded.gcode");
  scanner.feed(gcode);
  scanner.finish();
  EXPECT_EQ(header.mm_, 95);
  ASSERT_EQ(back.layers.size(), 1u);
  // As commanded: each of the 9 changes is issued 95 mm early, so ~95 mm wrong per change.
  const double commanded_wrong = wrong_length(back, planned);
  EXPECT_NEAR(commanded_wrong, 9 * 95, 5);
  std::vector<std::vector<double>> before;
  for (const auto& p : back.layers[0].paths) before.push_back(p.mixture);
  const std::size_t paths = back.layers[0].paths.size();

  const auto commanded = deposit_mixtures(back, header.mm_);
  EXPECT_LT(wrong_length(back, planned), 1e-6);
  // The pieces: one bead per planned line (the pieces of a line after the first joined to it),
  // the commanded mixture kept per piece: in print order, the read-back paths' mixtures.
  std::size_t own = 0;
  ASSERT_EQ(commanded.size(), back.layers[0].paths.size());
  EXPECT_GE(commanded.size(), paths);
  for (const auto& p : back.layers[0].paths) own += !p.joined;
  EXPECT_EQ(own, planned.layers[0].paths.size());
  auto changes = [](std::vector<std::vector<double>> v) {
    v.erase(std::unique(v.begin(), v.end()), v.end());
    return v;
  };
  EXPECT_EQ(changes(commanded), changes(before));
  // No look-ahead: nothing changes.
  Toolpath again = back;
  EXPECT_EQ(deposit_mixtures(again, 0).size(), back.layers[0].paths.size());
  EXPECT_EQ(again.layers[0].paths.size(), back.layers[0].paths.size());
}

namespace {

MachineProfile mizar(const std::string& lookahead) {
  Settings st;
  st.load_toml_file(std::string(TRELLIS_SOURCE_DIR) + "/profiles/geeetech_mizar_m_mixing.toml");
  st.set_text("gradient.lookahead", lookahead, SettingOrigin{"test"});
  return st.config().machine;
}

// One run of extrusion: a zigzag of 40 segments of 30 mm, cut into a piece per mixture (a step
// every 4 segments), the pieces after the first joined to it.
Toolpath one_run() {
  Toolpath tp;
  Layer layer{0.2, {}};
  for (int k = 0; k < 10; ++k) {
    Path p;
    for (int i = 4 * k; i <= 4 * k + 4; ++i)
      p.points.push_back({i % 2 ? 30.0 : 0.0, double(i), 0.2});
    p.role = PathRole::Infill;
    p.mixture = {k / 9.0, 1 - k / 9.0};
    p.joined = k > 0;
    layer.paths.push_back(p);
  }
  tp.layers.push_back(layer);
  return tp;
}

}  // namespace

// The reader gives the mixtures as deposited by default: the paths as planned, one per line,
// each in its planned mixture; asked for the commanded ones, a line is cut where each change
// was issued.
TEST(MixingLag, ReadAsDepositedByDefault) {
  const Toolpath planned = gradient();
  const std::string gcode = write_gcode(planned, mizar("95"));
  Diagnostics diag;
  const Toolpath deposited = read_gcode(gcode, {}, diag);
  ASSERT_EQ(deposited.layers.size(), 1u);
  EXPECT_EQ(deposited.path_count(), planned.path_count());
  EXPECT_LT(wrong_length(deposited, planned), 1e-6);
  GcodeReadOptions commanded;
  commanded.commanded_mixtures = true;
  const Toolpath as_commanded = read_gcode(gcode, commanded, diag);
  EXPECT_EQ(as_commanded.path_count(), planned.path_count() + 9);  // 9 changes, 95 mm early
  EXPECT_NEAR(wrong_length(as_commanded, planned), 9 * 95, 5);
  // Without the header line (another program's file) both read the same.
  std::string plain = gcode;
  plain.erase(
      plain.find("; mixture lookahead"),
      plain.find('\n', plain.find("; mixture lookahead")) - plain.find("; mixture lookahead") + 1);
  EXPECT_EQ(read_gcode(plain, {}, diag).path_count(), as_commanded.path_count());
}

// A run cut where its mixture changes reads back as the planned pieces, joined: one path of
// `trellis analyze` (a run between travels), as many IR paths as planned.
TEST(MixingLag, PiecesOfOneRunAreJoined) {
  const Toolpath planned = one_run();
  const std::string gcode = write_gcode(planned, mizar("95"));
  Diagnostics diag;
  const Toolpath back = read_gcode(gcode, {}, diag);
  EXPECT_EQ(back.path_count(), planned.path_count());
  EXPECT_EQ(run_count(back), 1u);
  EXPECT_EQ(run_count(planned), 1u);
  for (std::size_t k = 0; k < back.layers[0].paths.size(); ++k) {
    const Path& p = back.layers[0].paths[k];
    EXPECT_EQ(p.joined, k > 0) << k;
    EXPECT_NEAR(p.mixture[0], planned.layers[0].paths[k].mixture[0], 1e-3) << k;
  }
  GcodeReadOptions commanded;
  commanded.commanded_mixtures = true;
  EXPECT_EQ(run_count(read_gcode(gcode, commanded, diag)), 1u);
}

// A look-ahead longer than the start of the print: the changes planned in its first L mm are all
// issued at the start, the mixture the last of them plans deposited from there to the next
// change; the writer says so when that takes a whole layer, and the slicer's model of it
// (deposit_start_mixtures, which the report's gradient error is measured with) is what the
// G-code reads back as.
TEST(MixingLag, LookaheadPastTheStartIsWarnedAndModelled) {
  // gradient()'s lines 0..9 on a first layer (300 mm), 10..39 on a second; changes every 120 mm.
  Toolpath planned = gradient();
  planned.layers.push_back({0.4, {}});
  auto& first = planned.layers[0].paths;
  for (auto p = first.begin() + 10; p != first.end(); ++p) {
    for (auto& q : p->points) q.z = 0.4;
    planned.layers[1].paths.push_back(*p);
  }
  first.resize(10);
  GcodeStats stats;
  const std::string gcode = write_gcode(planned, mizar("600"), &stats);
  const auto it = std::find_if(stats.warnings.begin(), stats.warnings.end(),
                               [](const auto& w) { return w.first == "lookahead_exceeds_start"; });
  ASSERT_NE(it, stats.warnings.end());
  // Changes at 0, 120, ..., 600 mm issued at the start: the first 720 mm in one mixture.
  EXPECT_NE(it->second.find("gradient.lookahead = 600 mm"), std::string::npos) << it->second;
  EXPECT_NE(it->second.find("the 6 mixture changes"), std::string::npos) << it->second;
  EXPECT_NE(it->second.find("first 720 mm of path (layers 1 to 1 of 2 and part of layer 2)"),
            std::string::npos)
      << it->second;
  Toolpath model = planned;
  EXPECT_TRUE(deposit_start_mixtures(model, 600));
  Diagnostics diag;
  const Toolpath back = read_gcode(gcode, {}, diag);
  ASSERT_EQ(back.path_count(), model.path_count());
  std::size_t differ = 0;
  for (std::size_t l = 0; l < 2; ++l)
    for (std::size_t k = 0; k < model.layers[l].paths.size(); ++k) {
      EXPECT_NEAR(back.layers[l].paths[k].mixture[0], model.layers[l].paths[k].mixture[0], 1e-3);
      differ += model.layers[l].paths[k].mixture != planned.layers[l].paths[k].mixture;
    }
  EXPECT_EQ(differ, 20u);  // lines 0..19: deposited in line 20's mixture
  // One mixture over 240 mm of the first layer's 300: said by the report's error, not warned.
  GcodeStats quiet;
  write_gcode(planned, mizar("150"), &quiet);
  for (const auto& w : quiet.warnings) EXPECT_NE(w.first, "lookahead_exceeds_start") << w.second;
  // Within the first change: nothing deposited differently.
  Toolpath same = planned;
  EXPECT_FALSE(deposit_start_mixtures(same, 95));
}
