#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "trellis/core/error.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/lattice/cells3d.hpp"

using namespace trellis;

namespace {

std::vector<int> degrees(const Graph& g) {
  std::vector<int> d(g.nodes.size(), 0);
  for (const auto& e : g.edges) ++d[e.a], ++d[e.b];
  return d;
}

bool interior(const Graph& g, NodeId n, double lo, double hi) {
  const Vec3 p = g.nodes[n];
  auto in = [&](double v) { return v > lo + 1e-9 && v < hi - 1e-9; };
  return in(p.x) && in(p.y) && in(p.z);
}

}  // namespace

TEST(Cells3d, CountsOfTheClassicCells) {
  auto make = [](UnitCell c, int n, double size = 7) { return cell_lattice({c, size, n, n, n}); };
  const Graph octet = make(UnitCell::Octet, 1);
  EXPECT_EQ(octet.nodes.size(), 14u);
  EXPECT_EQ(octet.edges.size(), 36u);
  // Same as the AERO example octet_3x3x3 (172 vertices, 756 edges).
  const Graph o3 = make(UnitCell::Octet, 3);
  EXPECT_EQ(o3.nodes.size(), 172u);
  EXPECT_EQ(o3.edges.size(), 756u);
  for (int n = 1; n <= 4; ++n) {
    const Graph cubic = make(UnitCell::Cubic, n);
    EXPECT_EQ(cubic.nodes.size(), std::size_t((n + 1) * (n + 1) * (n + 1)));
    EXPECT_EQ(cubic.edges.size(), std::size_t(3 * n * (n + 1) * (n + 1)));
    const Graph bcc = make(UnitCell::Bcc, n);
    EXPECT_EQ(bcc.edges.size(), std::size_t(8 * n * n * n));
    const Graph fcc = make(UnitCell::Fcc, n);
    EXPECT_EQ(fcc.edges.size(), std::size_t(4 * (3 * n * n * (n + 1))));  // 4 per face
  }
  EXPECT_EQ(make(UnitCell::Diamond, 1).edges.size(), 16u);
}

TEST(Cells3d, EdgeLengthsAndInteriorDegreesOfThePolyhedralCells) {
  struct Case {
    UnitCell cell;
    double length;  // in cell sides
    std::vector<int> interior_degrees;
  };
  const std::vector<Case> cases = {
      {UnitCell::Diamond, std::sqrt(3.0) / 4, {4}},
      {UnitCell::Kelvin, std::sqrt(2.0) / 4, {4}},
      {UnitCell::RhombicDodecahedron, std::sqrt(3.0) / 4, {4, 8}},
      {UnitCell::Octet, std::sqrt(2.0) / 2, {12}},
  };
  for (const auto& c : cases) {
    const double size = 4;
    const Graph g = cell_lattice({c.cell, size, 3, 3, 3});
    for (EdgeId e = 0; e < g.edges.size(); ++e)
      ASSERT_NEAR(g.edge_length(e), c.length * size, 1e-9) << to_string(c.cell);
    const auto d = degrees(g);
    int checked = 0;
    for (NodeId n = 0; n < g.nodes.size(); ++n) {
      if (!interior(g, n, size * 0.9, size * 2.1)) continue;  // well inside the 3x3x3 block
      EXPECT_NE(std::find(c.interior_degrees.begin(), c.interior_degrees.end(), d[n]),
                c.interior_degrees.end())
          << to_string(c.cell) << " node " << n << " degree " << d[n];
      ++checked;
    }
    EXPECT_GT(checked, 0) << to_string(c.cell);
  }
}

TEST(Cells3d, NamesAndBadSettings) {
  for (const auto& n : unit_cell_names()) EXPECT_EQ(to_string(unit_cell_from_string(n)), n);
  EXPECT_THROW(unit_cell_from_string("octahedral"), SettingError);
  EXPECT_THROW(cell_lattice({UnitCell::Octet, 0, 1, 1, 1}), SettingError);
  EXPECT_THROW(cell_lattice({UnitCell::Octet, 1, 0, 1, 1}), SettingError);
  EXPECT_THROW(cell_lattice({UnitCell::Octet, 1, 1000, 1000, 1000}), SettingError);
}

TEST(Cells3d, VoronoiFoamInABoxIsReproducibleAndInside) {
  Diagnostics diag;
  FoamParams p;
  p.width = p.depth = p.height = 12;
  p.density = 0.05;
  p.seed = 3;
  const Graph a = voronoi_foam(p, diag), b = voronoi_foam(p, diag);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  for (NodeId n = 0; n < a.nodes.size(); ++n) EXPECT_EQ(a.nodes[n], b.nodes[n]);
  EXPECT_GT(a.edges.size(), 100u);
  const auto d = degrees(a);
  int four = 0;
  for (NodeId n = 0; n < a.nodes.size(); ++n) {
    const Vec3 q = a.nodes[n];
    EXPECT_TRUE(q.x >= -1e-6 && q.y >= -1e-6 && q.z >= -1e-6 && q.x <= 12 + 1e-6 &&
                q.y <= 12 + 1e-6 && q.z <= 12 + 1e-6);
    if (interior(a, n, 0.5, 11.5)) EXPECT_EQ(d[n], 4);  // generic 3D Voronoi vertices
    four += d[n] == 4;
  }
  EXPECT_GT(four, 0);
  p.seed = 4;
  EXPECT_NE(voronoi_foam(p, diag).edges.size(), 0u);
  p.density = 0;
  EXPECT_THROW(voronoi_foam(p, diag), SettingError);
}

TEST(Cells3d, VoronoiFoamInsideAMesh) {
  // A closed box mesh written to a temporary STL: every node of the foam lies inside it.
  TriangleMesh box;
  box.add_prism({{0, 0}, {10, 0}, {10, 6}, {0, 6}}, 0, 8);
  const std::string path = testing::TempDir() + "/foam_box.stl";
  write_stl(path, box);
  Diagnostics diag;
  FoamParams p;
  p.mesh = path;
  p.density = 0.08;
  const Graph g = voronoi_foam(p, diag);
  EXPECT_GT(g.edges.size(), 20u);
  for (const auto& q : g.nodes) {
    EXPECT_TRUE(q.x > 0 && q.x < 10 && q.y > 0 && q.y < 6 && q.z > 0 && q.z < 8);
  }
}

TEST(Cells3d, MaterialRules) {
  Graph g = cell_lattice({UnitCell::Octet, 7, 2, 2, 1});
  assign_materials(g, MaterialRule::XyPlane);
  std::size_t flat = 0;
  for (const auto& e : g.edges) {
    const bool in_plane = std::abs(g.nodes[e.a].z - g.nodes[e.b].z) < 1e-9;
    EXPECT_EQ(e.material, in_plane ? 0 : 1);
    flat += in_plane;
  }
  EXPECT_GT(flat, 0u);
  // Two separate cubes: two materials by component.
  Graph two = cell_lattice({UnitCell::Cubic, 1, 1, 1, 1});
  const std::size_t n = two.nodes.size(), m = two.edges.size();
  for (std::size_t i = 0; i < n; ++i) two.nodes.push_back(two.nodes[i] + Vec3{5, 0, 0});
  for (std::size_t i = 0; i < m; ++i)
    two.edges.push_back({two.edges[i].a + NodeId(n), two.edges[i].b + NodeId(n)});
  assign_materials(two, MaterialRule::Component);
  EXPECT_EQ(two.edges.front().material, 0);
  EXPECT_EQ(two.edges.back().material, 1);
  assign_materials(two, MaterialRule::Vertical);
  int vertical = 0;
  for (const auto& e : two.edges) vertical += e.material;
  EXPECT_EQ(vertical, 8);
}

TEST(Cells3d, ConformalLatticeInASphereWithAndWithoutSkin) {
  // A sphere of radius 10 (marching cubes at 1 mm, so its surface is within ~0.3 mm of the
  // true one) written as 3MF.
  const double R = 10, tol = 0.35;
  const TriangleMesh ball = field_to_mesh(sphere(R), {{-11, -11, -11}, {11, 11, 11}}, 1.0);
  const std::string path = testing::TempDir() + "/conformal_ball.3mf";
  write_3mf(path, ball);
  Diagnostics diag;
  ConformalParams p;
  p.mesh = path;
  p.cell = UnitCell::Cubic;
  p.size = 4;
  // No skin: exactly the struts of the periodic lattice with both ends inside.
  const Graph clipped = conformal_lattice(p, diag);
  const BBox3 b = bounds(ball);
  CellLatticeParams cells{UnitCell::Cubic, 4, 0, 0, 0};
  cells.nx = static_cast<int>(std::ceil((b.max.x - b.min.x) / 4));
  cells.ny = static_cast<int>(std::ceil((b.max.y - b.min.y) / 4));
  cells.nz = static_cast<int>(std::ceil((b.max.z - b.min.z) / 4));
  Graph full = cell_lattice(cells);
  std::size_t surely_in = 0, surely_out_found = 0;
  auto key = [](Vec3 a, Vec3 c) {
    auto r = [](double v) { return std::llround(v * 1000); };
    auto k1 = std::make_tuple(r(a.x), r(a.y), r(a.z)), k2 = std::make_tuple(r(c.x), r(c.y), r(c.z));
    return k1 < k2 ? std::make_pair(k1, k2) : std::make_pair(k2, k1);
  };
  std::map<decltype(key({}, {})), int> have;
  for (const auto& e : clipped.edges) have[key(clipped.nodes[e.a], clipped.nodes[e.b])] = 1;
  for (const auto& e : full.edges) {
    const Vec3 a = full.nodes[e.a] + b.min, c = full.nodes[e.b] + b.min;
    const double far = std::max(norm(a), norm(c));
    if (far < R - tol) {
      ++surely_in;
      EXPECT_TRUE(have.count(key(a, c)));
    }
    if (far > R + tol && have.count(key(a, c))) ++surely_out_found;
  }
  EXPECT_GT(surely_in, 50u);
  EXPECT_EQ(surely_out_found, 0u);
  EXPECT_EQ(have.size(), clipped.edges.size());
  // With a 2 mm skin: core struts at least 2 mm deep, skin struts inside, all one piece.
  p.skin = 2;
  p.skin_density = 0.1;
  p.core_material = 0;
  p.skin_material = 1;
  const Graph g = conformal_lattice(p, diag);
  std::size_t core = 0, skin = 0;
  for (const auto& e : g.edges) {
    const double ra = norm(g.nodes[e.a]), rb = norm(g.nodes[e.b]);
    EXPECT_LT(std::max(ra, rb), R + tol);
    if (e.material == 1) {
      ++skin;
      EXPECT_GT(std::max(ra, rb), R - 2 - tol);  // an end within the skin
    } else {
      ++core;
      // Core struts and the joins: at least one end 2 mm deep.
      EXPECT_LT(std::min(ra, rb), R - 2 + tol);
    }
  }
  EXPECT_GT(core, 20u);
  EXPECT_GT(skin, 50u);
  int parts = 0;
  connected_components(g, &parts);
  EXPECT_EQ(parts, 1);
  EXPECT_THROW(conformal_lattice({}, diag), SettingError);
}

TEST(Cells3d, FoamWithTooFewSeedsInsideAMeshIsAClearError) {
  // A 2 x 2 x 1 mm box at 0.5 seeds/mm³ holds 2 seeds, too few for 3D cells: an error, not
  // a crash.
  TriangleMesh box;
  box.add_prism({{0, 0}, {2, 0}, {2, 2}, {0, 2}}, 0, 1);
  const std::string path = testing::TempDir() + "/tiny_box.stl";
  write_stl(path, box);
  Diagnostics diag;
  FoamParams p;
  p.mesh = path;
  p.density = 0.5;
  EXPECT_THROW(voronoi_foam(p, diag), GeometryError);
}
