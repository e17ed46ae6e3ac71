#include <gtest/gtest.h>

#include "support/machines.hpp"
#include "support/random_graphs.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/plan/plan.hpp"

using namespace trellis;

namespace {

Analysis measure(const Toolpath& tp, const Graph& design, const AnalysisParams& params = {}) {
  MachineProfile p = test::open_bed();
  p.retract_length = 0.5;
  Diagnostics d;
  const std::string g = write_gcode(tp, p);
  CountingSink counter;
  GcodeScanner(counter, {}, d).feed(g);
  counter.finish();
  return analyze(read_gcode(g, {}, d), counter.counts, &design, params);
}

Toolpath plan(const Graph& g, Planner planner) {
  PlanParams pp;
  pp.planner = planner;
  pp.gippo.iterations = 20;
  Diagnostics d;
  return plan_lattice(g, pp, d).toolpath;
}

}  // namespace

TEST(Analysis, TrellisOutputIsExactOnEveryPattern) {
  for (const auto& name : pattern_names()) {
    AtlasParams a;
    a.pattern = pattern_from_string(name);
    a.region.width = a.region.height = 8;
    const Graph g = make_lattice2d(a);
    for (Planner planner : {Planner::Gippo, Planner::Euler}) {
      const Toolpath tp = plan(g, planner);
      const Analysis m = measure(tp, g);
      EXPECT_NEAR(m.extrusion_ratio, 1.0, 1e-3) << name;  // coordinates are written to 1 µm
      EXPECT_NEAR(m.double_length, 0, 1e-9) << name;
      EXPECT_NEAR(m.off_design_length, 0, 1e-9) << name;
      EXPECT_EQ(m.missing_edges, 0u) << name;
      EXPECT_EQ(m.counts.extrusion_starts, tp.path_count()) << name;
      EXPECT_EQ(m.counts.travel_moves, tp.path_count() - 1) << name;
      EXPECT_EQ(m.edges_real, g.edges.size()) << name;
      EXPECT_NEAR(m.score_corrected, m.score, 1e-12) << name;
    }
  }
}

TEST(Analysis, PerLayerCountsSumToTheTotalsAndEulerMeetsTheBoundOnEveryLayer) {
  // Three layers of honeycomb, each its own design level.
  AtlasParams a;
  a.pattern = pattern_from_string("honeycomb");
  a.region.width = a.region.height = 8;
  Graph g = make_lattice2d(a);
  const std::size_t per = g.nodes.size(), edges = g.edges.size();
  for (int level = 1; level < 3; ++level) {
    for (std::size_t n = 0; n < per; ++n) g.nodes.push_back(g.nodes[n] + Vec3{0, 0, 0.2 * level});
    for (std::size_t e = 0; e < edges; ++e) {
      Edge copy = g.edges[e];
      copy.a += static_cast<NodeId>(level * per);
      copy.b += static_cast<NodeId>(level * per);
      g.edges.push_back(copy);
    }
  }
  for (Planner planner : {Planner::Gippo, Planner::Euler}) {
    const Toolpath tp = plan(g, planner);
    const Analysis m = measure(tp, g);
    ASSERT_EQ(m.counts.per_layer.size(), 3u);
    ASSERT_EQ(m.layers.size(), 3u);
    std::size_t starts = 0, retractions = 0, travels = 0;
    double travel = 0;
    for (std::size_t i = 0; i < 3; ++i) {
      const auto& l = m.counts.per_layer[i];
      EXPECT_EQ(l.starts, tp.layers[i].paths.size());
      EXPECT_GE(l.starts, m.layers[i].lower_bound);
      if (planner == Planner::Euler) EXPECT_EQ(l.starts, m.layers[i].lower_bound);
      starts += l.starts, retractions += l.retractions, travels += l.travel_moves;
      travel += l.travel_length;
    }
    EXPECT_EQ(starts, m.counts.extrusion_starts);
    EXPECT_EQ(retractions, m.counts.retractions);
    EXPECT_EQ(travels, m.counts.travel_moves);
    EXPECT_NEAR(travel, m.counts.travel_length, 1e-9 * (1 + travel));
  }
}

TEST(Analysis, FindsDoublesMissingStrutsAndOffDesignDeposits) {
  const Graph g = test::random_planar_graph(4, 8, 8, 0.8);
  Toolpath tp = plan(g, Planner::Euler);
  auto& paths = tp.layers[0].paths;
  const double dropped = paths.back().length();
  std::size_t dropped_edges = paths.back().segments();
  paths.pop_back();
  const Path twice = paths.front();
  paths.push_back(twice);
  Path stray;
  stray.points = {{-5, -5, paths[0].points[0].z}, {-2, -5, paths[0].points[0].z}};
  paths.push_back(stray);
  const Analysis m = measure(tp, g);
  EXPECT_GE(m.missing_edges, dropped_edges);
  EXPECT_GT(m.double_length, 0.5 * twice.length());
  EXPECT_LE(m.double_length, twice.length() + 1e-9);
  EXPECT_NEAR(m.off_design_length, 3.0, 0.01);
  EXPECT_NEAR(m.extruded_length, g.total_length() - dropped + twice.length() + 3.0,
              0.01);  // 1 µm output rounding
  EXPECT_LT(m.score_corrected, m.score * 1.0001);
}

TEST(Analysis, AlignmentFindsAPartPlacedOnTheBed) {
  const Graph g = test::random_planar_graph(9);
  const Toolpath tp = plan(g, Planner::Euler);
  MachineProfile p = test::open_bed();
  p.center = true;
  p.origin = BedOrigin::Corner;  // placed at the bed centre, (1000, 1000)
  Diagnostics d;
  const std::string gcode = write_gcode(tp, p);
  CountingSink counter;
  GcodeScanner(counter, {}, d).feed(gcode);
  AnalysisParams params;
  params.auto_align = false;
  EXPECT_EQ(analyze(read_gcode(gcode, {}, d), counter.counts, &g, params).missing_edges,
            g.edges.size());
  params.align_centers = true;
  Analysis a = analyze(read_gcode(gcode, {}, d), counter.counts, &g, params);
  EXPECT_EQ(a.missing_edges, 0u);
  EXPECT_FALSE(a.auto_aligned);
  // Without --align the print, all of it away from the design, is aligned anyway and says so.
  params.align_centers = false;
  params.auto_align = true;
  a = analyze(read_gcode(gcode, {}, d), counter.counts, &g, params);
  EXPECT_EQ(a.missing_edges, 0u);
  EXPECT_TRUE(a.auto_aligned);
  EXPECT_NEAR(a.shift.x, -1000, 20);  // from the bed centre back to the design
  EXPECT_NEAR(a.shift.y, -1000, 20);
  // The same print where the design is: left alone.
  a = analyze(tp, counter.counts, &g, params);
  EXPECT_FALSE(a.auto_aligned);
  EXPECT_EQ(a.missing_edges, 0u);
}

// A plate's G-code measured per labelled part (M486 and Klipper): each part's extruded length
// and filament are those of its own paths, the parts' sums are the whole file's, and each part's
// time is at least its extrusions' at their feed rate.
TEST(Analysis, PlatePartsAreMeasuredEachOnItsOwn) {
  Toolpath tp;
  tp.part_labels = {"left", "right"};
  std::vector<double> length(2, 0.0);
  for (int l = 0; l < 3; ++l) {
    Layer layer{0.2 * (l + 1), {}};
    for (int k = 0; k < 4; ++k) {
      const int part = 1 + (k + l) % 2;
      Path path;
      path.part = part;
      const double x0 = part == 1 ? 20 : 60, size = 5.0 + k;
      path.points = {{x0, 20, layer.z}, {x0 + size, 20, layer.z}, {x0 + size, 20 + size, layer.z}};
      length[static_cast<std::size_t>(part - 1)] += 2 * size;
      path.speed = 20;
      layer.paths.push_back(std::move(path));
    }
    tp.layers.push_back(std::move(layer));
  }
  for (const std::string flavor : {"marlin", "klipper"}) {
    MachineProfile p = test::open_bed();
    p.flavor = flavor_from_string(flavor);
    p.center = false;
    GcodeStats stats;
    const std::string g = write_gcode(tp, p, &stats);
    Diagnostics d;
    CountingSink counter;
    GcodeScanner(counter, {}, d).feed(g);
    counter.finish();
    const auto& parts = counter.counts.parts;
    ASSERT_EQ(parts.size(), 2u) << flavor;
    double filament = 0;
    for (std::size_t i = 0; i < 2; ++i) {
      EXPECT_EQ(parts[i].label, tp.part_labels[i]) << flavor;
      EXPECT_NEAR(parts[i].extruded_length, length[i], 1e-6) << flavor;
      EXPECT_NEAR(parts[i].filament, extrusion_for(length[i], p.layer_height, p), 1e-3) << flavor;
      EXPECT_GE(parts[i].print_time_s, length[i] / 20 - 1e-9) << flavor;
      filament += parts[i].filament;
    }
    EXPECT_NEAR(parts[0].extruded_length + parts[1].extruded_length, counter.counts.extruded_length,
                1e-6);
    EXPECT_NEAR(filament, counter.counts.filament, 1e-6) << flavor;
    EXPECT_LE(parts[0].print_time_s + parts[1].print_time_s, counter.counts.print_time_s + 1e-9);
  }
}

// G4 dwells are time: the reader counts G4 P<ms> and S<s>, and a pneumatic file's dwells (before
// and after each path) add the same time to analyze's estimate as to the writer's.
TEST(Analysis, DwellsAreCountedAsTheWriterCountsThem) {
  Diagnostics d;
  CountingSink plain;
  GcodeScanner s(plain, {}, d);
  s.feed("G1 X10 E1 F600\nG4 P500\nG4 S2\nG4\n");
  s.finish();
  plain.finish();
  EXPECT_NEAR(plain.counts.print_time_s, 1 + 0.5 + 2, 1e-12);
  EXPECT_EQ(d.total(), 0u);

  AtlasParams a;
  a.pattern = pattern_from_string("honeycomb");
  a.region.width = a.region.height = 6;
  PlanParams pp;
  pp.planner = Planner::Gippo;
  pp.gippo.iterations = 5;
  const Toolpath tp = plan_lattice(make_lattice2d(a), pp, d).toolpath;
  MachineProfile p = test::open_bed();
  p.flavor = Flavor::Pneumatic;
  p.valve_on = "M3";
  p.valve_off = "M5";
  auto times = [&](double pre, double post) {
    p.pre_flow_dwell = pre;
    p.post_flow_dwell = post;
    GcodeStats stats;
    const std::string g = write_gcode(tp, p, &stats);
    CountingSink counter;
    GcodeReadOptions o;
    o.valve_on = "M3";
    o.valve_off = "M5";
    GcodeScanner scan(counter, o, d);
    scan.feed(g);
    scan.finish();
    counter.finish();
    return std::pair{stats.print_time_s, counter.counts.print_time_s};
  };
  const auto [w0, r0] = times(0, 0);
  const auto [w1, r1] = times(0.2, 0.3);
  ASSERT_GT(w1 - w0, 0.5 * tp.path_count() - 1e-9);
  EXPECT_NEAR(r1 - r0, w1 - w0, 1e-6);
}
