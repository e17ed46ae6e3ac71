#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <set>

#include "trellis/core/error.hpp"
#include "trellis/lattice/atlas.hpp"

using namespace trellis;

namespace {

double cross(Vec3 o, Vec3 a, Vec3 b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Whether two struts cross or overlap anywhere except at a shared node.
bool struts_intersect(const Graph& g, const Edge& e, const Edge& f) {
  if (e.a == f.a || e.a == f.b || e.b == f.a || e.b == f.b) {
    // Sharing a node: they must not be collinear and overlapping.
    const NodeId shared = (e.a == f.a || e.a == f.b) ? e.a : e.b;
    const NodeId p = e.other(shared), q = f.other(shared);
    const Vec3 s = g.nodes[shared], a = g.nodes[p], b = g.nodes[q];
    const double c = cross(s, a, b);
    const double d = (a.x - s.x) * (b.x - s.x) + (a.y - s.y) * (b.y - s.y);
    return std::abs(c) < 1e-9 * distance(s, a) * distance(s, b) && d > 0;
  }
  const Vec3 p1 = g.nodes[e.a], p2 = g.nodes[e.b], q1 = g.nodes[f.a], q2 = g.nodes[f.b];
  const double d1 = cross(q1, q2, p1), d2 = cross(q1, q2, p2), d3 = cross(p1, p2, q1),
               d4 = cross(p1, p2, q2);
  const double eps = 1e-12;
  return ((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps)) &&
         ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps));
}

std::vector<int> degrees(const Graph& g) {
  std::vector<int> d(g.nodes.size(), 0);
  for (const auto& e : g.edges) ++d[e.a], ++d[e.b];
  return d;
}

AtlasParams params(Pattern p, double rotation = 0) {
  AtlasParams a;
  a.pattern = p;
  a.cell_size = 1.0;
  a.voronoi_density = 1.5;
  a.rotation_deg = rotation;
  a.region.width = 8;
  a.region.height = 6;
  a.region.center = {3, -2};
  return a;
}

}  // namespace

class EveryPattern : public ::testing::TestWithParam<std::tuple<Pattern, double, bool>> {};

TEST_P(EveryPattern, PlanarInsideRegionNoDuplicates) {
  auto [pattern, rotation, circle] = GetParam();
  AtlasParams a = params(pattern, rotation);
  if (circle) {
    a.region.shape = RegionShape::Circle;
    a.region.diameter = 7;
  }
  a.contour = circle;
  const Graph g = make_lattice2d(a);
  ASSERT_GT(g.edges.size(), pattern == Pattern::Lines ? 4u : 20u);
  const Polygon2 region = a.region.polygon();
  for (const auto& p : g.nodes) {
    ASSERT_TRUE(contains(region, p.xy(), 1e-6)) << p.x << "," << p.y;
    ASSERT_EQ(p.z, 0.0);
  }
  std::map<std::pair<NodeId, NodeId>, int> seen;
  for (const auto& e : g.edges) {
    ASSERT_NE(e.a, e.b);
    ASSERT_GT(distance(g.nodes[e.a], g.nodes[e.b]), 1e-6);
    ASSERT_EQ((seen[{std::min(e.a, e.b), std::max(e.a, e.b)}]++), 0) << "duplicate strut";
  }
  for (std::size_t i = 0; i < g.edges.size(); ++i)
    for (std::size_t j = i + 1; j < g.edges.size(); ++j)
      ASSERT_FALSE(struts_intersect(g, g.edges[i], g.edges[j]))
          << to_string(pattern) << ": struts " << i << " and " << j << " cross";
  // The pattern reaches the border: some node lies on it (the crop made a node there).
  std::size_t on_border = 0;
  for (const auto& p : g.nodes)
    if (!contains(Polygon2{region.outer.size() == 4
                               ? make_rectangle(a.region.center, a.region.width - 1e-4,
                                                a.region.height - 1e-4)
                                     .outer
                               : make_circle(a.region.center, a.region.diameter - 1e-3).outer,
                           {}},
                  p.xy(), 0))
      ++on_border;
  EXPECT_GT(on_border, 3u);
}

INSTANTIATE_TEST_SUITE_P(
    Atlas, EveryPattern,
    ::testing::Combine(::testing::Values(Pattern::Honeycomb, Pattern::Voronoi, Pattern::Penrose,
                                         Pattern::SnubSquare, Pattern::Arrowhead,
                                         Pattern::ReentrantHoneycomb, Pattern::Square,
                                         Pattern::Triangle, Pattern::Lines),
                       ::testing::Values(0.0, 37.0), ::testing::Bool()));

TEST(Atlas, InteriorDegreesMatchTheTiling) {
  const std::map<Pattern, int> expected = {
      {Pattern::Honeycomb, 3}, {Pattern::SnubSquare, 5}, {Pattern::Square, 4},
      {Pattern::Triangle, 6},  {Pattern::Arrowhead, 4},  {Pattern::ReentrantHoneycomb, 3}};
  for (auto [pattern, deg] : expected) {
    AtlasParams a = params(pattern);
    a.region.width = a.region.height = 12;
    const Graph g = make_lattice2d(a);
    const auto d = degrees(g);
    std::map<int, int> hist;
    for (NodeId n = 0; n < g.nodes.size(); ++n) {
      const Vec3 p = g.nodes[n];
      if (std::abs(p.x - a.region.center.x) < 3 && std::abs(p.y - a.region.center.y) < 3)
        ++hist[d[n]];
    }
    ASSERT_EQ(hist.size(), 1u) << to_string(pattern) << " has mixed interior degrees";
    EXPECT_EQ(hist.begin()->first, deg) << to_string(pattern);
  }
}

TEST(Atlas, EdgeLengthsFollowTheCellSize) {
  AtlasParams a = params(Pattern::Honeycomb);
  a.cell_size = 0.8;
  const Graph g = make_lattice2d(a);
  std::size_t full = 0;
  for (EdgeId e = 0; e < g.edges.size(); ++e) {
    ASSERT_LE(g.edge_length(e), 0.8 + 1e-9);
    full += std::abs(g.edge_length(e) - 0.8) < 1e-9;
  }
  EXPECT_GT(full, g.edges.size() * 2 / 3);
  // Penrose rhombi: every uncut side is the cell size.
  a.pattern = Pattern::Penrose;
  const Graph p = make_lattice2d(a);
  full = 0;
  for (EdgeId e = 0; e < p.edges.size(); ++e) full += std::abs(p.edge_length(e) - 0.8) < 1e-6;
  EXPECT_GT(full, p.edges.size() * 2 / 3);
}

TEST(Atlas, VoronoiIsSeededAndDensityScales) {
  AtlasParams a = params(Pattern::Voronoi);
  const Graph g1 = make_lattice2d(a), g2 = make_lattice2d(a);
  EXPECT_EQ(g1.nodes, g2.nodes);
  a.seed = 2;
  EXPECT_NE(make_lattice2d(a).nodes, g1.nodes);
  a.voronoi_density = 6;
  EXPECT_GT(make_lattice2d(a).edges.size(), g1.edges.size() * 2);
}

TEST(Atlas, HandlesAndContourAreConnected) {
  AtlasParams a = params(Pattern::Honeycomb);
  a.handles = true;
  a.contour = true;
  const Graph g = make_lattice2d(a);
  int n = 0;
  connected_components(g, &n);
  EXPECT_EQ(n, 1);
  const BBox3 box = g.bbox();
  EXPECT_NEAR(box.max.x - box.min.x, a.region.width + 2 * a.handle_length, 1e-9);
}

// Clamping rings: every node of the lattice lies inside the outer ring, the pattern's nodes inside
// the innermost; the ring band holds exactly `rings` distinct radii, one spacing apart; the
// pattern touches the innermost ring (one connected part with it), and without rings nothing
// changes.
TEST(Atlas, ClampingRingsAreConcentricAtTheRim) {
  for (const Pattern pat : {Pattern::Voronoi, Pattern::Honeycomb}) {
    AtlasParams a = params(pat);
    a.region.shape = RegionShape::Circle;
    a.region.diameter = 20;
    const Graph plain = make_lattice2d(a);
    a.rings = 4;
    a.ring_spacing = 0.5;
    const Graph g = make_lattice2d(a);
    const Vec2 c = a.region.center;
    const double outer = a.region.diameter / 2, inner = outer - 3 * a.ring_spacing;
    std::set<long> band;
    for (const Vec3& n : g.nodes) {
      const double r = std::hypot(n.x - c.x, n.y - c.y);
      EXPECT_LE(r, outer + 1e-9);
      if (r > inner - a.ring_spacing / 2) band.insert(std::lround(r / a.ring_spacing));
    }
    EXPECT_EQ(band.size(), 4u) << to_string(pat);
    // Each outer ring is a closed loop on its own; the innermost carries the pattern.
    int parts = 0;
    connected_components(g, &parts);
    EXPECT_EQ(parts, 4) << to_string(pat);
    EXPECT_GT(g.edges.size(), plain.edges.size());
    a.rings = 0;
    EXPECT_EQ(make_lattice2d(a).nodes, plain.nodes);
    a.rings = 30;
    EXPECT_THROW(make_lattice2d(a), SettingError);
  }
}

TEST(Atlas, BadParametersAreSettingErrors) {
  AtlasParams a = params(Pattern::Honeycomb);
  a.cell_size = 0;
  EXPECT_THROW(make_lattice2d(a), SettingError);
  a = params(Pattern::Honeycomb);
  a.cell_size = 1e-4;
  EXPECT_THROW(make_lattice2d(a), SettingError);
  a = params(Pattern::ReentrantHoneycomb);
  a.reentrant_angle_deg = 60;
  EXPECT_THROW(make_lattice2d(a), SettingError);
  EXPECT_THROW(pattern_from_string("hexagons"), SettingError);
}

// The auxetic patterns' two lengths (GIPPO Table 1): cell_size across, cell_height up. The
// pattern repeats with exactly that period in Y (every segment well inside has its copy shifted
// by the height, none shifted by a slightly different one), and the arrowhead's inner angle
// follows from the height.
TEST(Atlas, AuxeticCellsHaveTheGivenVerticalLength) {
  for (Pattern pattern : {Pattern::Arrowhead, Pattern::ReentrantHoneycomb}) {
    for (double height : {0.6, 0.9, 1.4}) {
      AtlasParams p;
      p.pattern = pattern;
      p.cell_size = 2;
      p.cell_height = height;
      p.arrowhead_outer_deg = 60;  // outer apex 1.732 mm: room for every height above
      const auto segs = pattern_segments(p, 12);
      auto key = [](Vec2 a, Vec2 b) {
        if (b.x < a.x || (b.x == a.x && b.y < a.y)) std::swap(a, b);
        return std::array<long long, 4>{std::llround(a.x * 1e6), std::llround(a.y * 1e6),
                                        std::llround(b.x * 1e6), std::llround(b.y * 1e6)};
      };
      std::set<std::array<long long, 4>> all;
      for (const auto& s : segs) all.insert(key(s.a, s.b));
      auto periodic = [&](double dy) {
        std::size_t inside = 0;
        for (const auto& s : segs) {
          if (std::max({std::abs(s.a.x), std::abs(s.a.y), std::abs(s.b.x), std::abs(s.b.y)}) > 5)
            continue;
          ++inside;
          if (!all.count(key({s.a.x, s.a.y + dy}, {s.b.x, s.b.y + dy}))) return false;
        }
        return inside > 10;
      };
      EXPECT_TRUE(periodic(height)) << static_cast<int>(pattern) << " " << height;
      EXPECT_FALSE(periodic(height * 1.05)) << static_cast<int>(pattern) << " " << height;
      EXPECT_NO_THROW(make_lattice2d(p));
    }
  }
  AtlasParams bad;
  bad.pattern = Pattern::Arrowhead;
  bad.cell_size = 2;
  bad.arrowhead_outer_deg = 60;
  bad.cell_height = 1.8;  // above the outer chevron's 1.732 mm
  EXPECT_THROW(make_lattice2d(bad), SettingError);
}
