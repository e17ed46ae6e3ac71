// The planar control of a non-planar print (slice_planar_control): every path lies in the band of
// the solid that its tool's layer group fills, and the layers and tool changes add up.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/slice/nonplanar.hpp"

using namespace trellis;

namespace {

double lowest(const HeightField& s, double resolution) {
  double z = std::numeric_limits<double>::infinity();
  for (const auto& v : surface_mesh(s, resolution).vertices) z = std::min(z, v.z);
  return z;
}

double highest(const HeightField& s, double resolution) {
  double z = -std::numeric_limits<double>::infinity();
  for (const auto& v : surface_mesh(s, resolution).vertices) z = std::max(z, v.z);
  return z;
}

// Each path point's non-planar layer: (plane z − f(x, y)) / h, the plane being flat layer i's
// cut through the solid (its middle); the point must lie in a layer whose tool is the path's.
void expect_paths_in_their_bands(const PlanarControlResult& r, const HeightField& s,
                                 const NonplanarParams& prm) {
  const double h = prm.layer_height, z0 = lowest(s, prm.width / 2);
  std::size_t checked = 0;
  for (std::size_t i = 0; i < r.toolpath.layers.size(); ++i) {
    const double plane = z0 + r.toolpath.layers[i].z - 0.5 * h;  // layer z = (plane index + 1) h
    for (const auto& p : r.toolpath.layers[i].paths) {
      for (const auto& q : p.points) {
        const double f = s.height({q.x, q.y});
        ASSERT_TRUE(std::isfinite(f)) << "layer " << i << " point " << q.x << "," << q.y;
        const double k = (plane - f) / h;
        // Walls are inset half a bead into their band; 0.05 layer covers the outline's 5 µm
        // simplification on the steepest flank.
        std::set<int> tools;
        for (double e : {-0.05, 0.0, 0.05}) {
          const int layer = static_cast<int>(std::floor(k + e));
          if (layer >= 0 && layer < prm.layers)
            tools.insert(prm.layer_tools[static_cast<std::size_t>(layer) % prm.layer_tools.size()]);
        }
        EXPECT_TRUE(tools.count(p.tool)) << "layer " << i << " tool " << p.tool << " at " << q.x
                                         << "," << q.y << ": non-planar layer " << k;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100u);
}

std::size_t changes_between_paths(const Toolpath& tp) {
  std::size_t n = 0;
  const Path* last = nullptr;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) {
      if (last && last->tool != p.tool) ++n;
      last = &p;
    }
  return n;
}

}  // namespace

TEST(PlanarControl, FlatSurfaceIsOneToolPerLayerGroup) {
  NonplanarParams prm;
  prm.layers = 6;
  prm.layer_tools = {0, 0, 0, 1, 1, 1};
  const HeightField flat = HeightField::from_expression("0", {{0, 0}, {10, 6}}, "flat");
  const PlanarControlResult r = slice_planar_control(flat, prm);
  ASSERT_EQ(r.toolpath.layers.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    ASSERT_FALSE(r.toolpath.layers[i].paths.empty()) << i;
    for (const auto& p : r.toolpath.layers[i].paths) EXPECT_EQ(p.tool, i < 3 ? 0 : 1) << i;
    EXPECT_NEAR(r.toolpath.layers[i].z, (i + 1) * prm.layer_height, 1e-9);
  }
  EXPECT_EQ(r.layers_with_several_tools, 0u);
  EXPECT_EQ(r.tool_changes, 1u);
  expect_paths_in_their_bands(r, flat, prm);
}

TEST(PlanarControl, MCurveNeedsBothToolsWhereTheBandsMeetTheCut) {
  NonplanarParams prm;
  prm.layers = 9;
  prm.angles = {0};
  prm.layer_tools = {0, 0, 0, 1, 1, 1, 0, 0, 0};
  const HeightField m = m_curve({});
  const PlanarControlResult r = slice_planar_control(m, prm);
  // Every flat layer the solid reaches: the surface's height span plus the nine layers.
  const double solid = highest(m, prm.width / 2) - lowest(m, prm.width / 2) + 9 * prm.layer_height;
  // Planes that only graze the solid (thinner than a bead there) print nothing and are dropped:
  // at most the lowest and the highest.
  const auto planes = static_cast<std::size_t>(std::ceil(solid / prm.layer_height - 1e-6));
  EXPECT_LE(r.toolpath.layers.size(), planes);
  EXPECT_GE(r.toolpath.layers.size() + 2, planes);
  for (const auto& l : r.toolpath.layers) EXPECT_FALSE(l.paths.empty()) << "layer at z " << l.z;
  expect_paths_in_their_bands(r, m, prm);
  // A flat cut crosses the sloped bands: most layers need both syringes, the non-planar print 2
  // changes in all.
  EXPECT_GT(r.layers_with_several_tools, r.toolpath.layers.size() / 2);
  EXPECT_EQ(r.tool_changes, changes_between_paths(r.toolpath));
  EXPECT_GE(r.tool_changes, r.layers_with_several_tools);
  EXPECT_GT(r.tool_changes, 2u);
  // The layer below's last tool starts the next layer: at most one change into a layer.
  for (std::size_t i = 1; i < r.toolpath.layers.size(); ++i) {
    const auto& below = r.toolpath.layers[i - 1].paths;
    const auto& here = r.toolpath.layers[i].paths;
    if (below.empty() || here.empty()) continue;
    std::set<int> tools;
    for (const auto& p : here) tools.insert(p.tool);
    if (tools.count(below.back().tool)) EXPECT_EQ(here.front().tool, below.back().tool) << i;
  }
}

TEST(PlanarControl, MeshSurfaceGivesTheSameLayersAsItsFunction) {
  NonplanarParams prm;
  prm.layers = 4;
  prm.layer_tools = {0, 0, 1, 1};
  const HeightField m = m_curve({});
  const HeightField mesh = HeightField::from_mesh(surface_mesh(m, 0.2), "m.stl");
  const PlanarControlResult a = slice_planar_control(m, prm);
  const PlanarControlResult b = slice_planar_control(mesh, prm);
  ASSERT_EQ(a.toolpath.layers.size(), b.toolpath.layers.size());
  EXPECT_EQ(a.tool_changes, b.tool_changes);
  expect_paths_in_their_bands(b, m, prm);
}

TEST(PlanarControl, NormalOffsetsAreRefusedNamingTheSetting) {
  NonplanarParams prm;
  prm.offset = OffsetMode::Normal;
  try {
    slice_planar_control(m_curve({}), prm);
    FAIL() << "no error";
  } catch (const SettingError& e) {
    EXPECT_NE(std::string(e.what()).find("nonplanar.offset"), std::string::npos) << e.what();
  }
}
