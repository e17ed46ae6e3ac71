// A graded print on a mixing hotend with a look-ahead, written and read back: the mixture read
// as commanded is off over the look-ahead after every change; undone (deposit_mixtures, with the
// distance from the file's header), every point has the mixture the toolpath gave it.
#include <gtest/gtest.h>

#include <cmath>

#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/mixing_lag.hpp"
#include "trellis/settings/settings.hpp"

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
  // The pieces: one bead per read-back path, the commanded mixture kept per piece.
  std::size_t own = 0;
  ASSERT_EQ(commanded.size(), back.layers[0].paths.size());
  for (const auto& p : back.layers[0].paths) own += !p.joined;
  EXPECT_EQ(own, paths);
  for (std::size_t k = 0, j = 0; k < back.layers[0].paths.size(); ++k) {
    j += k > 0 && !back.layers[0].paths[k].joined;
    EXPECT_EQ(commanded[k], before[j]) << k;
  }
  // No look-ahead: nothing changes.
  Toolpath again = back;
  EXPECT_EQ(deposit_mixtures(again, 0).size(), back.layers[0].paths.size());
  EXPECT_EQ(again.layers[0].paths.size(), back.layers[0].paths.size());
}
