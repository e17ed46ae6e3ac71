// Direct contours against exact cross-sections, field route against mesh route, mesh IO, and the
// planar slicer's properties checked by rasterising what it prints.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <random>

#include "support/random_regions.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/pipeline.hpp"
#include "trellis/slice/slice.hpp"

using namespace trellis;

namespace {

const std::string kDesigns = std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/";
constexpr double kPi = std::numbers::pi;

struct Analytic {
  std::string name;
  Field field;
  std::function<double(double z)> area;                 // exact cross-section area
  std::function<std::vector<Vec2>(double z)> boundary;  // exact boundary samples
};

std::vector<Vec2> circle_pts(double cx, double cy, double r, int n = 720) {
  std::vector<Vec2> p;
  for (int i = 0; i < n; ++i)
    p.push_back({cx + r * std::cos(2 * kPi * i / n), cy + r * std::sin(2 * kPi * i / n)});
  return p;
}

std::vector<Analytic> analytic_shapes() {
  std::vector<Analytic> v;
  v.push_back({"sphere", sphere(10), [](double z) { return kPi * (100 - z * z); },
               [](double z) { return circle_pts(0, 0, std::sqrt(100 - z * z)); }});
  v.push_back({"box", rectprism({20, 12, 8}), [](double) { return 240.0; },
               [](double) {
                 std::vector<Vec2> p;
                 for (int i = 0; i <= 200; ++i) {
                   const double t = i / 200.0;
                   p.push_back({-10 + 20 * t, -6});
                   p.push_back({-10 + 20 * t, 6});
                   p.push_back({-10, -6 + 12 * t});
                   p.push_back({10, -6 + 12 * t});
                 }
                 return p;
               }});
  v.push_back({"cylinder", cylinder(7, 10), [](double) { return kPi * 49; },
               [](double) { return circle_pts(0, 0, 7); }});
  v.push_back({"torus", torus(10, 3),
               [](double z) {
                 const double w = std::sqrt(9 - z * z);
                 return kPi * ((10 + w) * (10 + w) - (10 - w) * (10 - w));
               },
               [](double z) {
                 const double w = std::sqrt(9 - z * z);
                 auto a = circle_pts(0, 0, 10 + w), b = circle_pts(0, 0, 10 - w);
                 a.insert(a.end(), b.begin(), b.end());
                 return a;
               }});
  v.push_back({"ring (difference)", subtract({cylinder(50, 15), cylinder(15, 15)}),
               [](double) { return kPi * (2500 - 225); },
               [](double) {
                 auto a = circle_pts(0, 0, 50, 2000), b = circle_pts(0, 0, 15);
                 a.insert(a.end(), b.begin(), b.end());
                 return a;
               }});
  v.push_back({"two spheres (union)",
               unite({translate(sphere(5), {-4, 0, 0}), translate(sphere(5), {4, 0, 0})}),
               [](double z) {
                 const double r2 = 25 - z * z, r = std::sqrt(r2), d = 8;
                 // Two circles of radius r, centres 8 apart: 2πr² minus the lens.
                 if (d >= 2 * r) return 2 * kPi * r2;
                 const double lens =
                     2 * r2 * std::acos(d / (2 * r)) - 0.5 * d * std::sqrt(4 * r2 - d * d);
                 return 2 * kPi * r2 - lens;
               },
               [](double z) {
                 const double r = std::sqrt(25 - z * z);
                 std::vector<Vec2> out;
                 for (auto p : circle_pts(-4, 0, r))
                   if (p.x <= 0) out.push_back(p);
                 for (auto p : circle_pts(4, 0, r))
                   if (p.x >= 0) out.push_back(p);
                 return out;
               }});
  return v;
}

TEST(Contours, MatchExactCrossSections) {
  FieldSliceOptions opt;
  opt.resolution = 0.1;
  for (const auto& s : analytic_shapes()) {
    Evaluator ev(s.field);
    const BBox3 e = s.field.extent();
    for (int k = 1; k < 10; ++k) {
      const double z = e.min.z + (e.max.z - e.min.z) * k / 10.0 + 1e-3;
      const Regions r = contour_at(s.field, ev, z, opt);
      const double exact = s.area(z);
      ASSERT_GT(exact, 0);
      EXPECT_NEAR(area(r), exact, 0.005 * exact) << s.name << " z=" << z;
      // Every contour vertex lies on the surface within 0.1% of the resolution (the field
      // is an exact distance for these shapes).
      double worst = 0;
      for (const auto& ring : rings_of(r))
        for (auto p : ring) worst = std::max(worst, std::abs(ev.value({p.x, p.y, z})));
      EXPECT_LT(worst, 1e-3 * opt.resolution) << s.name << " z=" << z;
      // Hausdorff: exact boundary → contour within the resolution (contour → exact is `worst`).
      double back = 0;
      for (auto p : s.boundary(z)) back = std::max(back, test::outline_distance(p, r));
      EXPECT_LT(back, opt.resolution) << s.name << " z=" << z;
    }
  }
}

TEST(Contours, HolesNestAndOrient) {
  Evaluator ev(subtract({cylinder(50, 15), cylinder(15, 15)}));
  FieldSliceOptions opt;
  const Field f = subtract({cylinder(50, 15), cylinder(15, 15)});
  const Regions r = contour_at(f, ev, 0.0, opt);
  ASSERT_EQ(r.size(), 1u);
  ASSERT_EQ(r[0].holes.size(), 1u);
  EXPECT_GT(signed_area(r[0].outer), 0);
  EXPECT_LT(signed_area(r[0].holes[0]), 0);
}

// Stitching: shuffled directed segments of random polygons come back as loops when each shared
// end is moved, in a random direction, by less than the tolerance on one of its two segments;
// moved by more than the tolerance, no junction joins.
TEST(Contours, StitchingRecoversShuffledLoops) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(0, 2 * kPi);
  const double tol = 1e-6;
  for (double scale : {0.4, 3.0}) {
    const bool joins = scale < 1;
    for (int trial = 0; trial < 50; ++trial) {
      std::vector<Segment2> segs;
      std::vector<Vec2> exact;
      const int loops = 1 + static_cast<int>(rng() % 5);
      std::size_t points = 0;
      for (int l = 0; l < loops; ++l) {
        const int n = 3 + static_cast<int>(rng() % 50);
        const auto pts = circle_pts(30.0 * l, 0, 5 + l, n);
        exact.insert(exact.end(), pts.begin(), pts.end());
        // Junction j (pts[j]) ends segment j-1 and starts segment j: one of the two is moved.
        std::vector<Vec2> offset(n);
        std::vector<bool> move_end(n);
        for (int j = 0; j < n; ++j) {
          const double t = angle(rng);
          offset[j] = Vec2{std::cos(t), std::sin(t)} * (scale * tol);
          move_end[j] = rng() % 2;
        }
        for (int i = 0; i < n; ++i) {
          const int j = (i + 1) % n;
          segs.push_back({pts[i] + (move_end[i] ? Vec2{} : offset[i]),
                          pts[j] + (move_end[j] ? offset[j] : Vec2{})});
        }
        points += n;
      }
      std::shuffle(segs.begin(), segs.end(), rng);
      const StitchedLines s = stitch_segments(segs, tol);
      if (!joins) {
        EXPECT_TRUE(s.loops.empty()) << "trial " << trial;
        EXPECT_EQ(s.open.size(), points) << "trial " << trial;
        continue;
      }
      EXPECT_EQ(s.loops.size(), static_cast<std::size_t>(loops)) << "trial " << trial;
      EXPECT_TRUE(s.open.empty()) << "trial " << trial;
      std::size_t total = 0;
      for (const auto& l : s.loops) {
        total += l.size();
        for (const Vec2 p : l) {
          double nearest = 1e9;
          for (const Vec2 q : exact) nearest = std::min(nearest, std::hypot(p.x - q.x, p.y - q.y));
          EXPECT_LE(nearest, tol);
        }
      }
      EXPECT_EQ(total, points) << "trial " << trial;
    }
  }
  // An open iso-line stays open.
  const StitchedLines open = stitch_segments({{{0, 0}, {1, 0}}, {{1, 0}, {2, 1}}}, 1e-6);
  ASSERT_EQ(open.open.size(), 1u);
  EXPECT_EQ(open.open[0].size(), 3u);
}

// The hatch sweep against a brute-force scan: every line crosses every edge it spans (half-open
// in the across coordinate), crossings sorted and paired. Random star polygons with holes, random
// angles, spacings and origins, plus a square whose vertices lie on the lines.
TEST(Regions, HatchMatchesABruteForceScanOfEveryEdge) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(0, 1);
  auto star = [&](Vec2 c, double r0, double r1, int n) {
    std::vector<double> ang(n);
    for (auto& a : ang) a = 2 * kPi * U(rng);
    std::sort(ang.begin(), ang.end());
    std::vector<Vec2> ring;
    for (double a : ang) {
      const double r = r0 + (r1 - r0) * U(rng);
      ring.push_back(c + Vec2{r * std::cos(a), r * std::sin(a)});
    }
    return ring;
  };
  for (int trial = 0; trial < 200; ++trial) {
    Regions regions;
    const int n = 3 + static_cast<int>(rng() % 40);
    Polygon2 a;
    a.outer = star({0, 0}, 6, 15, n);
    if (trial % 2) a.holes.push_back(star({0, 0}, 1, 4, 3 + static_cast<int>(rng() % 12)));
    regions.push_back(a);
    Polygon2 b;
    b.outer = star({40, 10}, 2, 8, 3 + static_cast<int>(rng() % 20));
    regions.push_back(b);
    double angle = 180 * U(rng), spacing = 0.1 + 1.4 * U(rng);
    Vec2 origin{10 * U(rng) - 5, 10 * U(rng) - 5};
    if (trial == 0) {  // vertices exactly on scan lines
      regions = {Polygon2{{{0, 0}, {4, 0}, {4, 4}, {0, 4}}, {}}};
      angle = 0;
      spacing = 0.5;
      origin = {0, 0};
    }
    const std::vector<Segment2> got = hatch(regions, angle, spacing, origin);
    // Brute force.
    const double rad = angle * kPi / 180;
    const Vec2 u{std::cos(rad), std::sin(rad)}, v{-std::sin(rad), std::cos(rad)};
    double tmin = 1e300, tmax = -1e300;
    for (const auto& ring : rings_of(regions))
      for (const Vec2 p : ring) {
        const double t = (p.x - origin.x) * v.x + (p.y - origin.y) * v.y;
        tmin = std::min(tmin, t);
        tmax = std::max(tmax, t);
      }
    std::vector<Segment2> want;
    for (long long k = static_cast<long long>(std::ceil(tmin / spacing));
         k <= static_cast<long long>(std::floor(tmax / spacing)); ++k) {
      const double t = static_cast<double>(k) * spacing;
      std::vector<double> xs;
      for (const auto& ring : rings_of(regions))
        for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
          const Vec2 p = ring[j] - origin, q = ring[i] - origin;
          double sp = p.x * u.x + p.y * u.y, tp = p.x * v.x + p.y * v.y;
          double sq = q.x * u.x + q.y * u.y, tq = q.x * v.x + q.y * v.y;
          if (tp == tq) continue;
          if (tp > tq) std::swap(tp, tq), std::swap(sp, sq);
          if (tp <= t && t < tq) xs.push_back(sp + (sq - sp) * (t - tp) / (tq - tp));
        }
      std::sort(xs.begin(), xs.end());
      ASSERT_EQ(xs.size() % 2, 0u) << "trial " << trial << " line " << k;
      for (std::size_t i = 0; i + 1 < xs.size(); i += 2)
        if (xs[i + 1] - xs[i] > 1e-9)
          want.push_back({origin + u * xs[i] + v * t, origin + u * xs[i + 1] + v * t});
    }
    ASSERT_EQ(got.size(), want.size()) << "trial " << trial;
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_NEAR(got[i].a.x, want[i].a.x, 1e-9) << "trial " << trial << " segment " << i;
      EXPECT_NEAR(got[i].a.y, want[i].a.y, 1e-9) << "trial " << trial << " segment " << i;
      EXPECT_NEAR(got[i].b.x, want[i].b.x, 1e-9) << "trial " << trial << " segment " << i;
      EXPECT_NEAR(got[i].b.y, want[i].b.y, 1e-9) << "trial " << trial << " segment " << i;
    }
    if (trial == 0) EXPECT_EQ(got.size(), 8u);  // lines t = 0 … 3.5 (t = 4 is the open end)
  }
}

// Clipper's output is nested by us (no PolyTree): islands in holes of islands, and a plate with
// many holes, through each operation. Every hole lies inside its polygon's outer ring and in no
// other polygon; islands in a hole come before the polygon whose hole it is (a PolyTree's order).
TEST(Regions, NestIslandsInHolesAndManyHoles) {
  auto square = [](double c, double h, bool ccw) {
    std::vector<Vec2> r{{c - h, c - h}, {c + h, c - h}, {c + h, c + h}, {c - h, c + h}};
    if (!ccw) std::reverse(r.begin(), r.end());
    return r;
  };
  // Concentric squares, half sizes 10, 9, …, 3: four islands with a hole each, each island in the
  // hole of the one around it.
  std::vector<std::vector<Vec2>> rings;
  for (int k = 0; k < 8; ++k) rings.push_back(square(0, 10 - k, k % 2 == 0));
  const auto check_nested = [](const Regions& r, const char* what) {
    for (std::size_t i = 0; i < r.size(); ++i) {
      for (const auto& h : r[i].holes) {
        EXPECT_TRUE(inside_ring(r[i].outer, h.front()) ||
                    inside_ring(r[i].outer, (h[0] + h[1]) * 0.5))
            << what << ": polygon " << i;
        for (std::size_t j = 0; j < r.size(); ++j)
          if (j != i)
            EXPECT_FALSE(contains(r[j], (h[0] + h[2]) * 0.5, 0)) << what << ": hole of " << i;
      }
      // An island inside polygon i's outer ring lies in one of its holes, and comes first.
      for (std::size_t j = 0; j < r.size(); ++j)
        if (j != i && inside_ring(r[i].outer, r[j].outer.front())) {
          EXPECT_LT(j, i) << what;
          EXPECT_FALSE(contains(r[i], r[j].outer.front(), 0)) << what;
        }
    }
  };
  const Regions nested = nest_rings(rings);
  ASSERT_EQ(nested.size(), 4u);
  EXPECT_NEAR(area(nested), 400 - 324 + 256 - 196 + 144 - 100 + 64 - 36, 1e-6);
  for (const auto& poly : nested) EXPECT_EQ(poly.holes.size(), 1u);
  EXPECT_NEAR(std::abs(signed_area(nested[0].outer)), 64, 1e-6);  // the innermost first
  check_nested(nested, "nest_rings");
  check_nested(offset(nested, -0.2), "offset in");
  check_nested(offset(nested, 0.2), "offset out");
  check_nested(unite(nested, {}), "unite");
  check_nested(intersection(nested, Regions{Polygon2{square(0, 9.5, true), {}}}), "intersection");
  check_nested(difference(nested, Regions{Polygon2{square(0, 4, true), {}}}), "difference");
  // A plate with 30 x 30 holes: one polygon, every hole kept.
  Polygon2 plate{square(75, 75, true), {}};
  for (int k = 0; k < 900; ++k) {
    const Vec2 c{(k % 30 + 0.5) * 5, (k / 30 + 0.5) * 5};
    plate.holes.push_back({c + Vec2{-1, -1}, c + Vec2{-1, 1}, c + Vec2{1, 1}, c + Vec2{1, -1}});
  }
  for (const double d : {-0.3, 0.3}) {
    const Regions r = offset(Regions{plate}, d);
    ASSERT_EQ(r.size(), 1u) << d;
    EXPECT_EQ(r[0].holes.size(), 900u) << d;
    check_nested(r, "plate");
  }
}

// Nesting at any slope: concentric jittered stars (six bands, alternately outer ring and hole) at
// two centres side by side, nested and then offset in and out. Each band's polygon keeps its
// one hole, the area is the bands' alternating sum, and every hole lies in its own outer ring.
TEST(Regions, NestJitteredConcentricStars) {
  for (std::uint64_t trial = 0; trial < 40; ++trial) {
    Rng rng(0x5eed + trial);
    std::vector<std::vector<Vec2>> rings;
    double want = 0;
    for (const Vec2 c : {Vec2{0, 0}, Vec2{21, 3}})
      for (int k = 0; k < 6; ++k) {
        const double r = 9.5 - 1.5 * k;
        rings.push_back(test::star(rng, c, r - 0.5, r, 32 + static_cast<int>(rng.uniform_index(64)),
                                   k % 2 == 0));
        want += (k % 2 == 0 ? 1 : -1) * std::abs(signed_area(rings.back()));
      }
    const Regions nested = nest_rings(rings);
    ASSERT_EQ(nested.size(), 6u) << "trial " << trial;
    // (Clipper's 1 nm grid along some 500 mm of rings: at most 2.5e-4 mm².)
    EXPECT_NEAR(area(nested), want, 2.5e-4) << "trial " << trial;
    for (const double d : {0.0, -0.05, 0.05}) {
      const Regions r = d == 0 ? nested : offset(nested, d);
      ASSERT_EQ(r.size(), 6u) << "trial " << trial << " offset " << d;
      for (std::size_t i = 0; i < r.size(); ++i) {
        ASSERT_EQ(r[i].holes.size(), 1u) << "trial " << trial << " offset " << d;
        for (const Vec2 v : r[i].holes[0])
          EXPECT_TRUE(inside_ring(r[i].outer, v)) << "trial " << trial << " offset " << d;
      }
    }
  }
}

// Marching keeps its buffers per thread between calls; a function that marches while being
// marched (nested) must get buffers of its own and leave the outer march's intact.
TEST(Contours, NestedMarchesKeepTheirOwnBuffers) {
  struct Disc : PlaneFunction {
    Vec2 c;
    double r;
    void sample(const Vec2* p, double* out, std::size_t n) override {
      for (std::size_t i = 0; i < n; ++i) out[i] = std::hypot(p[i].x - c.x, p[i].y - c.y) - r;
    }
  };
  struct Nesting : Disc {
    std::size_t inner_loops = 0;
    void sample(const Vec2* p, double* out, std::size_t n) override {
      Disc inner;
      inner.c = {0, 0};
      inner.r = 1;
      MarchOptions mo;
      mo.resolution = 0.25;
      inner_loops += march_squares(inner, {-2, -2}, {2, 2}, 0, mo).lines.loops.size();
      Disc::sample(p, out, n);
    }
  };
  MarchOptions mo;
  mo.resolution = 0.1;
  Disc plain;
  plain.c = {0.3, -0.2};
  plain.r = 3;
  Nesting nesting;
  nesting.c = plain.c;
  nesting.r = plain.r;
  const ContourSet a = march_squares(plain, {-5, -5}, {5, 5}, 0, mo);
  const ContourSet b = march_squares(nesting, {-5, -5}, {5, 5}, 0, mo);
  EXPECT_GT(nesting.inner_loops, 0u);
  ASSERT_EQ(a.lines.loops.size(), 1u);
  ASSERT_EQ(b.lines.loops.size(), 1u);
  ASSERT_EQ(a.lines.loops[0].size(), b.lines.loops[0].size());
  for (std::size_t i = 0; i < a.lines.loops[0].size(); ++i) {
    EXPECT_EQ(a.lines.loops[0][i].x, b.lines.loops[0][i].x) << i;
    EXPECT_EQ(a.lines.loops[0][i].y, b.lines.loops[0][i].y) << i;
  }
}

// The cubic first guess of a crossing: the exact root for a cubic along the edge, a quadratic
// where a neighbour is missing; in a march, the same contour within the tolerance from about
// one refinement sample per crossing instead of two or three.
TEST(Contours, CubicGuessFindsCrossingsWithFewerSamples) {
  // p(s) = (s − 0.3)(s + 2)(s − 4): values at s = −1, 0, 1, 2 and its root 0.3 in (0, 1).
  const auto cubic = [](double s) { return (s - 0.3) * (s + 2) * (s - 4); };
  EXPECT_NEAR(crossing_guess(cubic(-1), cubic(0), cubic(1), cubic(2)), 0.3, 1e-12);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto quad = [](double s) { return (s - 0.7) * (s + 1.5); };
  EXPECT_NEAR(crossing_guess(nan, quad(0), quad(1), quad(2)), 0.7, 1e-12);
  EXPECT_NEAR(crossing_guess(quad(-1), quad(0), quad(1), nan), 0.7, 1e-12);
  EXPECT_EQ(crossing_guess(nan, -1, 1, nan), -1);  // no neighbour: the caller's straight line

  // The PBF section's kind of field: a gyroid sheet φ² − c² (2.5 mm cells, c = 0.3) in a layer,
  // on its 25 µm grid with its 0.25 µm tolerance. Not a distance: the straight line between two
  // nodes misses its crossings by more than the tolerance.
  struct Sheet : PlaneFunction {
    void sample(const Vec2* p, double* out, std::size_t n) override {
      const double k = 2 * std::numbers::pi / 2.5, z = 0.37;
      for (std::size_t i = 0; i < n; ++i) {
        const double x = k * p[i].x, y = k * p[i].y;
        const double phi = std::sin(x) * std::cos(y) + std::sin(y) * std::cos(k * z) +
                           std::sin(k * z) * std::cos(x);
        out[i] = phi * phi - 0.09;
      }
    }
  } sheet;
  MarchOptions plain;
  plain.resolution = 0.025;
  plain.refine_fraction = 1e-2;
  MarchOptions cubic_opts = plain;
  cubic_opts.cubic_guess = true;
  const ContourSet a = march_squares(sheet, {0, 0}, {2.5, 2.5}, 0, plain);
  const ContourSet b = march_squares(sheet, {0, 0}, {2.5, 2.5}, 0, cubic_opts);
  ASSERT_EQ(a.lines.loops.size(), b.lines.loops.size());
  ASSERT_EQ(a.lines.open.size(), b.lines.open.size());
  std::size_t crossings = 0;
  double worst = 0;
  auto check = [&](const std::vector<std::vector<Vec2>>& la,
                   const std::vector<std::vector<Vec2>>& lb) {
    for (std::size_t k = 0; k < la.size(); ++k) {
      ASSERT_EQ(la[k].size(), lb[k].size());
      for (std::size_t i = 0; i < la[k].size(); ++i) {
        // Both within the bracket tolerance (1e-2 of a cell) of the same crossing.
        worst = std::max(worst, std::hypot(la[k][i].x - lb[k][i].x, la[k][i].y - lb[k][i].y));
        ++crossings;
      }
    }
  };
  check(a.lines.loops, b.lines.loops);
  check(a.lines.open, b.lines.open);
  ASSERT_GT(crossings, 500u);
  EXPECT_LT(worst, 2e-2 * plain.resolution);
  // The same grid nodes; about one refinement sample fewer per crossing (two become one).
  ASSERT_GT(a.samples, b.samples);
  EXPECT_GT(static_cast<double>(a.samples - b.samples), 0.9 * static_cast<double>(crossings))
      << "samples: straight line " << a.samples << ", cubic " << b.samples << ", crossings "
      << crossings;
}

// The points of a march's lines, and the largest distance from a point of `from` to the
// nearest of `to` (points by their 10 µm cell: for sets whose points pair up closely).
std::vector<Vec2> contour_points(const ContourSet& c) {
  std::vector<Vec2> v;
  for (const auto& l : c.lines.loops) v.insert(v.end(), l.begin(), l.end());
  for (const auto& l : c.lines.open) v.insert(v.end(), l.begin(), l.end());
  return v;
}
double farthest_point(const std::vector<Vec2>& from, const std::vector<Vec2>& to) {
  std::map<std::pair<long, long>, std::vector<Vec2>> cells;
  auto key = [](Vec2 p) {
    return std::pair{static_cast<long>(std::floor(p.x / 0.01)),
                     static_cast<long>(std::floor(p.y / 0.01))};
  };
  for (const Vec2 p : to) cells[key(p)].push_back(p);
  double worst = 0;
  for (const Vec2 p : from) {
    double best = 1e9;
    const auto [ci, cj] = key(p);
    for (long di = -1; di <= 1; ++di)
      for (long dj = -1; dj <= 1; ++dj) {
        const auto it = cells.find({ci + di, cj + dj});
        if (it == cells.end()) continue;
        for (const Vec2 q : it->second) best = std::min(best, std::hypot(q.x - p.x, q.y - p.y));
      }
    worst = std::max(worst, best);
  }
  return worst;
}
// Two marches' lines alike: as many loops and open lines, as many points (more than
// min_points), every point of each within tol of a point of the other.
void expect_same_lines(const ContourSet& a, const ContourSet& b, double tol,
                       std::size_t min_points) {
  ASSERT_EQ(a.lines.loops.size(), b.lines.loops.size());
  ASSERT_EQ(a.lines.open.size(), b.lines.open.size());
  const std::vector<Vec2> pa = contour_points(a), pb = contour_points(b);
  ASSERT_EQ(pa.size(), pb.size());
  ASSERT_GT(pa.size(), min_points);
  EXPECT_LT(farthest_point(pa, pb), tol);
  EXPECT_LT(farthest_point(pb, pa), tol);
}

// A function that repeats across the plane, cut by a disc: where it declares the repeating
// function alone (blocks inside the disc), the march contours one block per place in the period
// and translates the rest (MarchOptions::periodic_tiles). The same loops, the same crossings
// (each within the refinement tolerance of its edge's crossing), far fewer samples; nothing is
// translated when the period is not a whole number of cells. Tiles made by a march over one
// period of the repeating function alone (MarchOptions::tiles_out) give the same again with no
// block marched for them (tiles_in); tiles of another grid are ignored.
TEST(Contours, PeriodicTilesGiveTheSameContours) {
  struct Lattice : PlaneFunction {
    double P = 2.5;
    Vec2 o{6.13, 5.87};
    double R = 5.3;
    void sample(const Vec2* p, double* out, std::size_t n) override {
      const double k = 2 * std::numbers::pi / P;
      for (std::size_t i = 0; i < n; ++i) {
        const double x = k * p[i].x, y = k * p[i].y;
        const double phi =
            std::sin(x) * std::cos(y) + std::sin(y) * std::cos(0.4) + std::sin(0.4) * std::cos(x);
        const double sheet = phi * phi - 0.09;
        out[i] = std::max(sheet, std::hypot(p[i].x - o.x, p[i].y - o.y) - R);
      }
    }
    Vec2 period() const override { return {P, P}; }
    bool periodic(Vec2 lo, Vec2 hi) override {
      for (const Vec2 c : {lo, hi, Vec2{lo.x, hi.y}, Vec2{hi.x, lo.y}})
        if (!(std::hypot(c.x - o.x, c.y - o.y) < R)) return false;
      return true;
    }
    // With a bound (the disc's distance interval; the sheet within [−0.09, 5.3]), blocks along
    // the circle are split, and their quarters inside it are taken from the tiles by cells.
    bool bounded = false;
    Interval bound(Vec2 lo, Vec2 hi) override {
      if (!bounded) return PlaneFunction::bound(lo, hi);
      const double dx = std::max({lo.x - o.x, 0.0, o.x - hi.x}),
                   dy = std::max({lo.y - o.y, 0.0, o.y - hi.y});
      const double far = std::hypot(std::max(std::abs(lo.x - o.x), std::abs(hi.x - o.x)),
                                    std::max(std::abs(lo.y - o.y), std::abs(hi.y - o.y)));
      return {std::max(-0.09, std::hypot(dx, dy) - R), std::max(5.3, far - R)};
    }
  } f;
  MarchOptions tiled;
  tiled.resolution = 0.025;
  MarchOptions plain = tiled;
  plain.periodic_tiles = false;
  // The tiles of one period of the sheet alone (the disc far larger), from the same grid origin.
  Lattice sheet = f;
  sheet.R = 1e3;
  PeriodTiles period_tiles, coarse_tiles;
  {
    MarchOptions out = tiled;
    out.tiles_out = &period_tiles;
    const ContourSet none = march_squares(sheet, {0, 0}, {2.5, 2.5}, 0, out);
    EXPECT_TRUE(none.lines.loops.empty() && none.lines.open.empty());
    ASSERT_TRUE(period_tiles.data);
    EXPECT_GT(period_tiles.bytes, 10000u);
    out.resolution = 0.05;
    out.tiles_out = &coarse_tiles;
    march_squares(sheet, {0, 0}, {2.5, 2.5}, 0, out);
    ASSERT_TRUE(coarse_tiles.data);
  }
  MarchOptions given = tiled;
  given.tiles_in = &period_tiles;
  MarchOptions other_grid = tiled;
  other_grid.tiles_in = &coarse_tiles;
  for (const bool bounded : {false, true}) {
    SCOPED_TRACE(bounded ? "bounded" : "unbounded");
    f.bounded = bounded;
    const ContourSet a = march_squares(f, {0, 0}, {12.5, 12}, 0, plain);
    const ContourSet b = march_squares(f, {0, 0}, {12.5, 12}, 0, tiled);
    const ContourSet c = march_squares(f, {0, 0}, {12.5, 12}, 0, given);
    const ContourSet d = march_squares(f, {0, 0}, {12.5, 12}, 0, other_grid);
    EXPECT_EQ(d.samples, b.samples);
    EXPECT_EQ(d.tiled_blocks, b.tiled_blocks);
    EXPECT_EQ(d.lines.loops, b.lines.loops);
    // Every periodic whole block translated, the tiles' places too; none sampled.
    EXPECT_GT(c.tiled_blocks, b.tiled_blocks);
    EXPECT_LT(c.samples, b.samples);
    EXPECT_EQ(c.tiled_parts, b.tiled_parts);
    EXPECT_EQ(a.tiled_blocks, 0u);
    EXPECT_EQ(a.tiled_parts, 0u);
    EXPECT_GT(b.tiled_blocks, b.blocks / 2);
    // (Unbounded, blocks across the circle are marched whole.)
    if (bounded)
      EXPECT_GT(b.tiled_parts, 100u);
    else
      EXPECT_EQ(b.tiled_parts, 0u);
    EXPECT_LT(b.samples, a.samples / 2);
    // Every point of one within twice the refinement tolerance of a point of the other (the loops
    // may start elsewhere): points by their grid cell.
    const double tol = 2 * tiled.refine_fraction * tiled.resolution + 1e-12;
    expect_same_lines(a, b, tol, 5000);
    expect_same_lines(a, c, tol, 5000);
  }
  // A period of 2.51 mm is not a whole number of 25 µm cells: every block is marched.
  f.P = 2.51;
  EXPECT_EQ(march_squares(f, {0, 0}, {12.5, 12}, 0, tiled).tiled_blocks, 0u);
}

// Tiles turned half a turn (point_reflected_tiles): a layer of a gyroid sheet Φ(x, y, z) and its
// mirror layer Φ(x, y, −z) = Φ(−x, −y, z), cut by a disc; and of the gyroid φ itself, odd, whose
// inside swaps (φ(x, y, −z) = −φ(−x, −y, z): the lines run the other way). The mirror layer
// marched with the first layer's tiles turned gives the same loops as marched on its own (every
// point within twice the refinement tolerance, the same signed areas), with fewer samples.
// Turned tiles are made only when the turn takes tiles onto tiles.
TEST(Contours, PointReflectedTilesGiveTheSameContours) {
  struct Layer : PlaneFunction {
    double z = 0.4, flip = 1;  // flip: −1 for the layer at −z (its points turned)
    bool sheet = true, disc = true;
    void sample(const Vec2* p, double* out, std::size_t n) override {
      const double k = 2 * std::numbers::pi / 2.5;
      for (std::size_t i = 0; i < n; ++i) {
        const double x = k * flip * p[i].x, y = k * flip * p[i].y, kz = k * z;
        double phi =
            std::sin(x) * std::cos(y) + std::sin(y) * std::cos(kz) + std::sin(kz) * std::cos(x);
        if (!sheet) phi *= flip;
        const double v = sheet ? phi * phi - 0.09 : phi;
        out[i] = disc ? std::max(v, std::hypot(p[i].x - 1.13, p[i].y + 0.87) - 4.3) : v;
      }
    }
    Vec2 period() const override { return {2.5, 2.5}; }
    bool periodic(Vec2 lo, Vec2 hi) override {
      for (const Vec2 c : {lo, hi, Vec2{lo.x, hi.y}, Vec2{hi.x, lo.y}})
        if (disc && !(std::hypot(c.x - 1.13, c.y + 0.87) < 4.3)) return false;
      return true;
    }
  };
  auto signed_area = [](const ContourSet& c) {
    double a = 0;
    for (const auto& l : c.lines.loops)
      for (std::size_t i = 0, j = l.size() - 1; i < l.size(); j = i++)
        a += l[j].x * l[i].y - l[i].x * l[j].y;
    return a / 2;
  };
  MarchOptions mo;
  mo.resolution = 0.025;
  mo.tile_block = 20;                       // 0.5 mm tiles, five a period
  const Vec2 lo{-0.25, -0.25}, hi{6, 5.5};  // lo: −10 cells, so the turn moves nodes by 20
  for (const bool sheet : {true, false}) {
    SCOPED_TRACE(sheet ? "sheet" : "phi");
    Layer f;
    f.sheet = sheet;
    f.disc = false;
    PeriodTiles tiles;
    MarchOptions out = mo;
    out.tiles_out = &tiles;
    march_squares(f, lo, lo + Vec2{2.5, 2.5}, 0, out);
    ASSERT_TRUE(tiles.data);
    // Node k of the mirror layer's grid is node −2·lo/h − k = 20 − k of the first's.
    const PeriodTiles turned = point_reflected_tiles(tiles, mo.resolution, 20, 20, !sheet);
    ASSERT_TRUE(turned.data);
    EXPECT_NEAR(static_cast<double>(turned.bytes), static_cast<double>(tiles.bytes),
                0.1 * static_cast<double>(tiles.bytes));
    // Not onto tiles: a shift of 8 cells.
    EXPECT_FALSE(point_reflected_tiles(tiles, mo.resolution, 8, 20, false).data);
    Layer g = f;
    g.flip = -1;
    g.disc = true;
    MarchOptions own = mo, given = mo;
    given.tiles_in = &turned;
    const ContourSet a = march_squares(g, lo, hi, 0, own);
    const ContourSet b = march_squares(g, lo, hi, 0, given);
    EXPECT_GT(b.tiled_blocks, a.tiled_blocks);
    EXPECT_LT(b.samples, a.samples);
    expect_same_lines(a, b, 2 * mo.refine_fraction * mo.resolution + 1e-6, 1000);
    EXPECT_NEAR(signed_area(a), signed_area(b), 1e-4 * std::abs(signed_area(a)));
  }
}

// Crossings the function already knows (PlaneFunction::known_crossing) are taken without
// refinement where confirm_crossings confirms them, and refined as usual where it does not;
// MarchOptions::edge_crossings reports every crossing by its grid edge.
TEST(Contours, KnownCrossingsAreTakenOnlyWhereConfirmed) {
  const Vec2 lo{-2, -2};
  const double h = 0.1;
  struct Disc : PlaneFunction {
    Vec2 c{0.013, -0.021}, lo;
    double r = 1.234, h = 0;
    double at(Vec2 p) const { return std::hypot(p.x - c.x, p.y - c.y) - r; }
    void sample(const Vec2* p, double* out, std::size_t n) override {
      for (std::size_t i = 0; i < n; ++i) out[i] = at(p[i]);
    }
    // Offers the exact crossing on every other edge, a wrong one (the edge's middle) elsewhere.
    std::size_t offered = 0;
    double known_crossing(std::size_t i, std::size_t j, bool vertical, double fa,
                          double fb) override {
      EXPECT_LT(fa * fb, 0);
      ++offered;
      if (offered % 2 == 0) return 0.5;
      const auto node = [&](std::size_t ni, std::size_t nj) {
        return Vec2{lo.x + static_cast<double>(ni) * h, lo.y + static_cast<double>(nj) * h};
      };
      const Vec2 a = node(i, j), b = vertical ? node(i, j + 1) : node(i + 1, j);
      EXPECT_EQ(at(a), fa);
      EXPECT_EQ(at(b), fb);
      double t0 = 0, t1 = 1;  // bisection to the double's resolution
      for (int k = 0; k < 60; ++k) {
        const double m = 0.5 * (t0 + t1);
        ((at(a + (b - a) * m) < 0) == (fa < 0) ? t0 : t1) = m;
      }
      return 0.5 * (t0 + t1);
    }
    void confirm_crossings(const Vec2* p, std::size_t n, unsigned char* ok) override {
      for (std::size_t k = 0; k < n; ++k) ok[k] = std::abs(at(p[k])) < 1e-12;
    }
  };
  struct Plain : Disc {
    double known_crossing(std::size_t, std::size_t, bool, double, double) override { return -1; }
  };
  MarchOptions mo;
  mo.resolution = h;
  mo.refine_fraction = 1e-4;  // 0.01 µm
  std::vector<EdgeCrossing> edges;
  mo.edge_crossings = &edges;
  Plain plain;
  const ContourSet a = march_squares(plain, lo, {2, 2}, 0, mo);
  // The reported edges and parameters give back the contour's points.
  ASSERT_EQ(a.lines.loops.size(), 1u);
  const std::vector<Vec2>& loop = a.lines.loops[0];
  ASSERT_EQ(edges.size(), loop.size());
  for (const EdgeCrossing& e : edges) {
    EXPECT_GT(e.t, 0);
    EXPECT_LT(e.t, 1);
    const Vec2 p{lo.x + (static_cast<double>(e.i) + (e.vertical ? 0 : e.t)) * h,
                 lo.y + (static_cast<double>(e.j) + (e.vertical ? e.t : 0)) * h};
    double nearest = 1e9;
    for (const Vec2& q : loop) nearest = std::min(nearest, std::hypot(q.x - p.x, q.y - p.y));
    EXPECT_LT(nearest, 1e-12) << e.i << "," << e.j << (e.vertical ? " vertical" : " horizontal");
  }
  mo.edge_crossings = nullptr;
  Disc known;
  known.lo = lo;
  known.h = h;
  const ContourSet b = march_squares(known, lo, {2, 2}, 0, mo);
  ASSERT_EQ(b.lines.loops.size(), 1u);
  ASSERT_EQ(b.lines.loops[0].size(), loop.size());
  ASSERT_GT(known.offered, 50u);
  std::size_t exact = 0;
  for (const Vec2& p : b.lines.loops[0]) {
    // Every point on the circle to the tolerance: the wrong middles were refined.
    EXPECT_LT(std::abs(known.at(p)), 2 * mo.refine_fraction * h) << p.x << "," << p.y;
    exact += std::abs(known.at(p)) < 1e-12;
  }
  EXPECT_GE(exact, known.offered / 2);
  // The confirmed half cost one confirmation each instead of their refinement.
  EXPECT_LT(b.samples + known.offered / 4, a.samples)
      << "samples: plain " << a.samples << ", with known crossings " << b.samples;
}

// A material iso-line that leaves the domain comes back as an open polyline.
TEST(Contours, OpenIsoLinesOfAMaterialField) {
  struct Ramp : PlaneFunction {
    void sample(const Vec2* p, double* out, std::size_t n) override {
      for (std::size_t i = 0; i < n; ++i) out[i] = 0.3 * p[i].x + 0.1 * p[i].y;
    }
  } ramp;
  const ContourSet c = march_squares(ramp, {-10, -10}, {10, 10}, 0.5);
  ASSERT_EQ(c.lines.open.size(), 1u);
  EXPECT_TRUE(c.lines.loops.empty());
  for (auto p : c.lines.open[0]) EXPECT_NEAR(0.3 * p.x + 0.1 * p.y, 0.5, 1e-9);
}

TEST(Contours, BoundsSkipMostOfALargePlate) {
  const auto d = read_vcad(kDesigns + "fgm_column2_plate.vcad");
  Evaluator ev(d.field);
  SliceStats st;
  const Regions r = contour_at(d.field, ev, 0.0, {}, &st);
  // Marching squares cuts each sharp corner by half a cell: 4 × h²/2.
  EXPECT_NEAR(area(r), 150.0 * 75.0, 4 * 0.5 * 0.01 + 1e-6);
  // 1500 x 750 cells; marching only the rim samples far fewer nodes.
  EXPECT_LT(st.samples, 1500u * 750u / 10u);
}

TEST(MeshIo, ReadsStlObj3mfAndChecksClosure) {
  const trellis::test::TempDir dir("trellis_mesh_io");
  const auto& tmp = dir.path();
  TriangleMesh cube;
  cube.add_prism({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, 0, 10);
  write_stl((tmp / "c.stl").string(), cube);
  const TriangleMesh a = read_mesh((tmp / "c.stl").string());
  EXPECT_EQ(a.triangles.size(), 12u);
  EXPECT_EQ(a.vertices.size(), 8u);
  EXPECT_TRUE(check_mesh(a).closed());
  EXPECT_NEAR(volume(a), 1000, 1e-6);
  write_3mf((tmp / "c.3mf").string(), a);
  const TriangleMesh b = read_mesh((tmp / "c.3mf").string());
  EXPECT_EQ(b.triangles.size(), 12u);
  EXPECT_NEAR(volume(b), 1000, 1e-6);
  const TriangleMesh o = parse_obj(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n", "t.obj");
  EXPECT_TRUE(check_mesh(o).closed());
  EXPECT_NEAR(volume(o), 1.0 / 6, 1e-12);
  const TriangleMesh ascii = parse_stl(
      "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
      "endloop\nendfacet\nendsolid t\n",
      "t.stl");
  EXPECT_EQ(ascii.triangles.size(), 1u);
  // An open mesh is reported, naming the mesh and an edge.
  const MeshCheck c = check_mesh(ascii);
  EXPECT_EQ(c.open_edges, 3u);
  try {
    require_closed(ascii, "t.stl");
    ADD_FAILURE();
  } catch (const GeometryError& e) {
    EXPECT_NE(std::string(e.what()).find("t.stl"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("3 open edges"), std::string::npos);
  }
  EXPECT_THROW(parse_stl("solid x\nfacet\nvertex 1 2\n", "bad.stl"), ParseError);
  EXPECT_THROW(parse_stl("garbage", "bad.stl"), ParseError);
  EXPECT_THROW(parse_obj("v 0 0 0\nf 1 2 3\n", "bad.obj"), ParseError);
  EXPECT_THROW(read_mesh((tmp / "c.xyz").string()), ParseError);
  std::filesystem::remove_all(tmp);
}

TEST(MeshIo, MeshSliceMatchesBox) {
  TriangleMesh m;
  m.add_prism({{0, 0}, {20, 0}, {20, 10}, {0, 10}}, 0, 5);
  m.add_prism({{30, 0}, {40, 0}, {40, 10}, {30, 10}}, 0, 5);
  const Regions r = slice_mesh(weld(m), 2.5);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_NEAR(area(r), 300, 1e-6);
  for (const auto& p : r) EXPECT_GT(signed_area(p.outer), 0);
}

// The vase of the FGM paper's Listing 5 sliced through its distance field (the default for a
// .vcad) and through the STL directly: the same outlines within the voxel size.
TEST(Routes, FieldAndMeshRoutesAgreeOnTheVase) {
  const auto d = read_vcad(kDesigns + "fgm_column6_vase.vcad");
  const TriangleMesh mesh = weld(read_mesh(kDesigns + "Vase.stl"));
  Evaluator ev(d.field);
  FieldSliceOptions opt;
  opt.resolution = 0.1;
  const double voxel = 0.25;  // the default of mesh() leaves
  for (double z : {-45.0, -20.0, 0.0, 25.0, 45.0}) {
    const Regions a = contour_at(d.field, ev, z, opt);
    const Regions b = slice_mesh(mesh, z);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_NEAR(area(a), area(b), 0.01 * area(b)) << z;
    double worst = 0;
    for (const auto& ring : rings_of(a))
      for (std::size_t i = 0; i < ring.size(); i += 7)
        worst = std::max(worst, test::outline_distance(ring[i], b));
    for (const auto& ring : rings_of(b))
      for (auto p : ring) worst = std::max(worst, test::outline_distance(p, a));
    EXPECT_LT(worst, voxel) << "z=" << z;
  }
}

// ---------------------------------------------------------------- planar slicer properties

struct Raster {
  double x0, y0, px;
  int nx, ny;
  std::vector<int> count;
  Raster(const BBox3& b, double pixel) : x0(b.min.x - 1), y0(b.min.y - 1), px(pixel) {
    nx = static_cast<int>((b.max.x - b.min.x + 2) / px) + 1;
    ny = static_cast<int>((b.max.y - b.min.y + 2) / px) + 1;
    count.assign(static_cast<std::size_t>(nx) * ny, 0);
  }
  Vec2 center(int i, int j) const { return {x0 + (i + 0.5) * px, y0 + (j + 0.5) * px}; }
  // Marks pixels whose centre lies within w/2 of the polyline (one mark per path).
  void stamp(const Path& p, double w) {
    std::vector<char> hit(count.size(), 0);
    for (std::size_t k = 1; k < p.points.size(); ++k) {
      const Vec2 a = p.points[k - 1].xy(), b = p.points[k].xy();
      const int i0 = std::max(0, static_cast<int>((std::min(a.x, b.x) - w - x0) / px));
      const int i1 = std::min(nx - 1, static_cast<int>((std::max(a.x, b.x) + w - x0) / px));
      const int j0 = std::max(0, static_cast<int>((std::min(a.y, b.y) - w - y0) / px));
      const int j1 = std::min(ny - 1, static_cast<int>((std::max(a.y, b.y) + w - y0) / px));
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i)
          if (test::segment_distance(center(i, j), a, b) <= w / 2)
            hit[static_cast<std::size_t>(j) * nx + i] = 1;
    }
    for (std::size_t q = 0; q < hit.size(); ++q) count[q] += hit[q];
  }
};

bool inside(const Regions& r, Vec2 p) {
  for (const auto& poly : r)
    if (contains(poly, p, 0)) return true;
  return false;
}

// A 30 × 20 × 3 mm plate with a 10 mm hole in 0.3 mm layers, and the options its planar tests
// share (3 walls of 0.4 mm, 2 top and 2 bottom layers).
struct HolePlate {
  std::vector<double> zs = layer_planes(-1.5, 1.5, 0.3);
  std::vector<LayerOutline> outlines =
      slice_field(subtract({rectprism({30, 20, 3}), cylinder(5, 10)}), zs, {});
  PlanarOptions o = [] {
    PlanarOptions p;
    p.layer_height = 0.3;
    p.bead_width = 0.4;
    p.walls = 3;
    p.top_layers = 2;
    p.bottom_layers = 2;
    return p;
  }();
};

TEST(Planar, WallsInsideNotOverlappingInfillAtDensity) {
  HolePlate plate;
  const auto& zs = plate.zs;
  const auto& outlines = plate.outlines;
  PlanarOptions& o = plate.o;
  o.infill_density = 0.25;
  PlanarStats st;
  const Toolpath tp = plan_planar(outlines, o, &st);
  ASSERT_EQ(tp.layers.size(), zs.size());
  const std::size_t mid = zs.size() / 2;  // a sparse-infill layer
  const Regions& outline = outlines[mid].regions;
  const BBox3 box = [&] {
    BBox3 b;
    for (const auto& ring : rings_of(outline))
      for (auto p : ring) b.add({p.x, p.y, 0});
    return b;
  }();
  Raster walls(box, 0.05), fill(box, 0.05);
  for (const auto& p : tp.layers[mid].paths) {
    for (const auto& q : p.points) {
      ASSERT_TRUE(inside(outline, q.xy()));
      if (p.role == PathRole::Perimeter) {
        // Walls stay at least half a bead inside the outline.
        EXPECT_GE(test::outline_distance(q.xy(), outline), 0.5 * o.bead_width - 1e-3);
      }
    }
    (p.role == PathRole::Perimeter ? walls : fill).stamp(p, o.bead_width);
  }
  // Walls do not overlap: no pixel is covered by two wall loops (allow the pixel rounding at
  // the seams of a bead's edge).
  std::size_t doubled = 0, wall_px = 0;
  for (int c : walls.count) {
    doubled += c > 1;
    wall_px += c > 0;
  }
  EXPECT_LT(static_cast<double>(doubled), 0.01 * wall_px);
  // Infill covers the inner region at the set density (±20%).
  const Regions inner = offset(outline, -(3 * o.bead_width));
  std::size_t in_px = 0, covered = 0;
  for (int j = 0; j < fill.ny; ++j)
    for (int i = 0; i < fill.nx; ++i) {
      const Vec2 c = fill.center(i, j);
      if (!inside(inner, c)) continue;
      ++in_px;
      covered += fill.count[static_cast<std::size_t>(j) * fill.nx + i] > 0;
    }
  const double coverage = static_cast<double>(covered) / in_px;
  EXPECT_NEAR(coverage, o.infill_density, 0.2 * o.infill_density);
  // Bottom layer is solid: covered ≥ 95% inside the walls.
  Raster solid(box, 0.05);
  for (const auto& p : tp.layers[0].paths) solid.stamp(p, o.bead_width);
  const Regions inner0 = offset(outlines[0].regions, -(3 * o.bead_width));
  std::size_t n0 = 0, c0 = 0;
  for (int j = 0; j < solid.ny; ++j)
    for (int i = 0; i < solid.nx; ++i) {
      if (!inside(inner0, solid.center(i, j))) continue;
      ++n0;
      c0 += solid.count[static_cast<std::size_t>(j) * solid.nx + i] > 0;
    }
  EXPECT_GT(static_cast<double>(c0) / n0, 0.95);
  // Infill angle alternates.
  auto first_angle = [&](std::size_t layer, PathRole role) {
    for (const auto& p : tp.layers[layer].paths)
      if (p.role == role) {  // its first line (a linked path zig-zags along its lines)
        const Vec3 d = p.points[1] - p.points[0];
        return std::fmod(std::atan2(d.y, d.x) * 180 / kPi + 360, 180.0);
      }
    return -1.0;
  };
  const double a0 = first_angle(mid, PathRole::Infill), a1 = first_angle(mid + 1, PathRole::Infill);
  ASSERT_GE(a0, 0);
  ASSERT_GE(a1, 0);
  EXPECT_NEAR(std::abs(a0 - a1), 90, 1e-6);
}

// Every wall runs at (k + 0.5) beads from the outline, and the fill (skin and sparse) reaches
// exactly `infill_overlap` of a bead into the innermost wall, never farther.
TEST(Planar, InsetsStepABeadFromTheOutlineInward) {
  const HolePlate plate;
  const auto& zs = plate.zs;
  const auto& outlines = plate.outlines;
  const PlanarOptions& o = plate.o;
  const Toolpath tp = plan_planar(outlines, o);
  const double tol = o.simplify + 1e-3;  // the outline is simplified before it is offset
  for (const std::size_t layer : {std::size_t{0}, zs.size() / 2}) {  // a skin and a sparse layer
    const Regions& outline = outlines[layer].regions;
    std::vector<std::size_t> on_level(static_cast<std::size_t>(o.walls), 0);
    std::size_t wall_edges = 0;
    double fill_min = 1e300;
    for (const auto& p : tp.layers[layer].paths) {
      if (p.role != PathRole::Perimeter) {
        for (const auto& q : p.points)
          fill_min = std::min(fill_min, test::outline_distance(q.xy(), outline));
        continue;
      }
      for (std::size_t k = 1; k < p.points.size(); ++k) {
        // Edge middles: at a wall's own inset (the mitred corners aside, which lie farther).
        const double d =
            test::outline_distance(((p.points[k - 1] + p.points[k]) * 0.5).xy(), outline);
        EXPECT_GE(d, 0.5 * o.bead_width - tol);
        ++wall_edges;
        for (int w = 0; w < o.walls; ++w)
          if (std::abs(d - (w + 0.5) * o.bead_width) < tol) ++on_level[static_cast<std::size_t>(w)];
      }
    }
    std::size_t on_some = 0;
    for (const std::size_t n : on_level) {
      EXPECT_GT(n, 0u) << "layer " << layer << ": a wall level has no edge at its inset";
      on_some += n;
    }
    EXPECT_GT(static_cast<double>(on_some), 0.95 * static_cast<double>(wall_edges))
        << "layer " << layer;
    const double reach = (o.walls + 0.5 - o.infill_overlap) * o.bead_width;
    EXPECT_NEAR(fill_min, reach, tol) << "layer " << layer;
  }
}

TEST(Pipeline, SlicesEveryAppendixBDesign) {
  for (const char* name : {"fgm_column1_cylinder.vcad", "fgm_column2_plate.vcad",
                           "fgm_column3_ring_angular.vcad", "fgm_column5_ring_radial.vcad"}) {
    SliceJob job;
    job.input = kDesigns + name;
    job.planar.layer_height = 1.0;  // coarse: this checks the route, not the detail
    job.field.resolution = 0.25;
    // Graded designs: one material only when asked for (--strategy none), never silently.
    EXPECT_THROW(run_slice(job), SettingError) << name;
    job.strategy_chosen = true;
    const SliceResult r = run_slice(job);
    EXPECT_EQ(r.route, SliceRoute::Field);
    EXPECT_GT(r.planar.paths, 0u) << name;
    for (const auto& l : r.outlines) EXPECT_FALSE(l.regions.empty()) << name << " z=" << l.z;
  }
  // The mesh route of a design: marching cubes, then plane cuts; the same outlines within
  // the voxel.
  SliceJob field_job, mesh_job;
  field_job.input = mesh_job.input = kDesigns + "fgm_column5_ring_radial.vcad";
  field_job.planar.layer_height = mesh_job.planar.layer_height = 2.0;
  mesh_job.route = SliceRoute::Mesh;
  field_job.strategy_chosen = mesh_job.strategy_chosen = true;
  mesh_job.mesh_voxel = 0.25;
  const SliceResult a = run_slice(field_job), b = run_slice(mesh_job);
  EXPECT_EQ(b.route, SliceRoute::Mesh);
  ASSERT_EQ(a.outlines.size(), b.outlines.size());
  for (std::size_t i = 0; i < a.outlines.size(); ++i)
    EXPECT_NEAR(area(a.outlines[i].regions), area(b.outlines[i].regions),
                0.005 * area(a.outlines[i].regions));
  SliceJob unbounded;
  const trellis::test::TempDir dir("trellis_unbounded");
  const auto tmp = dir / "unbounded.vcad";
  { std::ofstream(tmp) << "gyroid(5, 0.3);\n"; }
  unbounded.input = tmp.string();
  EXPECT_THROW(run_slice(unbounded), GeometryError);
}

}  // namespace
