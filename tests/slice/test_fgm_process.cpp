// Process fields (fprocess): temperature, speed, flow and fan along every printed path, checked
// on the written G-code by a replay that shares no code with the writer or the reader. It
// follows positions, E (M82/M83, G92), F, the heater commands of Marlin, RepRapFirmware and
// Klipper, M106/M107 and G4 line by line, and
// compares what each extruding move is printed with against the design's field at points along
// the move.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/slice/fgm_process.hpp"
#include "trellis/slice/pipeline.hpp"

using namespace trellis;

namespace {

struct Move {
  Vec3 a, b;
  double e = 0;             // filament of the move (mm)
  double feed = 0;          // mm/s
  double temperature = -1;  // target in force, -1 = never set
  double fan = -1;          // % in force, -1 = never set
  bool settled = true;      // a settle dwell came after the last temperature change
};

struct Replay {
  std::vector<Move> moves;
  Vec2 offset;
  std::size_t travels = 0, retractions = 0, temperature_changes = 0;
};

double word(const std::string& w) {
  return std::stod(w.substr(1));
}

Replay replay(const std::string& gcode, double settle) {
  Replay r;
  std::istringstream in(gcode);
  std::string line;
  Vec3 pos;
  double e = 0, feed = 0, temperature = -1, fan = -1;
  bool relative = false, settled = true, heated = false;
  while (std::getline(in, line)) {
    if (line.rfind("; placement offset = ", 0) == 0) {
      std::sscanf(line.c_str() + 21, "%lf, %lf", &r.offset.x, &r.offset.y);
      continue;
    }
    std::istringstream words(line.substr(0, line.find(';')));
    std::string cmd;
    if (!(words >> cmd)) continue;
    std::vector<std::string> args;
    for (std::string w; words >> w;) args.push_back(w);
    if (cmd == "M83") relative = true;
    if (cmd == "M82") relative = false;
    // A new target: a wait settles too; a set alone needs the dwell.
    const auto set_temperature = [&](double t, bool wait) {
      if (t <= 0) return;
      if (heated && t != temperature) {
        ++r.temperature_changes;
        settled = wait;
      }
      temperature = t;
      heated = true;
    };
    // Marlin M104/M109 S; RepRapFirmware M568 P<tool> S<t> (M116 waits); Klipper
    // SET_HEATER_TEMPERATURE HEATER=… TARGET=<t> (TEMPERATURE_WAIT waits).
    if (cmd == "M104" || cmd == "M109" || cmd == "M568")
      for (const auto& w : args)
        if (w[0] == 'S') set_temperature(word(w), cmd == "M109");
    if (cmd == "SET_HEATER_TEMPERATURE")
      for (const auto& w : args)
        if (w.rfind("TARGET=", 0) == 0) set_temperature(std::stod(w.substr(7)), false);
    if (cmd == "M116" || cmd == "TEMPERATURE_WAIT") settled = true;
    if (cmd == "M106")
      for (const auto& w : args)
        if (w[0] == 'S') fan = word(w) / 2.55;
    if (cmd == "M107") fan = 0;
    if (cmd == "G4") {
      double s = 0;
      for (const auto& w : args) s += w[0] == 'P' ? word(w) / 1000 : w[0] == 'S' ? word(w) : 0;
      if (s >= settle - 1e-9) settled = true;
    }
    if (cmd == "G92")
      for (const auto& w : args)
        if (w[0] == 'E') e = word(w);
    if (cmd == "G0" || cmd == "G1") {
      Vec3 to = pos;
      double e_to = relative ? 0 : e;
      bool has_e = false;
      for (const auto& w : args) {
        if (w[0] == 'X') to.x = word(w);
        if (w[0] == 'Y') to.y = word(w);
        if (w[0] == 'Z') to.z = word(w);
        if (w[0] == 'F') feed = word(w) / 60;
        if (w[0] == 'E') e_to = word(w), has_e = true;
      }
      const double de = has_e ? (relative ? e_to : e_to - e) : 0;
      if (has_e && !relative) e = e_to;
      const bool moved = distance(pos, to) > 1e-12;
      if (de > 0 && moved) {
        r.moves.push_back({pos, to, de, feed, temperature, fan, settled});
      } else if (de < 0) {
        ++r.retractions;
      } else if (moved && distance_xy(pos, to) > 1e-12) {
        ++r.travels;
      }
      pos = to;
    }
  }
  return r;
}

// A 20 mm disc, 2 mm thick, graded in every parameter: temperature and fan with z, speed with
// x, flow with y (design coordinates: centred, z from -1 to 1).
const char* kGraded = R"vcad(
fprocess(["200 + 10*(z+1)", "30 + 0.7*x", "1 + 0.02*y", "50 + 20*z"],
         ["temperature", "speed", "flow", "fan"]) {
  cylinder(10, 2);
}
)vcad";

MachineProfile fdm_profile() {
  MachineProfile p;
  p.bed_x = p.bed_y = 200;
  p.bed_z = 100;
  p.center = true;
  p.nozzle_temperature = 205;
  p.max_nozzle_temperature = 290;
  p.max_speed = 200;
  p.settle_time = 3;
  p.layer_height = 0.2;
  p.short_path_factor = 1;  // every path at its field speed (SplitPathsStayOneBead: not so)
  return p;
}

SliceJob job_for(const std::string& vcad) {
  SliceJob job;
  job.input = vcad;
  job.planar.layer_height = 0.2;
  job.planar.bead_width = 0.4;
  job.planar.top_layers = job.planar.bottom_layers = 2;
  job.process.min_length = 0;  // no merging: every piece carries its own rounded value
  job.process.max_temperature = 290;
  job.process.max_speed = 200;
  return job;
}

ProcessOptions b_options(const MachineProfile& prof) {
  ProcessOptions o;
  o.short_path_segments = prof.short_path_segments;
  o.short_path_factor = prof.short_path_factor;
  return o;
}

struct Sliced {
  SliceResult result;
  std::string gcode;
  GcodeStats stats;
};

Sliced slice(const std::string& text, SliceJob job, const MachineProfile& prof,
             trellis::test::TempDir& dir) {
  const std::string vcad = dir.file("design.vcad");
  write_file_atomic(vcad, text);
  job.input = vcad;
  Sliced s;
  s.result = run_slice(job);
  s.gcode = write_gcode(s.result.toolpath, prof, &s.stats);
  return s;
}

}  // namespace

TEST(ProcessFields, WrittenValuesFollowTheFieldWithinHalfAStep) {
  trellis::test::TempDir dir;
  const MachineProfile prof = fdm_profile();
  const Sliced s = slice(kGraded, job_for(""), prof, dir);
  ASSERT_TRUE(s.result.process.active);
  const Replay r = replay(s.gcode, prof.settle_time);
  ASSERT_GT(r.moves.size(), 1000u);
  Evaluator ev(parse_vcad(kGraded, "design.vcad").field);
  const ProcessOptions o;
  double worst[4] = {0, 0, 0, 0};
  std::size_t flow_checked = 0;
  for (const Move& m : r.moves) {
    ASSERT_GT(m.temperature, 0);
    ASSERT_GE(m.fan, 0);
    const auto li = static_cast<std::size_t>(std::lround(m.b.z / 0.2)) - 1;
    ASSERT_LT(li, s.result.outlines.size());
    const double len = distance(m.a, m.b);
    // Flow from E: the move's filament over Eq. 4's for its length (E has 5 decimals).
    const double flow = m.e / extrusion_for(len, 0.2, prof);
    for (double t : {0.0, 0.25, 0.5, 0.75, 1.0}) {
      const Vec3 q = m.a + (m.b - m.a) * t;
      const ProcessValues v =
          ev.process({q.x - r.offset.x, q.y - r.offset.y, s.result.outlines[li].z});
      worst[0] = std::max(worst[0], std::abs(m.temperature - v.value[0]));
      worst[1] = std::max(worst[1], std::abs(m.feed - v.value[1]));
      worst[3] = std::max(worst[3], std::abs(m.fan - v.value[3]));
      // X and Y have 3 decimals and E 5: the move's flow is known to within `known`.
      const double known = flow * 1.5e-3 / len + 1e-5 / extrusion_for(len, 0.2, prof);
      if (len > 0.3) worst[2] = std::max(worst[2], std::abs(flow - v.value[2]) - known);
    }
    flow_checked += len > 0.3;
  }
  EXPECT_GT(flow_checked, 200u);
  // Half a step, plus the G-code's own rounding (X/Y 1 µm; fan as S 0..255; E 5 decimals).
  EXPECT_LE(worst[0], o.temperature_step / 2 + 1e-3);
  EXPECT_LE(worst[1], o.speed_step / 2 + 0.7e-3 * 2);
  EXPECT_LE(worst[2], o.flow_step / 2 + 1e-9);
  EXPECT_LE(worst[3], o.fan_step / 2 + 0.5 / 2.55 + 1e-3);
  // The report says what the replay measures.
  const auto& p = s.result.process.param;
  EXPECT_LE(p[0].max_deviation, o.temperature_step / 2 + 1e-9);
  EXPECT_NEAR(p[0].min, 200, 1);
  EXPECT_NEAR(p[0].max, 220, 1);
  EXPECT_NEAR(p[1].max_deviation, o.speed_step / 2, 0.05);  // reached at the cuts
  EXPECT_TRUE(process_warnings(s.result.process, o).empty());
}

TEST(ProcessFields, EveryTemperatureChangeSettlesBeforeTheNextExtrusion) {
  trellis::test::TempDir dir;
  MachineProfile prof = fdm_profile();
  const Sliced s = slice(kGraded, job_for(""), prof, dir);
  const Replay r = replay(s.gcode, prof.settle_time);
  std::size_t unsettled = 0;
  for (const Move& m : r.moves) unsettled += !m.settled;
  EXPECT_EQ(unsettled, 0u);
  // 200 → 220 °C over ten layers in 1 °C steps: one change per layer at least.
  EXPECT_GE(r.temperature_changes, 9u);
  EXPECT_EQ(s.stats.temperature_changes, r.temperature_changes);
  EXPECT_NEAR(s.stats.settle_time_s, 3.0 * r.temperature_changes, 1e-9);
  // The dwell is in the time estimate.
  prof.settle_time = 0;
  GcodeStats quick;
  write_gcode(s.result.toolpath, prof, &quick);
  EXPECT_NEAR(s.stats.print_time_s - quick.print_time_s, 3.0 * r.temperature_changes, 1e-6);
}

// The temperature field in each firmware's own words (machine.flavor): RepRapFirmware's M568
// and Klipper's SET_HEATER_TEMPERATURE, read back by the replay, are within half a step of the
// field on every extruding move and settle before it, as Marlin's M104.
TEST(ProcessFields, EveryFirmwareWritesTheTemperatureField) {
  trellis::test::TempDir dir;
  for (const std::string flavor : {"marlin", "reprap", "klipper"}) {
    MachineProfile prof = fdm_profile();
    prof.flavor = flavor_from_string(flavor);
    const Sliced s = slice(kGraded, job_for(""), prof, dir);
    const Replay r = replay(s.gcode, prof.settle_time);
    ASSERT_GT(r.moves.size(), 1000u) << flavor;
    Evaluator ev(parse_vcad(kGraded, "design.vcad").field);
    double worst = 0;
    std::size_t unsettled = 0;
    for (const Move& m : r.moves) {
      ASSERT_GT(m.temperature, 0) << flavor << ": an extrusion before any temperature";
      const auto li = static_cast<std::size_t>(std::lround(m.b.z / 0.2)) - 1;
      ASSERT_LT(li, s.result.outlines.size());
      const Vec3 q = (m.a + m.b) * 0.5;
      worst = std::max(
          worst,
          std::abs(
              m.temperature -
              ev.process({q.x - r.offset.x, q.y - r.offset.y, s.result.outlines[li].z}).value[0]));
      unsettled += !m.settled;
    }
    EXPECT_LE(worst, 0.5 + 1e-3) << flavor;
    EXPECT_EQ(unsettled, 0u) << flavor;
    EXPECT_GE(r.temperature_changes, 9u) << flavor;
    EXPECT_EQ(s.stats.temperature_changes, r.temperature_changes) << flavor;
  }
}

TEST(ProcessFields, SplitPathsStayOneBead) {
  // Splitting where the speed changes adds no travel, retraction or priming: the same travels
  // and retractions as the design without the field, and the filament is Eq. 4's times flow.
  trellis::test::TempDir dir;
  MachineProfile prof = fdm_profile();
  prof.retract_length = 0.8;
  prof.pre_flow = 0.3;
  prof.post_flow = 0.2;
  prof.short_path_segments = 4;
  prof.short_path_factor = 0.5;
  const char* plain = "cylinder(10, 2);";
  const char* graded = R"vcad(fprocess(["30 + 0.7*x"], ["speed"]) { cylinder(10, 2); })vcad";
  SliceJob job = job_for("");
  job.process = b_options(prof);
  job.process.min_length = 0;
  // Fill lines printed one by one, so that many paths are short (the linking stage would join
  // them into a few long serpentines, leaving the short-path rule nothing to slow).
  job.planar.link.connect = false;
  const Sliced a = slice(plain, job, prof, dir);
  const Sliced b = slice(graded, job, prof, dir);
  const Replay ra = replay(a.gcode, 0), rb = replay(b.gcode, 0);
  EXPECT_GT(b.result.process.pieces, b.result.process.paths + 100);  // split along paths
  EXPECT_EQ(ra.travels, rb.travels);
  EXPECT_EQ(ra.retractions, rb.retractions);
  EXPECT_NEAR(a.stats.filament, b.stats.filament, 1e-3);
  EXPECT_EQ(a.stats.paths, b.stats.paths);
  // The short-path factor slows the same beads as without the field (a split path is not
  // short because it has more pieces), and every other move is at its field speed.
  Evaluator ev(parse_vcad(graded, "d.vcad").field);
  double slow_a = 0, slow_b = 0;
  for (const Move& m : ra.moves)
    if (std::abs(m.feed - prof.print_speed * prof.short_path_factor) < 1e-6)
      slow_a += distance(m.a, m.b);
  for (const Move& m : rb.moves) {
    const Vec3 q = (m.a + m.b) * 0.5;
    const double field = ev.process({q.x - rb.offset.x, q.y - rb.offset.y, 0}).value[1];
    const bool slow = std::abs(m.feed - field * prof.short_path_factor) <= 0.25 + 1e-3;
    if (slow)
      slow_b += distance(m.a, m.b);
    else
      EXPECT_NEAR(m.feed, field, 0.5 + 1e-3);
  }
  EXPECT_GT(slow_a, 10);
  EXPECT_NEAR(slow_a, slow_b, 1e-3 * slow_a);
  EXPECT_GT(b.result.process.short_slowed, 10u);
  EXPECT_FALSE(process_warnings(b.result.process, b_options(prof)).empty());
}

TEST(ProcessFields, OutOfRangeIsRefusedNamingTheNode) {
  trellis::test::TempDir dir;
  const MachineProfile prof = fdm_profile();
  auto refused = [&](const std::string& text, const std::string& expect) {
    try {
      slice(text, job_for(""), prof, dir);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const GeometryError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("fprocess at design.vcad:2"), std::string::npos) << m;
      EXPECT_NE(m.find(expect), std::string::npos) << m;
    }
  };
  refused("\nfprocess([\"280 + 20*(z+1)\"], [\"temperature\"]) { cylinder(10, 2); }",
          "temperature.max_nozzle = 290");
  refused("\nfprocess([\"250 + 10*x\"], [\"speed\"]) { cylinder(10, 2); }", "speed.max = 200");
  refused("\nfprocess([\"110 - 10*z\"], [\"fan\"]) { cylinder(10, 2); }", "0 to 100 %");
  refused("\nfprocess([\"x/10\"], [\"flow\"]) { cylinder(10, 2); }", "flow");
  // In range everywhere it prints: accepted.
  EXPECT_NO_THROW(slice("\nfprocess([\"100 - 10*(z+1)\"], [\"fan\"]) { cylinder(10, 2); }",
                        job_for(""), prof, dir));
}

TEST(ProcessFields, TheLanguageNamesMistakes) {
  auto fails = [](const std::string& text, const std::string& expect) {
    try {
      parse_vcad(text, "d.vcad");
      ADD_FAILURE() << "parsed: " << text;
    } catch (const ParseError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  };
  fails("fprocess([\"200\"], [\"temp\"]) { sphere(1); }", "unknown parameter 'temp'");
  fails("fprocess([\"200\", \"210\"], [\"temperature\", \"temperature\"]) { sphere(1); }",
        "given twice");
  fails("fprocess([\"200\"], [\"temperature\", \"fan\"]) { sphere(1); }", "1 expressions but 2");
  fails("fprocess([\"200 +\"], [\"temperature\"]) { sphere(1); }", "d.vcad:1");
  // The innermost node sets a parameter; a union's point takes the part that holds it.
  const Field f = parse_vcad(R"vcad(fprocess(["200", "40"], ["temperature", "speed"]) {
    union() {
      translate(-10, 0, 0) { fprocess(["230"], ["temperature"]) { sphere(3); } }
      translate(10, 0, 0) { sphere(3); }
    }
  })vcad",
                             "d.vcad")
                      .field;
  Evaluator ev(f);
  EXPECT_EQ(ev.process({-10, 0, 0}).value[0], 230);
  EXPECT_EQ(ev.process({10, 0, 0}).value[0], 200);
  EXPECT_EQ(ev.process({-10, 0, 0}).value[1], 40);
  EXPECT_TRUE(std::isnan(ev.process({0, 0, 0}).value[2]));
}

TEST(ProcessFields, UnsetParametersKeepTheProfilesValues) {
  // Two discs: the left one hot and fanless by its own fprocess, the right one with none: the
  // right one prints at the profile's temperature and fan, also after the left one.
  trellis::test::TempDir dir;
  MachineProfile prof = fdm_profile();
  prof.fan_percent = 40;
  const Sliced s = slice(R"vcad(union() {
    translate(-15, 0, 0) { fprocess(["230", "0"], ["temperature", "fan"]) { cylinder(8, 2); } }
    translate(15, 0, 0) { cylinder(8, 2); }
  })vcad",
                         job_for(""), prof, dir);
  const Replay r = replay(s.gcode, prof.settle_time);
  std::size_t left = 0, right = 0, unsettled = 0;
  for (const Move& m : r.moves) {
    unsettled += !m.settled;
    if ((m.a.x + m.b.x) / 2 - r.offset.x < 0) {
      ++left;
      EXPECT_EQ(m.temperature, 230);
      EXPECT_NEAR(m.fan, 0, 1e-9);
    } else {
      ++right;
      EXPECT_EQ(m.temperature, prof.nozzle_temperature);
      EXPECT_NEAR(m.fan, 40, 0.5 / 2.55);
    }
  }
  EXPECT_GT(left, 100u);
  EXPECT_GT(right, 100u);
  EXPECT_EQ(unsettled, 0u);
  EXPECT_GE(r.temperature_changes, 10u);  // back and forth on every layer
}

TEST(ProcessFields, MergedPiecesBeyondHalfAStepAreReported) {
  trellis::test::TempDir dir;
  SliceJob job = job_for("");
  job.process.min_length = 3;  // merges pieces of a fast-changing speed field
  const Sliced s = slice(R"vcad(fprocess(["30 + 2*x"], ["speed"]) { cylinder(10, 2); })vcad", job,
                         fdm_profile(), dir);
  EXPECT_GT(s.result.process.merged, 0u);
  EXPECT_GT(s.result.process.param[1].max_deviation, 0.5);
  ASSERT_EQ(process_warnings(s.result.process, job.process).size(), 1u);
  EXPECT_EQ(process_warnings(s.result.process, job.process)[0].first, "process_quantisation");
  EXPECT_NE(process_warnings(s.result.process, job.process)[0].second.find("speed"),
            std::string::npos);
}

TEST(ProcessFields, RefusedWhereTheyCannotPrint) {
  trellis::test::TempDir dir;
  // A pneumatic machine has no E to scale and no fan.
  SliceJob job = job_for("");
  const std::string vcad = dir.file("d.vcad");
  write_file_atomic(vcad, R"vcad(fprocess(["0.8"], ["flow"]) { cylinder(10, 2); })vcad");
  job.input = vcad;
  const SliceResult r = run_slice(job);
  MachineProfile pn = fdm_profile();
  pn.flavor = Flavor::Pneumatic;
  pn.valve_on = "M106";
  pn.valve_off = "M107";
  EXPECT_THROW(write_gcode(r.toolpath, pn), MachineError);
  // Shards cannot carry them.
  job.layer_begin = 0;
  job.layer_end = 5;
  EXPECT_THROW(run_slice(job), SettingError);
}

// A path with a point that is not finite, or a segment that would need more samples than an int
// holds (a float -> int overflow before), is refused naming process.sample; nothing is split.
TEST(ProcessFields, NonFiniteOrRunawaySamplingIsRefused) {
  const Field f =
      parse_vcad(R"vcad(fprocess(["200 + x"], ["temperature"]) { cube(1e5); })vcad", "d.vcad")
          .field;
  auto refused = [&](std::vector<Vec3> points, double sample, const std::string& expect) {
    Toolpath tp;
    Path p;
    p.points = std::move(points);
    p.role = PathRole::Perimeter;
    tp.layers.push_back({0.2, {p}});
    ProcessOptions o;
    o.sample = sample;
    try {
      apply_process_fields(f, tp, o);
      ADD_FAILURE() << "accepted: " << expect;
    } catch (const GeometryError& e) {
      EXPECT_EQ(e.where().element, "process.sample");
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
    ASSERT_EQ(tp.layers[0].paths.size(), 1u);
  };
  const double inf = std::numeric_limits<double>::infinity();
  refused({{0, 0, 0.2}, {inf, 0, 0.2}}, 0.2, "not finite");
  refused({{0, 0, 0.2}, {std::nan(""), 0, 0.2}}, 0.2, "not finite");
  refused({{0, 0, 0.2}, {1e4, 0, 0.2}}, 1e-9, "raise process.sample");
}
