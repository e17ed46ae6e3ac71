#include <gtest/gtest.h>

#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
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
