// The prime tower of Strategy 1, checked on the written G-code by a replay that shares no code
// with the writer or the reader: positions, E, mixtures (M165) and tools (T) are followed line
// by line, and what lies off the part's footprint is the tower.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/slice/fgm.hpp"
#include "trellis/slice/pipeline.hpp"

using namespace trellis;

namespace {

struct Segment {
  Vec3 a, b;
  std::string mixture;     // the M165 / T command in force
  std::size_t change = 0;  // changes issued before it
  bool continues = false;  // follows the previous extrusion without a travel
};

struct Replay {
  std::vector<Segment> segments;
  std::vector<std::string> changes;           // commands, in order
  std::vector<std::vector<double>> mixtures;  // parsed M165 fractions per change
  Vec2 offset;
  std::size_t changes_inside_paths = 0;  // a change between two joined extrusions
  // Extrusions by a tool whose temperature was never set, or not waited for since it was.
  std::size_t cold_extrusions = 0;
  std::set<int> tools;  // tools that extruded
};

Replay replay(const std::string& gcode) {
  Replay r;
  std::istringstream in(gcode);
  std::string line;
  Vec3 pos;
  double e = 0;
  bool relative = false, extruding = false;
  std::string current;
  bool change_pending = false;
  int active = 0;
  std::map<int, double> target;
  std::set<int> waited;
  std::vector<double> pending;  // M163 factors before M164
  while (std::getline(in, line)) {
    if (line.rfind("; placement offset = ", 0) == 0) {
      std::sscanf(line.c_str() + 21, "%lf, %lf", &r.offset.x, &r.offset.y);
      continue;
    }
    const std::string code = line.substr(0, line.find(';'));
    std::istringstream words(code);
    std::string cmd;
    if (!(words >> cmd)) continue;
    if (cmd == "M83") relative = true;
    if (cmd == "M82") relative = false;
    if (cmd == "M104" || cmd == "M109") {
      int tool = active;
      double t = -1;
      for (std::string w; words >> w;) {
        if (w[0] == 'T') tool = std::stoi(w.substr(1));
        if (w[0] == 'S') t = std::stod(w.substr(1));
      }
      if (t >= 0) {
        target[tool] = t;
        waited.erase(tool);
      }
      if (cmd == "M109") waited.insert(tool);
      continue;
    }
    // Mixture commands of every dialect the writer has, and tool selection.
    auto change = [&](const std::vector<double>& mix) {
      current = code;
      r.changes.push_back(code);
      r.mixtures.push_back(mix);
      change_pending = extruding;
    };
    if (cmd == "M163") {
      int i = 0;
      double v = 0;
      for (std::string w; words >> w;) {
        if (w[0] == 'S') i = std::stoi(w.substr(1));
        if (w[0] == 'P') v = std::stod(w.substr(1));
      }
      if (pending.size() <= static_cast<std::size_t>(i)) pending.resize(i + 1);
      pending[i] = v;
      continue;
    }
    if (cmd == "M164") {
      change(pending);
      continue;
    }
    if (cmd == "M567" || cmd == "SET_MIX") {
      std::vector<double> mix;
      for (std::string w; words >> w;) {
        if (cmd == "SET_MIX") mix.push_back(std::stod(w.substr(w.find('=') + 1)));
        if (cmd == "M567" && w[0] == 'E')
          for (std::size_t a = 1; a < w.size();) {
            const std::size_t b = std::min(w.find(':', a), w.size());
            mix.push_back(std::stod(w.substr(a, b - a)));
            a = b + 1;
          }
      }
      change(mix);
      continue;
    }
    if (cmd == "M165" || (cmd[0] == 'T' && cmd.size() > 1)) {
      if (cmd[0] == 'T') active = std::stoi(cmd.substr(1));
      std::vector<double> mix;
      for (std::string w; words >> w;) mix.push_back(std::stod(w.substr(1)));
      change(mix);
      continue;
    }
    if (cmd == "G92") {
      for (std::string w; words >> w;)
        if (w[0] == 'E') e = std::stod(w.substr(1));
      continue;
    }
    if (cmd != "G0" && cmd != "G1") continue;
    Vec3 q = pos;
    double de = 0;
    bool has_e = false;
    for (std::string w; words >> w;) {
      const double v = std::stod(w.substr(1));
      if (w[0] == 'X') q.x = v;
      if (w[0] == 'Y') q.y = v;
      if (w[0] == 'Z') q.z = v;
      if (w[0] == 'E') {
        has_e = true;
        de = relative ? v : v - e;
        e = relative ? e + v : v;
      }
    }
    const bool moves = std::hypot(q.x - pos.x, q.y - pos.y) > 1e-9;
    if (cmd == "G1" && has_e && de > 0 && moves) {
      if (change_pending) ++r.changes_inside_paths;
      if (!(target[active] > 0) || !waited.count(active)) ++r.cold_extrusions;
      r.tools.insert(active);
      r.segments.push_back({pos, q, current, r.changes.size(), extruding});
      extruding = true;
    } else if (moves || std::abs(q.z - pos.z) > 1e-9) {
      extruding = false;
    }
    change_pending = false;
    pos = q;
  }
  return r;
}

Field design(const std::string& text) {
  return parse_vcad(text, "test.vcad").field;
}

struct Plan {
  std::vector<double> zs;
  std::vector<LayerOutline> outlines;
  Toolpath planar, graded;
  FgmStats stats;
  FgmOptions options;
};

// Strategy 1 in the paper's face order (a purge between colours), unless a tool changer's
// path order (pieces grouped by tool) is asked for.
Plan plan(const Field& f, int colors, const PurgeOptions& purge, double h = 0.2,
          bool tool_changer = false) {
  Plan p;
  const BBox3 e = f.extent();
  p.zs = layer_planes(e.min.z, e.max.z, h);
  p.outlines = slice_field(f, p.zs, FieldSliceOptions{});
  PlanarOptions po;
  po.layer_height = h;
  po.top_layers = po.bottom_layers = 1;
  p.planar = plan_planar(p.outlines, po);
  p.options.palette.colors = colors;
  p.options.layer_height = h;
  p.options.bead_width = po.bead_width;
  p.options.material_resolution = 0.5;
  p.options.order = tool_changer ? FgmOrder::Paths : FgmOrder::Faces;
  p.options.tool_changer = tool_changer;
  p.graded = plan_fgm_strategy1(f, p.outlines, p.planar, p.options, purge, &p.stats);
  return p;
}

// A 40 x 20 mm plate graded along X, six layers.
const char* kPlate =
    "fgrade([\"0.5 + x/40\", \"0.5 - x/40\"], [\"a\", \"b\"]) {\n  rectprism(40, 20, 1.2);\n}\n";

PurgeOptions bed_purge(double bed_x, double bed_y) {
  PurgeOptions o;
  o.melt_volume = 20;
  o.bed_x = bed_x;
  o.bed_y = bed_y;
  o.centred = true;
  return o;
}

struct Checked {
  std::size_t changes = 0, tower_layers = 0;
  double worst_error = 0, least_purge = 1e300, least_gap = 1e300;
};

// The must-hold properties of a tower print, on the replayed G-code.
Checked check_tower_print(const Plan& p, const Field& f, const MachineProfile& prof,
                          double clearance) {
  const std::string gcode = write_gcode(p.graded, prof);
  const Replay r = replay(gcode);
  Checked c;
  const double w = p.options.bead_width, h = p.options.layer_height;
  // The part's bead footprint on the bed.
  BBox3 part;
  for (const auto& l : p.planar.layers)
    for (const auto& q : l.paths)
      for (const auto& v : q.points) part.add({v.x + r.offset.x, v.y + r.offset.y, 0});
  part.min = part.min - Vec3{w / 2, w / 2, 0};
  part.max = part.max + Vec3{w / 2, w / 2, 0};
  auto on_part = [&](const Segment& s) {
    const Vec3 m = (s.a + s.b) * 0.5;
    return m.x >= part.min.x - 1e-3 && m.x <= part.max.x + 1e-3 && m.y >= part.min.y - 1e-3 &&
           m.y <= part.max.y + 1e-3;
  };
  const double L = purge_length(20, h, w);
  // 1. Every change (after the first selection) is followed by at least L mm in the tower
  //    before the part is printed again.
  std::map<std::size_t, double> tower_after;  // change index -> tower mm before part
  std::map<std::size_t, bool> closed;
  for (const auto& s : r.segments) {
    if (s.change < 2) continue;  // the first command selects, it changes nothing
    if (closed[s.change]) continue;
    if (on_part(s)) {
      closed[s.change] = true;
      EXPECT_GE(tower_after[s.change], L - 1e-3) << "change " << s.change << ": " << s.mixture;
      c.least_purge = std::min(c.least_purge, tower_after[s.change]);
    } else {
      tower_after[s.change] += distance_xy(s.a, s.b);
    }
  }
  c.changes = r.changes.size() > 0 ? r.changes.size() - 1 : 0;
  EXPECT_EQ(closed.size(), c.changes);
  // 2. The tower keeps the clearance from the part and stays on the bed; 3. every tower layer
  //    above the first sits on a tower layer below.
  std::map<long, BBox3> tower_layers;
  Evaluator ev(f);
  for (const auto& s : r.segments) {
    EXPECT_GE(std::min(s.a.x, s.b.x), w / 2 - 1e-3);
    EXPECT_LE(std::max(s.a.x, s.b.x), prof.bed_x - w / 2 + 1e-3);
    EXPECT_GE(std::min(s.a.y, s.b.y), w / 2 - 1e-3);
    EXPECT_LE(std::max(s.a.y, s.b.y), prof.bed_y - w / 2 + 1e-3);
    const long layer = std::lround(s.b.z / h);
    if (!on_part(s)) {
      BBox3& b = tower_layers[layer];
      b.add({s.a.x, s.a.y, 0});
      b.add({s.b.x, s.b.y, 0});
      const double gap = std::max({std::min(s.a.x, s.b.x) - w / 2 - part.max.x,
                                   part.min.x - std::max(s.a.x, s.b.x) - w / 2,
                                   std::min(s.a.y, s.b.y) - w / 2 - part.max.y,
                                   part.min.y - std::max(s.a.y, s.b.y) - w / 2});
      c.least_gap = std::min(c.least_gap, gap);
      continue;
    }
    // 4. The gradient error of what is printed: the design at the layer's plane against the
    //    mixture in force.
    const auto li = static_cast<std::size_t>(layer) - 1;
    EXPECT_LT(li, p.zs.size());
    if (li >= p.zs.size()) continue;
    const auto& mix = r.mixtures[s.change - 1];
    for (double t : {0.0, 0.5, 1.0}) {
      const Vec3 q = s.a + (s.b - s.a) * t;
      const double frac =
          std::clamp(ev.fractions({q.x - r.offset.x, q.y - r.offset.y, p.zs[li]})[0], 0.0, 1.0);
      c.worst_error = std::max(c.worst_error, std::abs(frac - mix[0]));
    }
  }
  EXPECT_GE(c.least_gap, clearance - 1e-3);
  EXPECT_FALSE(tower_layers.empty());
  if (tower_layers.empty()) return c;
  EXPECT_EQ(tower_layers.begin()->first, 1) << "the tower starts on the bed";
  long expect = 1;
  const BBox3* below = nullptr;
  for (const auto& [layer, box] : tower_layers) {
    EXPECT_EQ(layer, expect++) << "a tower layer is missing below layer " << layer;
    if (below) {
      EXPECT_GE(box.min.x, below->min.x - 1e-3);
      EXPECT_LE(box.max.x, below->max.x + 1e-3);
      EXPECT_GE(box.min.y, below->min.y - 1e-3);
      EXPECT_LE(box.max.y, below->max.y + 1e-3);
    }
    below = &box;
  }
  c.tower_layers = tower_layers.size();
  EXPECT_EQ(r.changes_inside_paths, 0u);
  return c;
}

// A five-tool changer on a 360 mm bed, centred, each tool one gradient step of two materials.
MachineProfile tool_changer() {
  MachineProfile prof;
  prof.mixing_inputs = 2;
  prof.tool_count = 5;
  prof.bed_x = prof.bed_y = 360;
  prof.center = true;
  prof.gradient_mode = GradientMode::Tools;
  prof.gradient_tools = 5;
  return prof;
}

}  // namespace

TEST(PrimeTower, MixingChangesFlushIntoATowerBesideThePart) {
  const Field f = design(kPlate);
  const Plan p = plan(f, 4, bed_purge(200, 200));
  ASSERT_TRUE(p.stats.tower.built);
  EXPECT_GT(p.stats.purges, 5u);
  MachineProfile prof;
  prof.mixing_inputs = 2;
  prof.tool_count = 5;
  prof.bed_x = prof.bed_y = 200;
  prof.center = true;
  prof.lookahead = 960;  // ignored: the tower flushes the dead volume
  const Checked c = check_tower_print(p, f, prof, 5);
  EXPECT_EQ(c.changes, p.stats.purges);
  EXPECT_EQ(c.tower_layers, p.stats.tower.layers);
  EXPECT_LE(c.worst_error, p.options.palette.error_bound() + 1e-3);
  // Sized by Eq. A.1: the busiest layer's purges fill its dense lines, the side is not larger
  // than one bead more would need.
  EXPECT_GE(p.stats.purge_length, p.stats.purges * purge_length(20, 0.2, 0.4) - 1e-6);
  // Per colour: lengths add up, masses follow the volume at 1.24 g/cm³.
  double length = 0;
  for (const auto& col : p.stats.tower.colours) length += col.length;
  EXPECT_NEAR(length, p.stats.tower.length, 1e-6);
  EXPECT_NEAR(p.stats.tower.mass, p.stats.tower.volume * 1.24e-3, 1e-9);
}

TEST(PrimeTower, ToolChangesHappenAtPathEndsAndPrimeInTheTower) {
  const Field f = design(kPlate);
  for (const bool grouped : {false, true}) {
    // Face order, and a tool changer's path order: its pieces grouped by tool, chained.
    const Plan p = plan(f, 5, bed_purge(360, 360), 0.2, grouped);
    ASSERT_TRUE(p.stats.tower.built);
    MachineProfile prof = tool_changer();
    prof.lookahead = 450;  // a tool changer has no shared dead volume to run ahead of
    const Replay r = replay(write_gcode(p.graded, prof));
    EXPECT_GT(r.changes.size(), 5u);
    EXPECT_EQ(r.changes_inside_paths, 0u);
    for (const auto& c : r.changes) EXPECT_EQ(c[0], 'T') << c;
    if (grouped) {
      // One change per tool a layer uses (and one where a layer starts with another tool).
      std::size_t used = 0;
      for (const auto& l : p.graded.layers) {
        std::set<std::vector<double>> mixes;
        for (const auto& q : l.paths)
          if (q.role != PathRole::Purge) mixes.insert(q.mixture);
        used += mixes.size();
      }
      EXPECT_LE(r.changes.size(), used + p.graded.layers.size());
    }
  }
}

TEST(PrimeTower, PlacedWhereTheBedHasRoomOrRefused) {
  const Field f = design(kPlate);
  // Room only behind or in front of the part: the tower goes there.
  const Plan back = plan(f, 4, bed_purge(45, 200));
  ASSERT_TRUE(back.stats.tower.built);
  EXPECT_GT(back.stats.tower.y - back.stats.tower.side / 2, 10 + 5 - 1e-6);
  MachineProfile prof;
  prof.mixing_inputs = 2;
  prof.tool_count = 5;
  prof.bed_x = 45;
  prof.bed_y = 200;
  prof.center = true;
  check_tower_print(back, f, prof, 5);
  // No room anywhere: an error naming the setting, no toolpath.
  try {
    plan(f, 4, bed_purge(45, 30));
    FAIL() << "a tower that fits nowhere was placed";
  } catch (const GeometryError& e) {
    EXPECT_NE(std::string(e.what()).find("no free bed space"), std::string::npos) << e.what();
  }
  // A fixed position on the part is refused.
  PurgeOptions fixed = bed_purge(200, 200);
  fixed.automatic = false;
  fixed.x = 15;
  fixed.y = 0;
  EXPECT_THROW(plan(f, 4, fixed), GeometryError);
  // A round bed: the tower must fit inside the circle (at 56 mm only as a strip).
  PurgeOptions round = bed_purge(48, 48);
  round.circular = true;
  EXPECT_THROW(plan(f, 4, round), GeometryError);
  round.bed_x = round.bed_y = 56;
  const Plan strip = plan(f, 4, round);
  ASSERT_TRUE(strip.stats.tower.built);
  EXPECT_NE(strip.stats.tower.size_x, strip.stats.tower.size_y);
  for (double sx : {-0.5, 0.5})
    for (double sy : {-0.5, 0.5}) {
      const auto& t = strip.stats.tower;
      // The bed is centred on the box of part and tower.
      const double cx =
          (std::min(-20.0, t.x - t.size_x / 2) + std::max(20.0, t.x + t.size_x / 2)) / 2;
      const double cy =
          (std::min(-10.0, t.y - t.size_y / 2) + std::max(10.0, t.y + t.size_y / 2)) / 2;
      EXPECT_LE(std::hypot(t.x + sx * t.size_x - cx, t.y + sy * t.size_y - cy), 28 + 1e-9);
    }
  round.bed_x = round.bed_y = 80;
  EXPECT_TRUE(plan(f, 4, round).stats.tower.built);
}

TEST(PrimeTower, AStripBesideThePartWhereNoSquareFits) {
  // 58 x 36 mm bed, 40 x 20 mm part: no square tower fits beside it, a strip does
  // (the S1 48-colour palette plate on the Mizar's 255 mm bed, in small). The replay checks it
  // like any tower: purges of at least L before the part goes on, no overlap with the part
  // (+ clearance), every layer on the one below.
  const Field f = design(kPlate);
  const Plan p = plan(f, 4, bed_purge(58, 36));
  ASSERT_TRUE(p.stats.tower.built);
  const auto& t = p.stats.tower;
  EXPECT_NE(t.size_x, t.size_y);  // a strip (here 11.6 x 32 mm to the right of the part)
  MachineProfile prof;
  prof.mixing_inputs = 2;
  prof.tool_count = 5;
  prof.bed_x = 58;
  prof.bed_y = 36;
  prof.center = true;
  const Checked c = check_tower_print(p, f, prof, 5);
  EXPECT_GT(c.changes, 0u);
  // A bed with room for neither is refused, saying how much tower the purges need.
  try {
    plan(f, 4, bed_purge(58, 30));
    FAIL() << "a tower that fits nowhere was placed";
  } catch (const GeometryError& e) {
    EXPECT_NE(std::string(e.what()).find("mm2 of tower"), std::string::npos) << e.what();
  }
}

TEST(PrimeTower, NoTowerWithoutPurges) {
  const Field f = design(kPlate);
  PurgeOptions none = bed_purge(200, 200);
  none.melt_volume = 0;
  const Plan p = plan(f, 4, none);
  EXPECT_FALSE(p.stats.tower.built);
  for (const auto& l : p.graded.layers)
    for (const auto& q : l.paths) EXPECT_NE(q.role, PathRole::Purge);
}

TEST(PrimeTower, StandsOnEveryLayerUpToTheLastChange) {
  // Graded along Z: a change every few layers, none on most; the tower still rises layer by
  // layer from the bed to the last change, and not beyond it.
  const Field f = design(
      "fgrade([\"z/3\", \"1 - z/3\"], [\"a\", \"b\"]) {\n  translate(0, 0, 1.5) {\n"
      "    rectprism(20, 20, 3);\n  }\n}\n");
  const Plan p = plan(f, 4, bed_purge(200, 200));
  ASSERT_TRUE(p.stats.tower.built);
  EXPECT_EQ(p.stats.purges, 3u);
  std::size_t with_purge = 0;
  for (const auto& l : p.graded.layers) {
    bool change = false;
    for (std::size_t k = 1; k < l.paths.size(); ++k)
      change = change || l.paths[k].mixture != l.paths[k - 1].mixture;
    with_purge += change;
  }
  EXPECT_LE(with_purge, 3u);
  MachineProfile prof;
  prof.mixing_inputs = 2;
  prof.tool_count = 5;
  prof.bed_x = prof.bed_y = 200;
  prof.center = true;
  const Checked c = check_tower_print(p, f, prof, 5);
  EXPECT_EQ(c.changes, 3u);
  EXPECT_EQ(c.tower_layers, p.stats.tower.layers);
  EXPECT_GT(c.tower_layers, with_purge);
  EXPECT_LT(c.tower_layers, p.graded.layers.size());
}

TEST(PrimeTower, ToolChangerHeatsEveryToolAndReportsWhatIsPrinted) {
  // Eight colours on five tools: refused unless quantising is asked for; then the palette is
  // the tools' five mixes and the reported gradient error is the one the replayed G-code has.
  trellis::test::TempDir dir;
  const std::string vcad = dir.file("plate.vcad");
  write_file_atomic(vcad, kPlate);
  SliceJob job;
  job.input = vcad;
  job.strategy = 1;
  job.planar.layer_height = 0.2;
  job.planar.top_layers = job.planar.bottom_layers = 1;
  job.fgm.palette.colors = 8;
  job.fgm.material_resolution = 0.5;
  job.tools = 5;
  job.purge = bed_purge(360, 360);
  EXPECT_THROW(run_slice(job), SettingError);
  job.quantize = true;
  const SliceResult r = run_slice(job);
  EXPECT_EQ(r.fgm.quantized_from, 8);
  EXPECT_NEAR(r.fgm.error_bound, 0.125, 1e-9);
  MachineProfile prof = tool_changer();
  prof.nozzle_temperature = 215;
  prof.standby_temperature = 170;  // idle tools wait here
  prof.lookahead = 450;
  const std::string gcode = write_gcode(r.toolpath, prof);
  const Replay rp = replay(gcode);
  EXPECT_NE(gcode.find("S170"), std::string::npos);
  EXPECT_EQ(rp.changes_inside_paths, 0u);
  EXPECT_EQ(rp.cold_extrusions, 0u);
  EXPECT_GE(rp.tools.size(), 4u);
  // The error of what is printed: tool t prints 1 - t/4 of material A.
  const Field f = design(kPlate);
  Evaluator ev(f);
  double worst = 0;
  for (const auto& s : rp.segments) {
    const double a = 1 - std::stoi(s.mixture.substr(1)) / 4.0;
    const Vec3 m = (s.a + s.b) * 0.5;
    const Vec2 q{m.x - rp.offset.x, m.y - rp.offset.y};
    if (std::abs(q.x) > 20 || std::abs(q.y) > 10) continue;  // the tower
    const auto li = static_cast<std::size_t>(std::lround(s.b.z / 0.2)) - 1;
    for (const Vec3 e : {s.a, s.b}) {
      const double frac = std::clamp(
          ev.fractions({e.x - rp.offset.x, e.y - rp.offset.y, r.outlines[li].z})[0], 0.0, 1.0);
      worst = std::max(worst, std::abs(frac - a));
    }
  }
  EXPECT_LE(worst, 0.125 + 1e-3);
  EXPECT_NEAR(worst, r.fgm.error_max, 2e-3);
}

TEST(PrimeTower, EveryMixingDialectPrintsTheGradientAsDesigned) {
  // Marlin M165, Marlin M163/M164 (virtual tool), RepRapFirmware M567 and a profile template
  // (here a made-up Klipper macro): read back by the replay, each prints within α/2, each
  // change flushed into the tower.
  const Field f = design(kPlate);
  const Plan p = plan(f, 6, bed_purge(200, 200));
  for (const std::string dialect : {"m165", "m163", "m567", "template"}) {
    MachineProfile prof;
    prof.mixing_inputs = 2;
    prof.tool_count = 5;
    prof.mixing_inputs = 2;
    prof.tool_count = 5;
    prof.bed_x = prof.bed_y = 200;
    prof.center = true;
    prof.gradient_dialect = mixing_dialect_from_string(dialect);
    prof.gradient_template = "SET_MIX A={a} B={b}";
    const std::string gcode = write_gcode(p.graded, prof);
    const Checked c = check_tower_print(p, f, prof, 5);
    EXPECT_EQ(c.changes, p.stats.purges) << dialect;
    EXPECT_LE(c.worst_error, p.options.palette.error_bound() + 1e-3) << dialect;
    EXPECT_GT(c.worst_error, 0.5 * p.options.palette.error_bound()) << dialect;
    if (dialect == "m163") {
      EXPECT_NE(gcode.find("M163 S1 P"), std::string::npos);
    }
  }
  MachineProfile bad;
  bad.mixing_inputs = 2;
  bad.gradient_dialect = MixingDialect::Template;
  EXPECT_THROW(write_gcode(p.graded, bad), SettingError);
}

TEST(PrimeTower, MultiToolMarlinSelectsAndHeatsEachPathsTool) {
  // Paths with their own tool (no mixture) on a two-tool Marlin machine: each tool selected
  // at its path's start and heated before its first extrusion; one-tool machines write no T.
  Toolpath tp;
  Layer l;
  l.z = 0.2;
  for (int k = 0; k < 4; ++k) {
    Path p;
    p.role = PathRole::Perimeter;
    p.tool = k % 2;
    p.points = {{0, 10.0 * k, 0.2}, {20, 10.0 * k, 0.2}, {20, 10.0 * k + 5, 0.2}};
    l.paths.push_back(p);
  }
  tp.layers.push_back(l);
  MachineProfile prof;
  prof.tool_count = 2;
  prof.nozzle_temperature = 210;
  prof.standby_temperature = 150;
  const Replay r = replay(write_gcode(tp, prof));
  EXPECT_EQ(r.changes.size(), 4u);
  EXPECT_EQ(r.cold_extrusions, 0u);
  EXPECT_EQ(r.tools, (std::set<int>{0, 1}));
  EXPECT_EQ(r.changes_inside_paths, 0u);
  prof.tool_count = 1;
  for (auto& p : tp.layers[0].paths) p.tool = 0;
  EXPECT_TRUE(replay(write_gcode(tp, prof)).changes.empty());
}

TEST(PrimeTower, Strategy2OnAToolChangerPrimesEveryToolInTheTower) {
  trellis::test::TempDir dir;
  const std::string vcad = dir.file("plate.vcad");
  write_file_atomic(vcad, kPlate);
  SliceJob job;
  job.input = vcad;
  job.strategy = 2;
  job.planar.layer_height = 0.2;
  job.fgm.palette.colors = 5;
  job.fgm.material_resolution = 0.5;
  job.tools = 5;
  job.purge = bed_purge(360, 360);
  const SliceResult r = run_slice(job);
  ASSERT_TRUE(r.fgm.tower.built);
  MachineProfile prof;
  prof.bed_x = prof.bed_y = 360;
  prof.center = true;
  prof.tool_count = 5;
  prof.gradient_mode = GradientMode::Tools;
  prof.nozzle_temperature = 215;
  const Replay rp = replay(write_gcode(r.toolpath, prof));
  EXPECT_EQ(rp.cold_extrusions, 0u);
  EXPECT_EQ(rp.changes_inside_paths, 0u);
  const double L = purge_length(20, 0.2, 0.4);
  std::map<std::size_t, double> tower;
  std::set<std::size_t> done;
  for (const auto& s : rp.segments) {
    if (s.change < 2 || done.count(s.change)) continue;
    const Vec3 m = (s.a + s.b) * 0.5;
    if (std::abs(m.x - rp.offset.x) <= 20.3 && std::abs(m.y - rp.offset.y) <= 10.3) {
      EXPECT_GE(tower[s.change], L - 1e-3) << s.mixture;
      done.insert(s.change);
    } else {
      tower[s.change] += distance_xy(s.a, s.b);
    }
  }
  EXPECT_EQ(done.size(), rp.changes.size() - 1);
  EXPECT_GT(done.size(), 5u);
}
