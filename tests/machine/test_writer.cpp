#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <sstream>

#include "support/gcode_replay.hpp"
#include "support/machines.hpp"
#include "support/random_graphs.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/plan/plan.hpp"
#include "trellis/settings/settings.hpp"

using namespace trellis;

namespace {

MachineProfile marlin() {
  MachineProfile p = test::open_bed();
  p.nozzle_diameter = 0.2;
  p.layer_height = 0.148;
  p.retract_length = 0.8;
  p.z_hop = 0.3;
  p.pre_flow = 0.05;
  p.post_flow = 0.02;
  return p;
}

MachineProfile pneumatic() {
  MachineProfile p = test::open_bed();
  p.flavor = Flavor::Pneumatic;
  p.valve_on = "M3";
  p.valve_off = "M5";
  p.pressure = 500;
  p.pressure_command = "M300 P{pressure}";
  p.z_hop = 0.5;
  return p;
}

// Checks the deposits of `gcode` against the design: every strut exactly once, every deposit on
// a strut (ends within `tol` of its nodes), at the layer's nozzle height.
void expect_exact_deposition(const Graph& g, const test::Replay& r, double layer_height,
                             const std::string& label, double tol = 0.02) {
  std::map<std::pair<NodeId, NodeId>, int> count;
  for (const auto& e : g.edges) count[{std::min(e.a, e.b), std::max(e.a, e.b)}] = 0;
  auto nearest = [&](double x, double y, double z) -> long {
    long best = -1;
    double best_d = tol;
    for (NodeId n = 0; n < g.nodes.size(); ++n) {
      const double d = std::hypot(g.nodes[n].x - x, g.nodes[n].y - y);
      if (d <= best_d && std::abs(g.nodes[n].z + layer_height - z) <= 1e-3) {
        best = n;
        best_d = d;
      }
    }
    return best;
  };
  std::size_t off = 0;
  for (const auto& d : r.deposits) {
    const long a = nearest(d.x0, d.y0, d.z0), b = nearest(d.x1, d.y1, d.z1);
    auto it =
        a < 0 || b < 0 ? count.end() : count.find({std::min<NodeId>(a, b), std::max<NodeId>(a, b)});
    if (it == count.end()) {
      ++off;
      continue;
    }
    ++it->second;
  }
  EXPECT_EQ(off, 0u) << label << ": deposits off the lattice";
  std::size_t missing = 0, doubled = 0;
  for (const auto& [k, n] : count) {
    missing += n == 0;
    doubled += n > 1;
  }
  EXPECT_EQ(missing, 0u) << label << ": struts never deposited";
  EXPECT_EQ(doubled, 0u) << label << ": struts deposited twice";
}

}  // namespace

TEST(Writer, ExtrusionFollowsEquation4) {
  MachineProfile p = marlin();
  p.k = 0.9;
  p.extrusion_multiplier = 1.1;
  const double e = extrusion_for(10, 0.148, p);
  EXPECT_NEAR(e, 0.9 * 4 * 10 * 0.148 * 1.1 * 0.2 / (std::numbers::pi * 1.75 * 1.75), 1e-15);
  Toolpath tp;
  Path path;
  path.points = {{0, 0, 0.148}, {10, 0, 0.148}, {10, 5, 0.148}, {0, 5, 0.148}, {0, 0, 0.148}};
  path.height = 0.148;
  tp.layers.push_back({0.148, {path}});
  p.pre_flow = p.post_flow = 0;
  const auto r = test::replay_gcode(write_gcode(tp, p));
  ASSERT_EQ(r.deposits.size(), 4u);
  double total = 0;
  for (const auto& d : r.deposits) total += d.e;
  EXPECT_NEAR(total, extrusion_for(30, 0.148, p), 4 * 1e-5);
  EXPECT_NEAR(r.deposits[0].e, extrusion_for(10, 0.148, p), 1e-5);
}

TEST(Writer, RelativeAndAbsoluteEDepositTheSame) {
  const Graph g = test::random_planar_graph(5);
  Diagnostics d;
  PlanParams pp;
  pp.planner = Planner::Euler;
  const PlanResult plan = plan_lattice(g, pp, d);
  MachineProfile abs_p = marlin(), rel_p = marlin();
  rel_p.relative_e = true;
  const auto a = test::replay_gcode(write_gcode(plan.toolpath, abs_p));
  const auto b = test::replay_gcode(write_gcode(plan.toolpath, rel_p));
  ASSERT_EQ(a.deposits.size(), b.deposits.size());
  for (std::size_t i = 0; i < a.deposits.size(); ++i)
    EXPECT_NEAR(a.deposits[i].e, b.deposits[i].e, 2e-5);
}

TEST(Writer, ShortPathsSlowDownAndRetractionHappens) {
  MachineProfile p = marlin();
  p.print_speed = 10;
  Toolpath tp;
  Path longp, shortp;
  longp.points = {{0, 0, 0.2}, {1, 0, 0.2}, {2, 0, 0.2}, {3, 0, 0.2}, {4, 0, 0.2}};
  shortp.points = {{0, 5, 0.2}, {1, 5, 0.2}};
  tp.layers.push_back({0.2, {longp, shortp}});
  GcodeStats s;
  const std::string g = write_gcode(tp, p, &s);
  EXPECT_NE(g.find("F600"), std::string::npos);  // 10 mm/s
  EXPECT_NE(g.find("F360"), std::string::npos);  // 0.6 x 10 mm/s for the 1-segment path
  EXPECT_EQ(s.retractions, 2u);                  // before the travel and at the end
  EXPECT_EQ(s.travel_moves, 1u);
  EXPECT_NE(g.find("; setting extrusion.nozzle_diameter = 0.2"), std::string::npos);
}

TEST(Writer, CentringMovesThePartToTheBedCentre) {
  MachineProfile p = marlin();
  p.center = true;
  p.origin = BedOrigin::Corner;
  p.bed_x = 200;
  p.bed_y = 100;
  Toolpath tp;
  Path path;
  path.points = {{-5, -5, 0.2}, {5, 5, 0.2}};
  tp.layers.push_back({0.2, {path}});
  const auto r = test::replay_gcode(write_gcode(tp, p));
  ASSERT_EQ(r.deposits.size(), 1u);
  EXPECT_NEAR(r.deposits[0].x0, 95, 1e-9);
  EXPECT_NEAR(r.deposits[0].y1, 55, 1e-9);
  // A machine whose origin is the bed centre (a delta): the centre is X0 Y0.
  p.origin = BedOrigin::Center;
  const auto c = test::replay_gcode(write_gcode(tp, p));
  EXPECT_NEAR(c.deposits[0].x0, -5, 1e-9);
  EXPECT_NEAR(c.deposits[0].y1, 5, 1e-9);
}

TEST(Writer, TemplatesExpandAndUnknownPlaceholdersFail) {
  MachineProfile p = marlin();
  p.nozzle_temperature = 225;
  EXPECT_EQ(expand_template("M109 S{nozzle} ; {temperature.nozzle}", p, "t"), "M109 S225 ; 225");
  EXPECT_THROW(expand_template("M109 S{nozle}", p, "t"), SettingError);
  EXPECT_THROW(write_gcode(Toolpath{}, p), GeometryError);
}

// The core property of issue 2: parse the G-code written for every atlas pattern and for random
// planar graphs, and find every strut deposited exactly once and nothing off the lattice.
TEST(WriterProperty, EveryStrutExactlyOnceNothingOffTheLattice) {
  std::vector<std::pair<std::string, Graph>> designs;
  for (const auto& name : pattern_names()) {
    AtlasParams a;
    a.pattern = pattern_from_string(name);
    a.region.width = a.region.height = 6;
    a.rotation_deg = 21;
    a.contour = name == "lines";
    designs.emplace_back(name, make_lattice2d(a));
  }
  for (std::uint64_t seed = 1; seed <= 12; ++seed)
    designs.emplace_back("random planar " + std::to_string(seed),
                         test::random_planar_graph(seed, 7, 6, 0.7));
  // Two layers stacked: each planned on its own.
  {
    AtlasParams a;
    a.region.width = a.region.height = 5;
    Graph two = make_lattice2d(a);
    a.rotation_deg = 45;
    a.z = 0.148;
    const Graph top = make_lattice2d(a);
    const auto off = static_cast<NodeId>(two.nodes.size());
    two.nodes.insert(two.nodes.end(), top.nodes.begin(), top.nodes.end());
    for (Edge e : top.edges) two.edges.push_back({e.a + off, e.b + off});
    designs.emplace_back("two layers", two);
  }
  for (const auto& [label, g] : designs)
    for (Planner planner : {Planner::Gippo, Planner::Euler})
      for (PathOrder order : {PathOrder::LongestFirst, PathOrder::Travel}) {
        PlanParams pp;
        pp.planner = planner;
        pp.order = order;
        pp.gippo.iterations = 20;
        Diagnostics d;
        const PlanResult plan = plan_lattice(g, pp, d);
        const std::string name = label + " / " + to_string(planner) + " / " + to_string(order);
        expect_exact_deposition(g, test::replay_gcode(write_gcode(plan.toolpath, marlin())),
                                pp.layer_height, name + " / marlin");
        const MachineProfile pn = pneumatic();
        expect_exact_deposition(
            g, test::replay_gcode(write_gcode(plan.toolpath, pn), pn.valve_on, pn.valve_off),
            pp.layer_height, name + " / pneumatic");
      }
}

TEST(WriterProperty, ExtrusionStartsEqualPathCount) {
  const Graph g = test::random_planar_graph(3, 9, 9);
  PlanParams pp;
  pp.gippo.iterations = 10;
  Diagnostics d;
  const PlanResult plan = plan_lattice(g, pp, d);
  MachineProfile p = marlin();
  p.pre_flow = p.post_flow = 0;
  const auto r = test::replay_gcode(write_gcode(plan.toolpath, p));
  EXPECT_EQ(r.extrusion_starts, plan.total.paths);
}

TEST(WriterProperty, ByteIdenticalForOneOrTwoThreads) {
  AtlasParams a;
  a.pattern = Pattern::Voronoi;
  a.region.width = a.region.height = 10;
  const Graph g = make_lattice2d(a);
  std::string out[2];
  for (int t = 1; t <= 2; ++t) {
    PlanParams pp;
    pp.gippo.iterations = 100;
    Diagnostics d;
    RunContext context;
    context.threads = t;
    out[t - 1] = write_gcode(plan_lattice(g, pp, d, context).toolpath, marlin());
  }
  EXPECT_EQ(out[0], out[1]);
}

namespace {

// Paths that carry a mixture get an M165 before them when it changes; reading the G-code back
// gives each path its mixture (the graded-material writers build on this).
TEST(Writer, MixturesBecomeM165AndReadBack) {
  trellis::Toolpath tp;
  tp.layers.resize(1);
  tp.layers[0].z = 0.2;
  const std::vector<std::vector<double>> mixes = {{0.125, 0.875}, {0.125, 0.875}, {0.625, 0.375}};
  for (std::size_t i = 0; i < mixes.size(); ++i) {
    trellis::Path p;
    p.points = {{0.0, 2.0 * i, 0.2}, {10.0, 2.0 * i, 0.2}};
    p.mixture = mixes[i];
    tp.layers[0].paths.push_back(p);
  }
  const trellis::MachineProfile prof = trellis::test::open_bed({}, 0, 2);
  const std::string g = trellis::write_gcode(tp, prof);
  std::size_t count = 0;
  for (std::size_t pos = g.find("M165"); pos != std::string::npos; pos = g.find("M165", pos + 1))
    ++count;
  EXPECT_EQ(count, 2u);  // the second path keeps the first one's mixture
  EXPECT_NE(g.find("M165 A0.125 B0.875"), std::string::npos);
  trellis::Diagnostics diag;
  const trellis::Toolpath back = trellis::read_gcode(g, {}, diag);
  std::vector<std::vector<double>> seen;
  for (const auto& l : back.layers)
    for (const auto& p : l.paths) seen.push_back(p.mixture);
  ASSERT_EQ(seen.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    ASSERT_EQ(seen[i].size(), 2u);
    EXPECT_NEAR(seen[i][0], mixes[i][0], 1e-9);
    EXPECT_NEAR(seen[i][1], mixes[i][1], 1e-9);
  }
}

TEST(Writer, EmbeddedTravelLeavesTheBathVerticallyAndSwapsNozzles) {
  trellis::Toolpath tp;
  tp.layers.resize(1);
  auto add = [&](std::vector<trellis::Vec3> pts, int tool) {
    trellis::Path p;
    p.points = std::move(pts);
    p.tool = tool;
    tp.layers[0].paths.push_back(p);
  };
  add({{0, 0, 0}, {5, 0, 5}, {10, 0, 0}}, 0);
  add({{41, 5, 0}, {51, 5, 0}}, 1);
  add({{41, 9, 0}, {51, 9, 0}}, 1);
  trellis::MachineProfile prof = trellis::load_machine_profile(
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/embedded_aero_two_nozzle.toml");
  prof.node_overlap = 0.5;
  prof.center = false;  // design coordinates are bed coordinates
  trellis::GcodeStats stats;
  const std::string g = trellis::write_gcode(tp, prof, &stats);
  EXPECT_EQ(stats.tool_changes, 1u);  // T0 selected, then one change to T1
  EXPECT_NE(g.find("T0 ;"), std::string::npos);
  EXPECT_NE(g.find("M400 ; raise nozzle 0 above the bath"), std::string::npos);
  EXPECT_NE(g.find("T1 ;"), std::string::npos);
  EXPECT_NE(g.find("M300 P600"), std::string::npos);  // tool 0 pressure
  EXPECT_NE(g.find("M300 P650"), std::string::npos);  // tool 1 pressure
  EXPECT_NE(g.find("G4 P200"), std::string::npos);    // node dwell at the inner node
  // Every XY travel happens at the bath surface + clearance (27 mm); Z moves alone otherwise.
  std::istringstream in(g);
  std::string line;
  double z = 30;
  int xy_travels = 0;
  while (std::getline(in, line)) {
    if (line.rfind("G0", 0) != 0) continue;
    const bool has_xy = line.find('X') != std::string::npos || line.find('Y') != std::string::npos;
    const auto zp = line.find('Z');
    if (zp != std::string::npos) {
      EXPECT_FALSE(has_xy) << line;  // vertical only
      z = std::stod(line.substr(zp + 1));
    }
    if (has_xy) {
      EXPECT_NEAR(z, 27, 1e-9) << line;
      ++xy_travels;
    }
  }
  EXPECT_EQ(xy_travels, 3);
  // Nozzle 1 sits 40 mm to the right of nozzle 0: the head goes 40 mm to the left of its paths;
  // the overlap pushes the ends 0.5 mm past the nodes.
  EXPECT_NE(g.find("G0 X0.5 Y5"), std::string::npos) << g;
  EXPECT_NE(g.find("G1 X11.5 Y5"), std::string::npos);
  prof.tool_offsets = "0,0;abc";
  EXPECT_THROW(trellis::validate(prof), trellis::SettingError);
}

}  // namespace
// write_gcode_into replaces the buffer's text with exactly write_gcode's bytes, whatever the
// buffer held (shorter, longer), and keeps using its memory.
TEST(Writer, IntoAReusedBufferWritesTheSameBytes) {
  Toolpath tp;
  for (int l = 0; l < 3; ++l) {
    const double z = 0.2 * (l + 1);
    Path path;
    path.points = {{0, 0, z}, {10, 5, z}};
    tp.layers.push_back({z, {path}});
  }
  MachineProfile p;
  p.nozzle_temperature = 200;
  const std::string expected = write_gcode(tp, p);
  std::string buffer(3 * expected.size(), 'x');
  write_gcode_into(buffer, tp, p);
  EXPECT_EQ(buffer, expected);
  const char* memory = buffer.data();
  write_gcode_into(buffer, tp, p);
  EXPECT_EQ(buffer, expected);
  EXPECT_EQ(buffer.data(), memory);
  buffer = "G1 X1";
  write_gcode_into(buffer, tp, p);
  EXPECT_EQ(buffer, expected);
}
