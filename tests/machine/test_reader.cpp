#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "support/gcode_log_sink.hpp"
#include "support/machines.hpp"
#include "support/random_graphs.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/rng.hpp"
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
  if (profile.flavor == Flavor::Pneumatic) {
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
      if (profile.flavor == Flavor::Marlin) {
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
  pneumatic.flavor = Flavor::Pneumatic;
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

// A pneumatic file Trellis wrote names its valve commands in its job header: read with no valve
// options it gives what the profile's commands give. A Marlin file's header also lists
// [pneumatic] (valve_on = 'M106', the fan): it is not taken, the file reads by E as before.
TEST(Reader, OurPneumaticFilesReadBackFromTheirHeader) {
  MachineProfile pneumatic = test::open_bed();
  pneumatic.flavor = Flavor::Pneumatic;
  pneumatic.valve_on = "M3 ; valve open";
  pneumatic.valve_off = "M5";
  AtlasParams a;
  a.pattern = pattern_from_string("honeycomb");
  a.region.width = a.region.height = 6;
  const Toolpath tp = planned(make_lattice2d(a), Planner::Gippo);
  const std::string body = write_gcode(tp, pneumatic);
  GcodeReadOptions given;
  given.valve_on = pneumatic.valve_on;
  given.valve_off = pneumatic.valve_off;
  Diagnostics d;
  const Toolpath expected = read_gcode(body, given, d, "given.nc");
  ASSERT_GT(expected.path_count(), 0u);
  const std::string header =
      "; job: [machine]\n; job: flavor = 'pneumatic'\n; job: [pneumatic]\n"
      "; job: valve_on = 'M3 ; valve open'\n; job: valve_off = \"M5\"\n";
  const Toolpath back = read_gcode(header + body, {}, d, "header.nc");
  EXPECT_EQ(back.path_count(), expected.path_count());
  EXPECT_NEAR(back.extrusion_length(), expected.extrusion_length(), 1e-9);
  EXPECT_EQ(read_gcode(body, {}, d, "bare.nc").path_count(), 0u);  // no header, no options

  MachineProfile marlin = test::open_bed();
  const std::string mbody = write_gcode(tp, marlin);
  const std::string mheader =
      "; job: [machine]\n; job: flavor = 'marlin'\n; job: [pneumatic]\n"
      "; job: valve_on = 'M106'\n; job: valve_off = 'M107'\n";
  const Toolpath m0 = read_gcode(mbody, {}, d, "m.gcode");
  const Toolpath m1 = read_gcode(mheader + mbody, {}, d, "mh.gcode");
  EXPECT_EQ(m1.path_count(), m0.path_count());
  EXPECT_NEAR(m1.extrusion_length(), m0.extrusion_length(), 1e-9);
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

TEST(Reader, ValveCommandsMatchWholeWords) {
  // M300 is a beep, not the valve command M3: the move after it must not extrude.
  GcodeReadOptions opt;
  opt.valve_on = "M3";
  opt.valve_off = "M5";
  Diagnostics d;
  const Toolpath tp = read_gcode(
      "G0 X0 Y0\nM300 S440 P200\nG1 X10 Y0\nM3 S1000\nG1 X20 Y0\nM5\nM3;open\nG1 X30 Y0\nM50\n"
      "G1 X40 Y0\n",
      opt, d);
  ASSERT_EQ(tp.layers.size(), 1u);
  ASSERT_EQ(tp.layers[0].paths.size(), 1u);
  const auto& pts = tp.layers[0].paths[0].points;
  // Open from "M3 S1000" (x = 10) on; M5 and "M3;open" close and reopen it without a move, and
  // M50 is not M5: one path from 10 to 40. Prefix matching would start it at 0 (M300) and end it
  // at 30 (M50).
  EXPECT_DOUBLE_EQ(pts.front().x, 10);
  EXPECT_DOUBLE_EQ(pts.back().x, 40);
}

TEST(Reader, RepRapFirmwareAndKlipperDialects) {
  Diagnostics d;
  // RepRapFirmware: tool temperatures by M568 / G10 P, mixing by M567 P<tool> E<a>:<b>.
  const Toolpath rrf = read_gcode(
      "M568 P0 S205 R150\nG10 P1 S230 R160\nM567 P1 E0.3:0.7\nT0\nG1 X1 E1\nT1\nG1 X2 E2\n"
      "M568 P1 S240\nG1 X3 E3\nG10 ; a firmware retraction, not a tool setting\nG1 X4 E4\n",
      {}, d, "rrf");
  EXPECT_EQ(d.total(), 0u) << (d.messages().empty() ? "" : d.messages()[0].text);
  ASSERT_EQ(rrf.layers.size(), 1u);
  const auto& r = rrf.layers[0].paths;
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0].tool, 0);
  EXPECT_EQ(r[0].temperature, 205);
  EXPECT_TRUE(r[0].mixture.empty());
  EXPECT_EQ(r[1].tool, 1);
  EXPECT_EQ(r[1].temperature, 230);
  EXPECT_EQ(r[1].mixture, (std::vector<double>{0.3, 0.7}));
  EXPECT_EQ(r[2].temperature, 240);  // the tool in use changed its temperature
  // Klipper: ACTIVATE_EXTRUDER and SET_HEATER_TEMPERATURE; the bed heater is not a nozzle.
  const Toolpath kl = read_gcode(
      "SET_HEATER_TEMPERATURE HEATER=extruder TARGET=200\n"
      "SET_HEATER_TEMPERATURE HEATER=extruder1 TARGET=215\n"
      "SET_HEATER_TEMPERATURE HEATER=heater_bed TARGET=60\nG1 X1 E1\n"
      "ACTIVATE_EXTRUDER EXTRUDER=extruder1\nG1 X2 E2\nM104 T0 S190\n"
      "ACTIVATE_EXTRUDER EXTRUDER=extruder\nG1 X3 E3\n",
      {}, d, "klipper");
  EXPECT_EQ(d.total(), 0u) << (d.messages().empty() ? "" : d.messages()[0].text);
  ASSERT_EQ(kl.layers.size(), 1u);
  const auto& k = kl.layers[0].paths;
  ASSERT_EQ(k.size(), 3u);
  EXPECT_EQ(k[0].tool, 0);
  EXPECT_EQ(k[0].temperature, 200);
  EXPECT_EQ(k[1].tool, 1);
  EXPECT_EQ(k[1].temperature, 215);
  EXPECT_EQ(k[2].tool, 0);
  EXPECT_EQ(k[2].temperature, 190);
  // Marlin's M163/M164 virtual-tool mix, normalised.
  const Toolpath m = read_gcode("M163 S0 P1\nM163 S1 P3\nM164 S0\nG1 X1 E1\n", {}, d, "m163");
  ASSERT_EQ(m.layers.size(), 1u);
  EXPECT_EQ(m.layers[0].paths[0].mixture, (std::vector<double>{0.25, 0.75}));
  // A bad mix ratio is a named bad line.
  Diagnostics bad;
  read_gcode("M567 P0 E0.5:x\n", {}, bad, "bad");
  EXPECT_EQ(bad.count("gcode_bad_line"), 1u);
}

namespace {

// Every event a scanner reports (support/gcode_log_sink.hpp).
using RecordingSink = trellis::test::LogSink;

// Events and warnings of `text` read line by line (line(): the general reader) or fed in chunks
// of `chunk` bytes (feed(): the one-pass reader of plain G0/G1 lines, the general one for the
// rest).
std::string scan_log(std::string_view text, std::size_t chunk) {
  RecordingSink sink;
  Diagnostics diag;
  GcodeScanner scanner(sink, {}, diag, "t");
  if (chunk == 0) {
    for (std::size_t pos = 0; pos < text.size();) {
      const std::size_t nl = std::min(text.find('\n', pos), text.size());
      scanner.line(text.substr(pos, nl - pos));
      pos = nl + 1;
    }
  } else {
    for (std::size_t pos = 0; pos < text.size(); pos += chunk)
      scanner.feed(text.substr(pos, chunk));
    scanner.finish();
  }
  for (const auto& m : diag.messages()) sink.log += m.kind + ": " + m.text + "\n";
  for (const auto& [kind, count] : diag.counts())
    sink.log += kind + " x" + std::to_string(count) + "\n";
  return sink.log + "lines " + std::to_string(scanner.lines()) + "\n";
}

}  // namespace

// The one-pass reader of plain moves must not change a result: on our own G-code and on lines
// made to fall just inside or outside what it takes (spellings, blanks, comments, checksums,
// bad and long numbers, duplicate words, relative modes, arcs, inches), every event and every
// warning is the one the general reader gives, whatever the chunks the text comes in.
TEST(Reader, OnePassMovesReadExactlyAsTheGeneralReader) {
  MachineProfile profile;
  profile.retract_length = 0.8;
  profile.z_hop = 0.2;
  Toolpath tp;
  Rng rng(5);
  for (int l = 0; l < 3; ++l) {
    Layer layer{0.2 * (l + 1), {}};
    for (int k = 0; k < 40; ++k) {
      Path path;
      Vec3 q{rng.uniform01() * 200, rng.uniform01() * 200, layer.z};
      for (int i = 0; i < 6; ++i) {
        path.points.push_back(q);
        q = q + Vec3{rng.uniform01() - 0.5, rng.uniform01() - 0.5, 0};
      }
      path.speed = 10 + k % 3;
      layer.paths.push_back(std::move(path));
    }
    tp.layers.push_back(std::move(layer));
  }
  std::string text = write_gcode(tp, profile);
  text +=
      "G1 X1 Y2 E3\ng1 x1 y2\nG1 X1\tY2\nG1 X1 Y2\r\nG1 X1 Y2  \n  G1 X3\nG1 X1 Y2 ;c\nG1 X1;c\n"
      "G1 X1 Y2*57\nG1 X1(c) Y2\nN10 G1 X4\nG1 X1Y2\nG1 X1E5\nG1 X1e5\nG1 X1E-5\nG1 X+5 Y.5 Z5.\n"
      "G1 X-0 Y-.25\nG1 X1234567.5\nG1 X999999.9999\nG1 X1000000.0001\nG1 X1000001\n"
      "G1 X1.2345678901234567 Y2\nG1 X12345678901234567\nG1 X1 X2\nG1 X\nG1 X-\nG1 X.\nG1 X1 F0\n"
      "G1 X1 F-5\nG1 F1200\nG1 A1 B2 C3 D4 H5 K6 L7 M8 N9 O1 P2 Q3 S4 T5 U6 V7 W8\n"
      "G1 X1 Y1 Z1 E1 F1 A1 B1 C1 D1 H1 I1 J1 K1 L1 M1 N1 O1\nG0 X5 Y5\nG0 \nG1\nG10\nG1 E-1\n"
      "G92 E0\nG1 X2 E1\nG91\nG1 X1 Y1 E.5\nM83\nG1 X1 E.1\nG90\nM82\nG20\nG1 X1 Y1\nG21\n"
      "G2 X10 Y0 I5 J0 E2\nG3 X0 Y0 R5 E3\nG1 X5 Y5 E4 F600\nG1 X5 Y5 E4\nG1 X5 Y5 E3\n"
      ";LAYER_CHANGE\n;TYPE:Perimeter\n;WIDTH:0.45\nG1 X6 Y6 E5\nG1 X7 Y7 E6";
  const std::string general = scan_log(text, 0);
  EXPECT_GT(general.size(), 10000u);
  for (std::size_t chunk :
       {std::size_t{1}, std::size_t{7}, std::size_t{64}, std::size_t{4096}, text.size()})
    EXPECT_EQ(scan_log(text, chunk), general) << "chunks of " << chunk;
}
