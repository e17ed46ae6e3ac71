#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <limits>
#include <random>

#include "support/temp_dir.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
#include "trellis/job/print_check.hpp"
#include "trellis/job/reports.hpp"
#include "trellis/lattice/cells3d.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/plan/aero.hpp"
#include "trellis/settings/settings.hpp"

using namespace trellis;

namespace {

// Two horizontal struts stacked 2 mm apart and a vertical one beside them.
Graph stack() {
  Graph g;
  g.nodes = {{0, 0, 0}, {5, 0, 0}, {0, 0, 2}, {5, 0, 2}, {8, 0, 0}, {8, 0, 4}};
  g.edges = {{0, 1}, {2, 3}, {4, 5}};
  return g;
}

Path path(std::vector<Vec3> pts) {
  Path p;
  p.points = std::move(pts);
  return p;
}

Toolpath toolpath(std::vector<Path> paths) {
  Toolpath tp;
  tp.layers.push_back({0, std::move(paths)});
  return tp;
}

}  // namespace

TEST(CollisionCheck, LowerFirstIsCleanUpperFirstCollides) {
  const Graph g = stack();
  const CheckOptions o;
  const CollisionCheck good =
      check_collisions(g,
                       toolpath({path({{0, 0, 0}, {5, 0, 0}}), path({{0, 0, 2}, {5, 0, 2}}),
                                 path({{8, 0, 0}, {8, 0, 4}})}),
                       o);
  EXPECT_TRUE(good.ok());
  EXPECT_EQ(good.printed_once, 3u);
  const CollisionCheck bad =
      check_collisions(g,
                       toolpath({path({{0, 0, 2}, {5, 0, 2}}), path({{0, 0, 0}, {5, 0, 0}}),
                                 path({{8, 0, 0}, {8, 0, 4}})}),
                       o);
  EXPECT_EQ(bad.collisions, 1u);
  ASSERT_EQ(bad.hits.size(), 1u);
  EXPECT_EQ(bad.hits[0].strut, 0);
  EXPECT_EQ(bad.hits[0].hit_strut, 1);
  EXPECT_EQ(bad.hits[0].path, 1u);
  EXPECT_NEAR(bad.hits[0].point.z, 2, 1e-9);
  EXPECT_NEAR(bad.hits[0].tip.z, 0, 1e-9);
  EXPECT_FALSE(bad.ok());
  EXPECT_NE(collision_check_json(bad, o).find("\"hit_strut\": 1"), std::string::npos);
}

TEST(CollisionCheck, TopDownMissingRepeatedOffDesign) {
  const Graph g = stack();
  const CheckOptions o;
  const CollisionCheck c =
      check_collisions(g,
                       toolpath({path({{0, 0, 0}, {5, 0, 0}}), path({{8, 0, 4}, {8, 0, 0}}),
                                 path({{5, 0, 0}, {0, 0, 0}}), path({{20, 0, 0}, {21, 0, 0}})}),
                       o);
  ASSERT_EQ(c.top_down.size(), 1u);
  EXPECT_EQ(c.top_down[0].second, 2u);
  EXPECT_EQ(c.missing, std::vector<EdgeId>{1});
  EXPECT_EQ(c.repeated, std::vector<EdgeId>{0});
  EXPECT_EQ(c.off_design_segments, 1u);
  EXPECT_FALSE(c.ok());
  // Ends pushed past their nodes (the writer's overlap) still match within the snap distance.
  CheckOptions snap;
  snap.snap = 0.25;
  const CollisionCheck o2 =
      check_collisions(g,
                       toolpath({path({{-0.2, 0, 0}, {5.2, 0, 0}}), path({{0, 0, 2}, {5, 0, 2}}),
                                 path({{8, 0, -0.2}, {8, 0, 4.2}})}),
                       snap);
  EXPECT_EQ(o2.printed_once, 3u);
  CheckOptions bad;
  bad.snap = 0;
  EXPECT_THROW(check_collisions(g, toolpath({}), bad), SettingError);
}

TEST(CollisionCheck, EmbeddedGcodeReadBackIsCleanAndComplete) {
  // Plan a two-material octet, write it for the two-nozzle machine, read the G-code back, undo
  // the tool offsets and replay it: every strut once, no collision, steep struts bottom-up.
  // Planned and written with a node overlap of 0.3 mm: the ends pushed past their nodes are
  // part of the plan's collision model, so the printed G-code is clean too.
  Graph g = cell_lattice({UnitCell::Octet, 7, 2, 2, 2});
  assign_materials(g, MaterialRule::XyPlane);
  Diagnostics d;
  AeroParams p;
  p.nozzle.end_overlap = 0.3;
  const AeroResult r = plan_aero(g, p, d);
  const Toolpath tp = aero_toolpath(g, r, "test");
  MachineProfile prof = load_machine_profile(std::string(TRELLIS_SOURCE_DIR) +
                                             "/profiles/embedded_aero_two_nozzle.toml");
  prof.node_overlap = 0.3;
  const std::string gcode = write_gcode(tp, prof);
  GcodeReadOptions read;
  read.valve_on = prof.valve_on;
  read.valve_off = prof.valve_off;
  Toolpath back = read_gcode(gcode, read, d);
  to_design_coordinates(back, gcode);  // placement undone (the reader undid the offsets)
  std::size_t paths = 0;
  for (const auto& l : back.layers) paths += l.paths.size();
  EXPECT_EQ(paths, r.trails.trails.size());
  CheckOptions o;
  o.snap = prof.node_overlap + 0.05;
  const CollisionCheck c = check_collisions(g, back, o);
  EXPECT_EQ(c.printed_once, g.edges.size());
  EXPECT_EQ(c.collisions, 0u);
  EXPECT_TRUE(c.ok());
}

// A 2D lattice (every node at z = 0) printed as GIPPO plans it, at the layer heights: matched in
// the design's plane, each strut due once per printed layer.
TEST(CollisionCheck, PlanarDesignsAreMatchedLayerByLayer) {
  Graph g;
  g.nodes = {{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}};
  g.edges = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
  const CheckOptions o;
  auto square = [](double z) {
    return path({{0, 0, z}, {4, 0, z}, {4, 4, z}, {0, 4, z}, {0, 0, z}});
  };
  Toolpath one = toolpath({square(0.2)});
  const CollisionCheck a = check_collisions(g, one, o);
  EXPECT_EQ(a.printed_once, 4u);
  EXPECT_TRUE(a.ok());

  Toolpath two = one;
  two.layers.push_back({1, {square(0.4)}});
  const CollisionCheck b = check_collisions(g, two, o);
  EXPECT_EQ(b.printed_once, 4u);  // once in each of the two layers
  EXPECT_TRUE(b.ok());

  Toolpath partial = one;  // the second layer lacks the closing strut
  partial.layers.push_back({1, {path({{0, 0, 0.4}, {4, 0, 0.4}, {4, 4, 0.4}, {0, 4, 0.4}})}});
  const CollisionCheck c = check_collisions(g, partial, o);
  EXPECT_EQ(c.missing, std::vector<EdgeId>{3});
  EXPECT_FALSE(c.ok());

  Toolpath twice = toolpath({square(0.2), path({{0, 0, 0.2}, {4, 0, 0.2}})});
  EXPECT_EQ(check_collisions(g, twice, o).repeated, std::vector<EdgeId>{0});

  Toolpath off = toolpath({path({{0, 0, 0.2}, {4, 1, 0.2}})});
  EXPECT_EQ(check_collisions(g, off, o).off_design_segments, 1u);

  // A 3D design keeps matching in space: the same square one layer up is off a design at z = 0
  // once the design has a node elsewhere in z.
  Graph spatial = g;
  spatial.nodes.push_back({0, 0, 3});
  spatial.edges.push_back({0, 4});
  EXPECT_EQ(check_collisions(spatial, one, o).off_design_segments, 4u);
}

namespace {

// Every pair tested the slow way: each segment against every one printed before it (no index,
// nothing dropped). A design without nodes: every segment off it, no shared nodes.
struct Reference {
  std::size_t collisions = 0, pairs = 0;
  std::vector<std::array<std::size_t, 4>> hits;  // path, segment, hit path, hit segment
};

Reference brute_force(const Toolpath& tp, const NozzleModel& nozzle) {
  struct Seg {
    Vec3 a, b;
    std::size_t path, index;
  };
  std::vector<Seg> segs;
  std::size_t paths = 0;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) {
      for (std::size_t i = 0; i + 1 < p.points.size(); ++i)
        if (distance(p.points[i], p.points[i + 1]) > 0)
          segs.push_back({p.points[i], p.points[i + 1], paths, i});
      ++paths;
    }
  Reference r;
  for (std::size_t i = 0; i < segs.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) {
      const Seg &q = segs[i], &t = segs[j];
      if (std::max(t.a.z, t.b.z) <= std::min(q.a.z, q.b.z) + nozzle.tip_clearance) continue;
      const double R = nozzle.radius;
      if (std::max(t.a.x, t.b.x) < std::min(q.a.x, q.b.x) - R ||
          std::min(t.a.x, t.b.x) > std::max(q.a.x, q.b.x) + R ||
          std::max(t.a.y, t.b.y) < std::min(q.a.y, q.b.y) - R ||
          std::min(t.a.y, t.b.y) > std::max(q.a.y, q.b.y) + R)
        continue;
      ++r.pairs;
      if (!nozzle_hits(nozzle, q.a, q.b, t.a, t.b, nullptr, 0)) continue;
      ++r.collisions;
      r.hits.push_back({q.path, q.index, t.path, t.index});
    }
  return r;
}

// Layers of short random moves whose heights wander up and down (a later layer may come below
// an earlier one, and a layer's own moves span heights), plus a few long moves across the print.
Toolpath wandering_print(unsigned seed, int layers) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(0, 6), step(-1, 1), dz(-0.15, 0.3);
  Toolpath tp;
  double z = 0;
  for (int k = 0; k < layers; ++k) {
    z = std::max(0.0, z + dz(rng));
    Layer l{z, {}};
    for (int m = 0; m < 12; ++m) {
      Vec3 a{xy(rng), xy(rng), z + 0.2 * step(rng)};
      Path p = path({a});
      for (int s = 0; s < 3; ++s) {
        a = {a.x + step(rng), a.y + step(rng), a.z + 0.05 * step(rng)};
        p.points.push_back(a);
      }
      if (m == 0 && k % 7 == 0) p.points.push_back({a.x + 40, a.y - 30, a.z});  // a long one
      l.paths.push_back(std::move(p));
    }
    tp.layers.push_back(std::move(l));
  }
  return tp;
}

void expect_same(const CollisionCheck& a, const CollisionCheck& b) {
  EXPECT_EQ(a.paths, b.paths);
  EXPECT_EQ(a.segments, b.segments);
  EXPECT_EQ(a.collisions, b.collisions);
  EXPECT_EQ(a.pairs_tested, b.pairs_tested);
  EXPECT_EQ(a.printed_once, b.printed_once);
  EXPECT_EQ(a.missing, b.missing);
  EXPECT_EQ(a.repeated, b.repeated);
  EXPECT_EQ(a.top_down, b.top_down);
  EXPECT_EQ(a.off_design_segments, b.off_design_segments);
  ASSERT_EQ(a.hits.size(), b.hits.size());
  for (std::size_t i = 0; i < a.hits.size(); ++i) {
    EXPECT_EQ(a.hits[i].path, b.hits[i].path);
    EXPECT_EQ(a.hits[i].segment, b.hits[i].segment);
    EXPECT_EQ(a.hits[i].hit_path, b.hits[i].hit_path);
    EXPECT_EQ(a.hits[i].hit_segment, b.hits[i].hit_segment);
    EXPECT_EQ(a.hits[i].point, b.hits[i].point);
  }
}

}  // namespace

// The replay drops material once no later tip can come below it: it finds every collision (and
// tests every pair within reach) that comparing each segment with every earlier one finds, in
// print order, while holding fewer segments than the print has.
TEST(CollisionCheck, DroppingHeldMaterialFindsWhatEveryPairFinds) {
  const Graph none;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    const Toolpath tp = wandering_print(seed, 60);
    CheckOptions o;
    o.nozzle.radius = 0.5 + 0.1 * seed;
    o.nozzle.tip_clearance = 0.02 * seed;
    o.max_listed = std::numeric_limits<std::size_t>::max();
    const CollisionCheck c = check_collisions(none, tp, o);
    const Reference r = brute_force(tp, o.nozzle);
    EXPECT_GT(r.collisions, 20u) << seed;  // a print that tests something
    EXPECT_EQ(c.collisions, r.collisions) << seed;
    EXPECT_EQ(c.pairs_tested, r.pairs) << seed;
    ASSERT_EQ(c.hits.size(), r.hits.size()) << seed;
    for (std::size_t i = 0; i < r.hits.size(); ++i) {
      const auto& h = c.hits[i];
      EXPECT_EQ((std::array<std::size_t, 4>{h.path, h.segment, h.hit_path, h.hit_segment}),
                r.hits[i])
          << seed << " hit " << i;
    }
    EXPECT_LT(c.peak_held, c.segments) << seed;
  }
  // Stacked layers: about two layers held, however many there are.
  Toolpath stacked;
  for (int k = 0; k < 200; ++k) {
    const double z = 0.2 * (k + 1);
    stacked.layers.push_back({z, {path({{0, 0, z}, {5, 0, z}, {5, 5, z}, {0, 5, z}})}});
  }
  const CollisionCheck s = check_collisions(none, stacked, CheckOptions{});
  EXPECT_EQ(s.segments, 600u);
  EXPECT_LE(s.peak_held, 6u);
}

// `trellis check` streams a G-code from its file: the same check as reading the whole print, on
// an AERO print written for the two-nozzle bath machine, in plan order and with its paths
// reversed (collisions, steep struts top-down).
TEST(CollisionCheck, StreamedGcodeChecksAsTheWholePrint) {
  Graph g = cell_lattice({UnitCell::Octet, 7, 2, 2, 2});
  assign_materials(g, MaterialRule::XyPlane);
  Diagnostics d;
  const AeroResult r = plan_aero(g, AeroParams{}, d);
  const std::string profile =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/embedded_aero_two_nozzle.toml";
  const MachineProfile prof = load_machine_profile(profile);
  Settings st;
  st.load_toml_file(profile);
  test::TempDir dir;
  for (bool reversed : {false, true}) {
    Toolpath tp = aero_toolpath(g, r, "test");
    if (reversed) {
      std::reverse(tp.layers.begin(), tp.layers.end());
      for (auto& l : tp.layers) std::reverse(l.paths.begin(), l.paths.end());
    }
    const std::string file = dir.file(reversed ? "reversed.gcode" : "planned.gcode");
    std::ofstream(file) << write_gcode(tp, prof);
    PrintCheck whole(st, true), streamed(st, true);
    whole.set_design(g, d);
    streamed.set_design(g, d);
    Diagnostics dw, ds;
    const CollisionCheck a = whole.check(whole.read(file, dw));
    const CollisionCheck b = streamed.check_file(file, ds);
    EXPECT_EQ(a.segments, g.edges.size()) << reversed;
    EXPECT_EQ(reversed, a.collisions > 0);
    expect_same(a, b);
    EXPECT_EQ(whole.options().snap, streamed.options().snap);
  }
}
