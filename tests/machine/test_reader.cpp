#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "support/machines.hpp"
#include "support/random_graphs.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/plan/plan.hpp"

using namespace trellis;

namespace {

Toolpath planned(const Graph& g, Planner planner) {
  PlanParams pp;
  pp.planner = planner;
  pp.gippo.iterations = 10;
  Diagnostics d;
  return plan_lattice(g, pp, d).toolpath;
}

// Our IR read back from our own G-code: same layers, paths, points (within 1 µm) and E per path.
void expect_round_trip(const Toolpath& tp, const MachineProfile& profile,
                       const std::string& label) {
  const std::string gcode = write_gcode(tp, profile);
  Diagnostics diag;
  GcodeReadOptions opt;
  if (profile.flavor == "pneumatic") {
    opt.valve_on = profile.valve_on;
    opt.valve_off = profile.valve_off;
  }
  const Toolpath back = read_gcode(gcode, opt, diag, label);
  EXPECT_EQ(diag.total(), 0u) << label;
  ASSERT_EQ(back.layers.size(), tp.layers.size()) << label;
  for (std::size_t l = 0; l < tp.layers.size(); ++l) {
    ASSERT_EQ(back.layers[l].paths.size(), tp.layers[l].paths.size()) << label << " layer " << l;
    for (std::size_t i = 0; i < tp.layers[l].paths.size(); ++i) {
      const Path& a = tp.layers[l].paths[i];
      const Path& b = back.layers[l].paths[i];
      ASSERT_EQ(a.points.size(), b.points.size()) << label;
      for (std::size_t k = 0; k < a.points.size(); ++k)
        ASSERT_LE(distance(a.points[k], b.points[k]), 1e-3) << label;
      if (profile.flavor == "marlin") {
        const double e =
            extrusion_for(a.length(), a.height > 0 ? a.height : profile.layer_height, profile) +
            profile.pre_flow + profile.post_flow;
        // Pre-/post-flow happen without motion, so the reader does not count them as deposits.
        EXPECT_NEAR(b.filament, e - profile.pre_flow - profile.post_flow,
                    1e-5 * (a.points.size() + 1))
            << label;
      }
    }
  }
}

}  // namespace

TEST(Reader, RoundTripForEveryWriterOnManyLattices) {
  MachineProfile marlin = test::open_bed();
  marlin.retract_length = 0.8;
  marlin.z_hop = 0.3;
  MachineProfile relative = marlin;
  relative.relative_e = true;
  relative.pre_flow = 0.05;
  MachineProfile pneumatic = test::open_bed();
  pneumatic.flavor = "pneumatic";
  pneumatic.valve_on = "M3";
  pneumatic.valve_off = "M5";
  for (const auto& name : pattern_names()) {
    AtlasParams a;
    a.pattern = pattern_from_string(name);
    a.region.width = a.region.height = 5;
    const Toolpath tp = planned(make_lattice2d(a), Planner::Gippo);
    expect_round_trip(tp, marlin, name + " marlin");
    expect_round_trip(tp, relative, name + " relative");
    expect_round_trip(tp, pneumatic, name + " pneumatic");
  }
  for (std::uint64_t seed = 1; seed <= 8; ++seed)
    expect_round_trip(planned(test::random_planar_graph(seed), Planner::Euler), marlin, "random");
}

TEST(Reader, ModesUnitsArcsAndComments) {
  const std::string g =
      "; Cura-like\n;LAYER:0\nG21\nG90\nM83\nG92 E0\n;TYPE:WALL-OUTER\n"
      "G0 X0 Y0 Z0.2\nG1 X10 E1 F1200\nG91\nG1 Y10 E1\nG90\n"
      "G1 X10 Y10 E-1\n"  // retraction (relative E, no motion)
      "G0 X20 Y0\nG1 E1\n"
      "G2 X30 Y0 I5 J0 E2\n"  // half circle, radius 5, clockwise over the top
      ";LAYER:1\nG20\nG1 Z0.0157\nG1 X1 Y0 E0.04\n";
  Diagnostics d;
  const Toolpath tp = read_gcode(g, {}, d, "t.gcode");
  EXPECT_EQ(d.total(), 0u);
  ASSERT_EQ(tp.layers.size(), 2u);
  ASSERT_EQ(tp.layers[0].paths.size(), 2u);
  const Path& p = tp.layers[0].paths[0];
  EXPECT_EQ(p.role, PathRole::Perimeter);
  EXPECT_NEAR(p.length(), 20, 1e-9);
  EXPECT_DOUBLE_EQ(p.speed, 20);
  const Path& arc = tp.layers[0].paths[1];
  EXPECT_NEAR(arc.length(), 5 * std::numbers::pi, 0.01);
  double top = 0;
  for (const auto& q : arc.points) top = std::max(top, q.y);
  EXPECT_NEAR(top, 5, 0.01);  // clockwise from (20,0) to (30,0) goes over the top
  EXPECT_NEAR(arc.filament, 2, 1e-9);
  // Inches: G20 then X1 = 25.4 mm.
  ASSERT_EQ(tp.layers[1].paths.size(), 1u);
  EXPECT_NEAR(tp.layers[1].paths[0].points.back().x, 25.4, 1e-9);
}

TEST(Reader, ToolsMixturesAndTemperaturesReachThePaths) {
  Diagnostics d;
  const Toolpath tp = read_gcode(
      "M104 S210\nG1 X1 E1\nT1\nM165 A0.25 B0.75\nM109 S225.5\nG1 X2 E2\nM104 Sabc\n", {}, d);
  ASSERT_EQ(tp.layers.size(), 1u);
  ASSERT_EQ(tp.layers[0].paths.size(), 2u);
  EXPECT_EQ(tp.layers[0].paths[0].temperature, 210);
  EXPECT_EQ(tp.layers[0].paths[0].tool, 0);
  EXPECT_EQ(tp.layers[0].paths[1].tool, 1);
  EXPECT_EQ(tp.layers[0].paths[1].mixture, (std::vector<double>{0.25, 0.75}));
  EXPECT_DOUBLE_EQ(tp.layers[0].paths[1].temperature, 225.5);
  EXPECT_EQ(d.count("gcode_bad_line"), 1u);
}

TEST(Reader, LineNumbersChecksumsCommentsAndSpellings) {
  Diagnostics d;
  const Toolpath tp = read_gcode(
      "N10 G1 X1 Y0 E1*45\ng1 x2 y0 e2\nG01 X3 Y0 E3 (inline comment) Y9\nG1 X4 Y0 E4 ; tail\n"
      "(whole-line comment)\n*17\nM104 S200*33\n",
      {}, d, "n.gcode");
  EXPECT_EQ(d.total(), 0u) << (d.messages().empty() ? "" : d.messages()[0].text);
  ASSERT_EQ(tp.layers.size(), 1u);
  ASSERT_EQ(tp.layers[0].paths.size(), 1u);
  const auto& pts = tp.layers[0].paths[0].points;
  ASSERT_EQ(pts.size(), 5u);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    EXPECT_DOUBLE_EQ(pts[i].x, static_cast<double>(i));
    EXPECT_DOUBLE_EQ(pts[i].y, 0.0);
  }
}

TEST(Reader, PrusaLayerCommentsAndLayersByZ) {
  Diagnostics d;
  const Toolpath a = read_gcode(
      ";LAYER_CHANGE\n;Z:0.2\nG1 Z0.2\nG1 X1 E1\n;LAYER_CHANGE\n;Z:0.4\nG1 Z0.4\nG1 X2 E2\n", {},
      d);
  EXPECT_EQ(a.layers.size(), 2u);
  const Toolpath b = read_gcode("G1 Z0.2\nG1 X1 E1\nG1 Z0.4\nG1 X2 E2\nG1 X3 E3\n", {}, d);
  ASSERT_EQ(b.layers.size(), 2u);
  EXPECT_NEAR(b.layers[1].z, 0.4, 1e-12);
}

TEST(Reader, MalformedLinesAreCountedOrStopTheRead) {
  const std::string bad =
      "G1 X1 Y2 E0.1\nG1 X@ Y3\nG1 X99999999999 E1\nG1 Xnan\n#garbage line\nG1 X5 Y5 E0.3\nG1 X7 Y";
  Diagnostics d;
  const Toolpath tp = read_gcode(bad, {}, d, "b.gcode");
  EXPECT_GE(d.count("gcode_bad_line"), 4u);
  ASSERT_EQ(tp.layers.size(), 1u);
  // (0,0)->(1,2)->(5,5): the bad lines in between are skipped, so the deposit runs on.
  ASSERT_EQ(tp.layers[0].paths.size(), 1u);
  EXPECT_EQ(tp.layers[0].paths[0].points.size(), 3u);
  bool named = false;
  for (const auto& m : d.messages()) named |= m.text.find("b.gcode:2") != std::string::npos;
  EXPECT_TRUE(named);
  GcodeReadOptions strict;
  strict.stop_on_error = true;
  try {
    read_gcode(bad, strict, d, "b.gcode");
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(e.where().line, 2);
  }
}
