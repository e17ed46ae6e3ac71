// offset() takes a direct route where ClipperOffset's clean-up union has nothing to clean
// (src/geom/offset_direct.cpp): its regions must be ClipperOffset's, whichever route it took.
#include <gtest/gtest.h>

#include <algorithm>
#include <clipper.hpp>
#include <cmath>
#include <numbers>

#include "../../src/geom/clipper_util.hpp"
#include "support/random_regions.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {
namespace {

namespace cl = ClipperLib;

// ClipperOffset itself, as offset() called it before the direct route.
Regions clipper_offset(const Regions& regions, double delta) {
  cl::ClipperOffset off(2.0, 0.002 * kClipperScale);
  auto add = [&](const std::vector<Vec2>& ring, bool ccw) {
    if (ring.size() < 3) return;
    cl::Path path;
    for (const Vec2 p : ring)
      path.push_back({std::llround(p.x * kClipperScale), std::llround(p.y * kClipperScale)});
    if (cl::Orientation(path) != ccw) cl::ReversePath(path);
    off.AddPath(path, cl::jtMiter, cl::etClosedPolygon);
  };
  for (const auto& p : regions) {
    add(p.outer, true);
    for (const auto& h : p.holes) add(h, false);
  }
  cl::Paths out;
  off.Execute(out, delta * kClipperScale);
  std::vector<std::vector<Vec2>> rings;
  for (const auto& path : out) {
    auto& r = rings.emplace_back();
    for (const auto& q : path)
      r.push_back(
          {static_cast<double>(q.X) / kClipperScale, static_cast<double>(q.Y) / kClipperScale});
  }
  return nest_rings(rings);
}

double perimeter(const Regions& regions) {
  double l = 0;
  for (const auto& ring : rings_of(regions))
    for (std::size_t i = 0; i < ring.size(); ++i)
      l += std::sqrt(dist2(ring[i], ring[(i + 1) % ring.size()]));
  return l;
}

std::size_t holes(const Regions& regions) {
  std::size_t n = 0;
  for (const auto& p : regions) n += p.holes.size();
  return n;
}

// Random stars with holes and a second island, offset in and out by up to 60 % of their size
// (walls that close, holes that vanish or merge, islands that meet): the same polygons and
// holes as ClipperOffset's, and the same area up to its 1 nm rounding along the outline.
TEST(Regions, OffsetIsClipperOffsetsRegion) {
  std::size_t cases = 0, changed_shape = 0;
  for (std::uint64_t trial = 0; trial < 400; ++trial) {
    Rng rng(0x0ff5e7 + trial);
    const double scale = 1 + 20 * rng.uniform01();
    const Regions r = test::random_region(rng, scale);
    for (const double f : {-0.6, -0.3, -0.1, -0.02, 0.02, 0.1, 0.3, 0.6}) {
      const double d = f * scale * (0.5 + rng.uniform01());
      const Regions got = offset(r, d);
      const Regions want = clipper_offset(r, d);
      ++cases;
      if (want.size() != r.size() || holes(want) != holes(r)) ++changed_shape;
      const std::string what = "trial " + std::to_string(trial) + " delta " + std::to_string(d);
      ASSERT_EQ(got.size(), want.size()) << what;
      EXPECT_EQ(holes(got), holes(want)) << what;
      const double tol = 4e-6 * (perimeter(want) + perimeter(got)) + 1e-9;
      EXPECT_NEAR(area(difference(got, want)), 0, tol) << what;
      EXPECT_NEAR(area(difference(want, got)), 0, tol) << what;
    }
  }
  // The cases include offsets whose clean-up changes the polygons (the direct route's refusals).
  EXPECT_GT(changed_shape, cases / 10);
}

// A ring with a repeated point, a spike and a sliver: the same as ClipperOffset's too.
TEST(Regions, OffsetOfDegenerateRingsIsClipperOffsets) {
  const std::vector<Regions> inputs{
      {Polygon2{{{0, 0}, {10, 0}, {10, 0}, {10, 10}, {0, 10}}, {}}},
      {Polygon2{{{0, 0}, {10, 0}, {10, 5}, {20, 5.001}, {10, 5.002}, {10, 10}, {0, 10}}, {}}},
      {Polygon2{{{0, 0}, {10, 0}, {10, 0.3}, {0, 0.3}}, {}}},
      {Polygon2{{{0, 0}, {10, 0}, {10, 10}, {0, 10}}, {{{4, 4}, {4, 6}, {6, 6}, {6, 4}}}}},
  };
  for (std::size_t i = 0; i < inputs.size(); ++i)
    for (const double d : {-2.0, -0.2, -0.1, 0.1, 0.2, 1.5}) {
      const Regions got = offset(inputs[i], d);
      const Regions want = clipper_offset(inputs[i], d);
      ASSERT_EQ(got.size(), want.size()) << i << " " << d;
      EXPECT_EQ(holes(got), holes(want)) << i << " " << d;
      const double tol = 4e-6 * (perimeter(want) + perimeter(got)) + 1e-9;
      EXPECT_NEAR(area(difference(got, want)), 0, tol) << i << " " << d;
      EXPECT_NEAR(area(difference(want, got)), 0, tol) << i << " " << d;
    }
}

// A slice of a curved wall: an ellipse of many short edges (0.01-0.3 mm), some with slicing noise
// (a micrometre or two) and bumps narrower than the offsets below, sometimes a hole likewise.
Regions tessellated_region(Rng& rng) {
  constexpr double kPi = std::numbers::pi;
  auto ellipse = [&](Vec2 c, double rx, double ry, bool ccw) {
    const double step = 0.01 + 0.3 * rng.uniform01() * rng.uniform01();
    const int n = std::clamp(static_cast<int>(2 * kPi * std::max(rx, ry) / step), 8, 3000);
    const int bumps = static_cast<int>(rng.uniform_index(6));
    const double bump_height = 0.3 * rng.uniform01(), bump_width = 0.05 + 0.2 * rng.uniform01();
    std::vector<double> at;
    for (int b = 0; b < bumps; ++b) at.push_back(2 * kPi * rng.uniform01());
    const double noise = rng.uniform01() < 0.3 ? 0.002 * rng.uniform01() : 0.0;
    std::vector<Vec2> ring;
    for (int i = 0; i < n; ++i) {
      const double a = 2 * kPi * i / n;
      double r = 1 + noise * (rng.uniform01() - 0.5) / std::max(rx, ry);
      for (const double b : at)
        if (std::abs(std::remainder(a - b, 2 * kPi)) * std::max(rx, ry) < bump_width)
          r += bump_height / std::max(rx, ry);
      ring.push_back(c + Vec2{rx * r * std::cos(a), ry * r * std::sin(a)});
    }
    if (!ccw) std::reverse(ring.begin(), ring.end());
    return ring;
  };
  const double rx = 0.5 + 15 * rng.uniform01(), ry = rx * (0.3 + 0.7 * rng.uniform01());
  Polygon2 p;
  p.outer = ellipse({0, 0}, rx, ry, true);
  if (rng.uniform01() < 0.4 && ry > 3)
    p.holes.push_back(ellipse({0.2 * rx, 0}, 0.3 * ry, 0.3 * ry, false));
  return {p};
}

// Offsets in and out by more than many edges' length (the walls and infill region of a slice):
// edges trimmed away at both ends are dropped by the direct route as ClipperOffset's union drops
// them, so the regions are ClipperOffset's, and the direct route (no union) takes more of them
// (224 of these 480; before edges were dropped, 93).
TEST(Regions, OffsetOfTessellatedCurvesIsClipperOffsetsAndMostlyDirect) {
  std::size_t cases = 0, direct = 0;
  for (std::uint64_t trial = 0; trial < 80; ++trial) {
    Rng rng(0x7e55e11a7e + trial);
    const Regions r = tessellated_region(rng);
    for (const double d : {-0.94, -0.6, -0.4, -0.2, 0.2, 0.5}) {
      const Regions got = offset(r, d);
      const Regions want = clipper_offset(r, d);
      ++cases;
      // The rings as offset() hands them over: outer counter-clockwise, holes clockwise.
      cl::Paths rings, out;
      for (const auto& poly : r) {
        rings.push_back(clipper_util::to_path(poly.outer));
        if (!cl::Orientation(rings.back())) cl::ReversePath(rings.back());
        for (const auto& h : poly.holes) {
          rings.push_back(clipper_util::to_path(h));
          if (cl::Orientation(rings.back())) cl::ReversePath(rings.back());
        }
      }
      direct += clipper_util::offset_directly(rings, d * kClipperScale, 2.0, out) ? 1 : 0;
      const std::string what = "trial " + std::to_string(trial) + " delta " + std::to_string(d);
      ASSERT_EQ(got.size(), want.size()) << what;
      EXPECT_EQ(holes(got), holes(want)) << what;
      const double tol = 4e-6 * (perimeter(want) + perimeter(got)) + 1e-9;
      EXPECT_NEAR(area(difference(got, want)), 0, tol) << what;
      EXPECT_NEAR(area(difference(want, got)), 0, tol) << what;
    }
  }
  EXPECT_GT(direct, 2 * cases / 5) << direct << " of " << cases << " offsets were direct";
}

// Whether two edges of the rings meet (not neighbours at their shared point), every pair tested:
// the plain way rings_meet's sweep and grid must agree with.
bool edges_meet_plainly(const cl::Paths& rings) {
  auto orient = [](const cl::IntPoint& a, const cl::IntPoint& b, const cl::IntPoint& c) {
    const __int128 v = static_cast<__int128>(b.X - a.X) * (c.Y - a.Y) -
                       static_cast<__int128>(b.Y - a.Y) * (c.X - a.X);
    return v > 0 ? 1 : v < 0 ? -1 : 0;
  };
  auto on = [](const cl::IntPoint& p, const cl::IntPoint& q, const cl::IntPoint& r) {
    return std::min(p.X, q.X) <= r.X && r.X <= std::max(p.X, q.X) && std::min(p.Y, q.Y) <= r.Y &&
           r.Y <= std::max(p.Y, q.Y);
  };
  struct E {
    std::size_t ring, edge;
    cl::IntPoint a, b;
  };
  std::vector<E> all;
  for (std::size_t r = 0; r < rings.size(); ++r)
    for (std::size_t e = 0; e < rings[r].size(); ++e)
      all.push_back({r, e, rings[r][e], rings[r][(e + 1) % rings[r].size()]});
  for (std::size_t i = 0; i < all.size(); ++i)
    for (std::size_t j = i + 1; j < all.size(); ++j) {
      const E& p = all[i];
      const E& q = all[j];
      const std::size_t m = rings[p.ring].size();
      if (p.ring == q.ring && (q.edge == p.edge + 1 || (p.edge == 0 && q.edge + 1 == m))) {
        // Neighbours: they meet elsewhere only where the second runs back along the first.
        const E& first = q.edge == p.edge + 1 ? p : q;
        const E& second = q.edge == p.edge + 1 ? q : p;
        const __int128 dot =
            static_cast<__int128>(first.b.X - first.a.X) * (second.b.X - second.a.X) +
            static_cast<__int128>(first.b.Y - first.a.Y) * (second.b.Y - second.a.Y);
        if (orient(first.a, first.b, second.b) == 0 && dot < 0) return true;
        continue;
      }
      const int d1 = orient(p.a, p.b, q.a), d2 = orient(p.a, p.b, q.b);
      const int d3 = orient(q.a, q.b, p.a), d4 = orient(q.a, q.b, p.b);
      if (d1 * d2 < 0 && d3 * d4 < 0) return true;
      if ((d1 == 0 && on(p.a, p.b, q.a)) || (d2 == 0 && on(p.a, p.b, q.b)) ||
          (d3 == 0 && on(q.a, q.b, p.a)) || (d4 == 0 && on(q.a, q.b, p.b)))
        return true;
    }
  return false;
}

// offset_directly's test for rings that meet, found by a sweep along x (clipper_util::
// rings_meet) and by the grid it replaced: the same answer and the same give-up on seeded rings
// (a slice's curves offset, stars, strips side by side along x that send the sweep to the grid,
// long diagonal edges that make the grid give up), and where neither gives up the answer of
// testing every pair.
TEST(Regions, RingsMeetBySweepIsTheGridsAnswer) {
  std::size_t cases = 0, met = 0, apart = 0, gave_up_count = 0, strips = 0;
  for (std::uint64_t trial = 0; trial < 300; ++trial) {
    Rng rng(0x5ee9a11 + trial);
    cl::Paths rings;
    const int kind = static_cast<int>(trial % 4);
    if (kind == 0 || kind == 1) {
      // Offset rings as offset_directly checks them (before the check: they may cross).
      const Regions r =
          kind == 0 ? tessellated_region(rng) : test::random_region(rng, 1 + 10 * rng.uniform01());
      for (const auto& poly : r) {
        rings.push_back(clipper_util::to_path(poly.outer));
        for (const auto& h : poly.holes) rings.push_back(clipper_util::to_path(h));
      }
      const double d = (rng.uniform01() - 0.6) * 2.0 * kClipperScale;
      cl::ClipperOffset off(2.0, 0.002 * kClipperScale);
      off.AddPaths(rings, cl::jtMiter, cl::etClosedPolygon);
      cl::Paths out;
      off.Execute(out, d);
      if (out.empty()) continue;
      rings = out;
      if (rng.uniform01() < 0.5) {
        // A copy of one ring moved by up to a few of its points' spacing: meets it or not.
        cl::Path moved = rings[rng.uniform_index(rings.size())];
        const auto dx = static_cast<cl::cInt>((rng.uniform01() - 0.5) * 0.2 * kClipperScale);
        const auto dy = static_cast<cl::cInt>((rng.uniform01() - 0.5) * 0.2 * kClipperScale);
        for (auto& q : moved) q.X += dx, q.Y += dy;
        rings.push_back(moved);
      }
    } else if (kind == 2) {
      // Thin strips stacked along y, each as wide as the part: every edge overlaps every other
      // along x (the sweep hands over to the grid); sometimes one strip crosses its neighbour.
      const int n = 20 + static_cast<int>(rng.uniform_index(60));
      for (int k = 0; k < n; ++k) {
        const cl::cInt y = k * 1000, w = 1000000;
        rings.push_back({{0, y}, {w, y + 10}, {w, y + 500}, {0, y + 490}});
      }
      if (rng.uniform01() < 0.5) rings[rng.uniform_index(rings.size())][2].Y += 700;
      ++strips;
    } else {
      // A few long diagonal edges and short ones: the grid may give up.
      const int n = 3 + static_cast<int>(rng.uniform_index(30));
      for (int k = 0; k < 1 + static_cast<int>(rng.uniform_index(3)); ++k)
        rings.push_back(clipper_util::to_path(
            test::star(rng, {10.0 * k * rng.uniform01(), 5.0 * rng.uniform01()}, 1, 40, n, true)));
    }
    bool gave_up_sweep = false, gave_up_grid = false;
    const bool sweep = clipper_util::rings_meet(rings, gave_up_sweep, true);
    const bool grid = clipper_util::rings_meet(rings, gave_up_grid, false);
    const std::string what = "trial " + std::to_string(trial);
    ASSERT_EQ(sweep, grid) << what;
    ASSERT_EQ(gave_up_sweep, gave_up_grid) << what;
    ++cases;
    if (gave_up_sweep) {
      ++gave_up_count;
      continue;
    }
    ASSERT_EQ(sweep, edges_meet_plainly(rings)) << what;
    (sweep ? met : apart) += 1;
  }
  // Both answers and the give-up occur.
  EXPECT_GT(met, cases / 10);
  EXPECT_GT(apart, cases / 10);
  EXPECT_GT(gave_up_count, 0u);
  EXPECT_GT(strips, 0u);
}

}  // namespace
}  // namespace trellis
