// Multi-laser PBF (slice/pbf_lasers.hpp) over random layers and 1–4 lasers: every vector on one
// laser whose field holds it, the pieces together the layer's own vectors, the lasers' times
// balanced unless a field forbids it, vectors within the overlap never cut; one laser leaves the
// layer as it was. The .cli and 3MF round trips of the laser ids are in tests/machine.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/slice/pbf_lasers.hpp"

using namespace trellis;

namespace {

// A layer of contour polylines (2–6 points) and hatch vectors in [0, 100] × [0, 50] mm, at most
// `reach` mm long along X, in random order.
Layer random_layer(unsigned seed, int count, double reach) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0, 100), y(0, 50), d(-1, 1);
  std::uniform_int_distribution<int> pts(2, 6), coin(0, 9);
  Layer l;
  l.z = 0.02;
  for (int k = 0; k < count; ++k) {
    Path p;
    p.role = coin(rng) < 3 ? PathRole::Contour : PathRole::Hatch;
    p.speed = p.role == PathRole::Hatch ? 1000 : 800;
    p.power = 100;
    const int m = p.role == PathRole::Hatch ? 2 : pts(rng);
    Vec3 q{x(rng), y(rng), l.z};
    for (int j = 0; j < m; ++j) {
      p.points.push_back(q);
      q.x = std::clamp(q.x + d(rng) * reach / (m - 1) / 2, 0.0, 100.0);
      q.y = std::clamp(q.y + d(rng) * 2, 0.0, 50.0);
    }
    l.paths.push_back(std::move(p));
  }
  return l;
}

double length(const std::vector<Vec3>& pts) {
  double s = 0;
  for (std::size_t k = 1; k < pts.size(); ++k) s += distance(pts[k - 1], pts[k]);
  return s;
}

bool inside(const BBox2& f, const Vec3& q) {
  return q.x >= f.min.x - 1e-9 && q.x <= f.max.x + 1e-9 && q.y >= f.min.y - 1e-9 &&
         q.y <= f.max.y + 1e-9;
}

// Overlapping stripe fields: laser l reaches its nth of X and `margin` mm beyond.
LaserSetup striped(int lasers, double margin, double overlap) {
  std::vector<double> f;
  for (int l = 0; l < lasers; ++l) {
    const double w = 100.0 / lasers;
    f.insert(f.end(),
             {std::max(0.0, l * w - margin), 0.0, std::min(100.0, (l + 1) * w + margin), 50.0});
  }
  return laser_setup(lasers, f, overlap, ScanTiming{});
}

// Every path on one laser whose field holds all its points; the pieces of each original path,
// in order, join into it (same ends, same length, its corners in order).
void expect_partition(const Layer& before, const Layer& after, const LaserSplit& s,
                      const LaserSetup& setup, const std::string& what) {
  ASSERT_EQ(after.paths.size(), s.source.size()) << what;
  ASSERT_EQ(s.seconds.size(), setup.fields.size()) << what;
  ASSERT_TRUE(std::is_sorted(s.source.begin(), s.source.end())) << what;
  for (const Path& p : after.paths) {
    ASSERT_GE(p.tool, 0) << what;
    ASSERT_LT(p.tool, static_cast<int>(setup.fields.size())) << what;
    for (const Vec3& q : p.points)
      EXPECT_TRUE(inside(setup.fields[static_cast<std::size_t>(p.tool)], q))
          << what << ": (" << q.x << ", " << q.y << ") outside laser " << p.tool << "'s field";
  }
  std::size_t k = 0;
  for (std::size_t i = 0; i < before.paths.size(); ++i) {
    const Path& o = before.paths[i];
    std::vector<Vec3> joined;
    for (; k < s.source.size() && s.source[k] == i; ++k) {
      const Path& p = after.paths[k];
      EXPECT_EQ(p.role, o.role) << what;
      EXPECT_EQ(p.speed, o.speed) << what;
      EXPECT_EQ(p.power, o.power) << what;
      if (!joined.empty()) {
        EXPECT_NEAR(distance(joined.back(), p.points.front()), 0, 1e-12) << what;
      }
      joined.insert(joined.end(), p.points.begin() + (joined.empty() ? 0 : 1), p.points.end());
    }
    ASSERT_FALSE(joined.empty()) << what << ": path " << i << " lost";
    EXPECT_NEAR(length(joined), length(o.points), 1e-9) << what << ": path " << i;
    EXPECT_NEAR(distance(joined.front(), o.points.front()), 0, 1e-12) << what;
    EXPECT_NEAR(distance(joined.back(), o.points.back()), 0, 1e-12) << what;
    std::size_t at = 0;  // the original's corners appear in order
    for (const Vec3& q : o.points) {
      while (at < joined.size() && distance(joined[at], q) > 1e-12) ++at;
      EXPECT_LT(at, joined.size()) << what << ": path " << i << " lost a corner";
    }
  }
  EXPECT_EQ(k, s.source.size()) << what;
}

// The laser times the split reports are scan_time over each laser's paths in layer order.
void expect_times(const Layer& after, const LaserSplit& s, const LaserSetup& setup) {
  for (std::size_t l = 0; l < setup.fields.size(); ++l) {
    std::vector<const Path*> mine;
    for (const Path& p : after.paths)
      if (p.tool == static_cast<int>(l)) mine.push_back(&p);
    EXPECT_NEAR(s.seconds[l], scan_time(mine, setup.timing), 1e-12);
  }
}

}  // namespace

TEST(PbfLasers, EveryVectorOnOneLaserInItsFieldAndThePiecesAreTheLayer) {
  for (unsigned seed = 1; seed <= 12; ++seed)
    for (int lasers = 1; lasers <= 4; ++lasers)
      for (const bool fields : {false, true}) {
        const Layer before = random_layer(seed, 150, seed % 3 == 0 ? 60 : 8);
        const LaserSetup setup =
            fields ? striped(lasers, 10, 2) : laser_setup(lasers, {}, 2, ScanTiming{});
        Layer after = before;
        const LaserSplit s = split_among_lasers(after, setup, seed);
        const std::string what = "seed " + std::to_string(seed) + ", " + std::to_string(lasers) +
                                 " laser(s)" + (fields ? " with fields" : "");
        expect_partition(before, after, s, setup, what);
        expect_times(after, s, setup);
        EXPECT_EQ(s.boundaries.size(), static_cast<std::size_t>(lasers - 1)) << what;
        EXPECT_TRUE(std::is_sorted(s.boundaries.begin(), s.boundaries.end())) << what;
      }
}

TEST(PbfLasers, OneLaserLeavesTheLayerAsItWas) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Layer before = random_layer(seed, 80, 30);
    Layer after = before;
    const LaserSetup setup = laser_setup(1, {}, 2, ScanTiming{});
    const LaserSplit s = split_among_lasers(after, setup, 0);
    ASSERT_EQ(after.paths.size(), before.paths.size());
    for (std::size_t i = 0; i < before.paths.size(); ++i) {
      EXPECT_EQ(after.paths[i].tool, 0);
      EXPECT_EQ(after.paths[i].points.size(), before.paths[i].points.size());
      for (std::size_t k = 0; k < before.paths[i].points.size(); ++k)
        EXPECT_EQ(distance(after.paths[i].points[k], before.paths[i].points[k]), 0);
    }
    std::vector<const Path*> all;
    for (const Path& p : before.paths) all.push_back(&p);
    EXPECT_DOUBLE_EQ(s.seconds.at(0), scan_time(all, setup.timing));
    EXPECT_DOUBLE_EQ(s.build_seconds(), s.seconds[0]);
  }
}

// Reachable everywhere: the slowest laser within 15 % of the fastest over layers of many short
// vectors (one vector and its jump are well under that share of a laser's time).
TEST(PbfLasers, LasersThatReachEverywhereAreBalanced) {
  for (unsigned seed = 1; seed <= 10; ++seed)
    for (int lasers = 2; lasers <= 4; ++lasers) {
      Layer layer = random_layer(seed, 400, 3);
      const LaserSplit s = split_among_lasers(layer, laser_setup(lasers, {}, 1, ScanTiming{}), 0);
      const double hi = *std::max_element(s.seconds.begin(), s.seconds.end());
      const double lo = *std::min_element(s.seconds.begin(), s.seconds.end());
      EXPECT_GT(lo, 0);
      EXPECT_LE(hi / lo, 1.15) << "seed " << seed << ", " << lasers << " lasers";
      // And the build is faster than one laser's: at least (lasers - 0.5)× as fast.
      const Layer whole = random_layer(seed, 400, 3);
      std::vector<const Path*> all;
      for (const Path& p : whole.paths) all.push_back(&p);
      const double one = scan_time(all, ScanTiming{});
      EXPECT_LT(s.build_seconds(), one / (lasers - 0.5)) << "seed " << seed;
    }
}

// A field that forbids the balance: laser 0 reaches only x <= 30 of work spread evenly over
// 0..100. Laser 0 takes all it can (its stripe ends at its field's edge), nothing outside.
TEST(PbfLasers, AFieldLimitsTheBalance) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Layer layer = random_layer(seed, 300, 2);
    const LaserSetup setup = laser_setup(2, {0, 0, 30, 50, 20, 0, 100, 50}, 1, ScanTiming{});
    Layer after = layer;
    const LaserSplit s = split_among_lasers(after, setup, 0);
    expect_partition(layer, after, s, setup, "seed " + std::to_string(seed));
    EXPECT_LT(s.seconds[0], s.seconds[1]);
    EXPECT_NEAR(s.boundaries.at(0), 30, 1e-9);
  }
}

TEST(PbfLasers, VectorsWithinTheOverlapAreNeverCutLongerOnesAre) {
  for (unsigned seed = 1; seed <= 6; ++seed)
    for (int lasers = 2; lasers <= 4; ++lasers) {
      Layer shorter = random_layer(seed, 200, 1.0);  // at most 1 mm along X
      const std::size_t n = shorter.paths.size();
      const LaserSplit s = split_among_lasers(shorter, laser_setup(lasers, {}, 2, ScanTiming{}), 0);
      EXPECT_EQ(s.cut, 0u);
      EXPECT_EQ(shorter.paths.size(), n);
      // No overlap and vectors across the plate: some are cut, every piece inside its stripe.
      Layer longer = random_layer(seed, 60, 100);
      const LaserSplit t = split_among_lasers(longer, laser_setup(lasers, {}, 0, ScanTiming{}), 0);
      EXPECT_GT(t.cut, 0u);
      for (const Path& p : longer.paths)
        for (const Vec3& q : p.points) {
          const std::size_t l = static_cast<std::size_t>(p.tool);
          if (l > 0) {
            EXPECT_GE(q.x, t.boundaries[l - 1] - 1e-9);
          }
          if (l + 1 < static_cast<std::size_t>(lasers)) {
            EXPECT_LE(q.x, t.boundaries[l] + 1e-9);
          }
        }
    }
}

TEST(PbfLasers, AVectorNoLaserReachesIsRefused) {
  Layer layer = random_layer(3, 50, 5);
  const LaserSetup setup = laser_setup(2, {0, 0, 40, 50, 60, 0, 100, 50}, 1, ScanTiming{});
  try {
    split_among_lasers(layer, setup, 7);
    FAIL() << "a vector in the gap between the fields was accepted";
  } catch (const GeometryError& e) {
    EXPECT_NE(std::string(e.what()).find("layer 7"), std::string::npos) << e.what();
    EXPECT_EQ(e.where().element, "laser.fields");
  }
  EXPECT_THROW(laser_setup(2, {0, 0, 40, 50}, 1, ScanTiming{}), SettingError);
  EXPECT_THROW(laser_setup(1, {10, 0, 5, 50}, 1, ScanTiming{}), SettingError);
}

TEST(PbfLasers, SameLayerSameSplit) {
  const Layer layer = random_layer(9, 300, 20);
  Layer a = layer, b = layer;
  const LaserSetup setup = striped(3, 10, 2);
  const LaserSplit sa = split_among_lasers(a, setup, 0), sb = split_among_lasers(b, setup, 0);
  EXPECT_EQ(sa.boundaries, sb.boundaries);
  EXPECT_EQ(sa.source, sb.source);
  ASSERT_EQ(a.paths.size(), b.paths.size());
  for (std::size_t i = 0; i < a.paths.size(); ++i) EXPECT_EQ(a.paths[i].tool, b.paths[i].tool);
}

TEST(PbfLasers, TimesOfAToolpathReadBack) {
  Toolpath tp;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    tp.layers.push_back(random_layer(seed, 100, 10));
    split_among_lasers(tp.layers.back(), laser_setup(3, {}, 1, ScanTiming{}), 0);
  }
  const LaserTimes t = laser_times(tp, ScanTiming{});
  ASSERT_EQ(t.per_layer.size(), 3u);
  const std::vector<double> totals = t.totals();
  ASSERT_EQ(totals.size(), 3u);
  double build = 0;
  for (const auto& l : t.per_layer) build += *std::max_element(l.begin(), l.end());
  EXPECT_DOUBLE_EQ(t.build_seconds(), build);
  EXPECT_LE(t.build_seconds(), totals[0] + totals[1] + totals[2]);
}

namespace {

Layer transposed(Layer l) {
  for (Path& p : l.paths)
    for (Vec3& q : p.points) std::swap(q.x, q.y);
  return l;
}

LaserSetup transposed(LaserSetup s) {
  for (BBox2& f : s.fields) std::swap(f.min.x, f.min.y), std::swap(f.max.x, f.max.y);
  return s;
}

}  // namespace

// Stripes along Y are stripes along X of the layer turned about the diagonal: the same lasers,
// boundaries and times, the points the turned ones; each laser's vectors lie in its Y stripe
// (within half the overlap), in its field, and the pieces are the layer.
TEST(PbfLasers, StripesAlongYAreTheTransposedSplitAlongX) {
  for (unsigned seed = 1; seed <= 6; ++seed)
    for (int lasers : {2, 3}) {
      const std::string what = "seed " + std::to_string(seed) + ", " + std::to_string(lasers);
      const Layer layer = transposed(random_layer(seed, 150, 15));  // [0, 50] × [0, 100]
      LaserSetup setup = transposed(striped(lasers, 10, 2));
      setup.axis = LaserAxis::Y;
      Layer along_y = layer, along_x = transposed(layer);
      LaserSetup x_setup = transposed(setup);
      x_setup.axis = LaserAxis::X;
      const LaserSplit sy = split_among_lasers(along_y, setup, seed);
      const LaserSplit sx = split_among_lasers(along_x, x_setup, seed);
      EXPECT_EQ(sy.axis, LaserAxis::Y) << what;
      EXPECT_EQ(sx.axis, LaserAxis::X) << what;
      EXPECT_EQ(sy.boundaries, sx.boundaries) << what;
      EXPECT_EQ(sy.seconds, sx.seconds) << what;
      EXPECT_EQ(sy.source, sx.source) << what;
      const Layer back = transposed(along_x);
      ASSERT_EQ(along_y.paths.size(), back.paths.size()) << what;
      for (std::size_t i = 0; i < back.paths.size(); ++i) {
        EXPECT_EQ(along_y.paths[i].tool, back.paths[i].tool) << what;
        EXPECT_EQ(along_y.paths[i].points, back.paths[i].points) << what;
      }
      expect_partition(layer, along_y, sy, setup, what);
      expect_times(along_y, sy, setup);
      for (const Path& p : along_y.paths)
        for (const Vec3& q : p.points) {
          const auto l = static_cast<std::size_t>(p.tool);
          if (l > 0) {
            EXPECT_GE(q.y, sy.boundaries[l - 1] - 1 - 1e-9) << what;
          }
          if (l + 1 < setup.fields.size()) {
            EXPECT_LE(q.y, sy.boundaries[l] + 1 + 1e-9) << what;
          }
        }
    }
}

// auto keeps, per layer, whichever axis builds the layer sooner (X on a tie): the kept split is
// the faster of the two, and a partition of the layer.
TEST(PbfLasers, AutoKeepsTheAxisThatBuildsSooner) {
  for (unsigned seed = 1; seed <= 6; ++seed)
    for (bool long_in_y : {false, true}) {
      const std::string what = "seed " + std::to_string(seed) + (long_in_y ? ", long in Y" : "");
      // Long vectors across a narrow part: cut by stripes across them, whole in stripes along.
      Layer layer = random_layer(seed, 120, 40);
      if (long_in_y) layer = transposed(layer);
      double best = 1e300;
      for (LaserAxis axis : {LaserAxis::X, LaserAxis::Y}) {
        Layer l = layer;
        LaserSetup s = laser_setup(2, {}, 0, ScanTiming{});
        s.axis = axis;
        best = std::min(best, split_among_lasers(l, s, 0).build_seconds());
      }
      Layer l = layer;
      LaserSetup s = laser_setup(2, {}, 0, ScanTiming{});
      s.axis = LaserAxis::Auto;
      const LaserSplit a = split_among_lasers(l, s, 0);
      EXPECT_DOUBLE_EQ(a.build_seconds(), best) << what;
      expect_partition(layer, l, a, s, what);
    }
  // Fields one behind the other in Y: a vector across both (x = 50, y 20..30) cannot be cut
  // along X into pieces each field holds, so auto splits along Y.
  Layer layer = random_layer(4, 80, 5);
  Path across;
  across.role = PathRole::Hatch;
  across.points = {{50, 20, 0.02}, {50, 30, 0.02}};
  layer.paths.push_back(across);
  LaserSetup s = laser_setup(2, {0, 0, 100, 26, 0, 24, 100, 50}, 1, ScanTiming{});
  Layer x = layer;
  EXPECT_THROW(split_among_lasers(x, s, 0), GeometryError);
  s.axis = LaserAxis::Auto;
  Layer l = layer;
  const LaserSplit a = split_among_lasers(l, s, 0);
  EXPECT_EQ(a.axis, LaserAxis::Y);
  expect_partition(layer, l, a, s, "fields in Y");
}

// A vector no laser reaches is named in the layer's own coordinates when splitting along Y.
TEST(PbfLasers, RefusalsAlongYNameTheVectorAsItIs) {
  Layer layer;
  Path p;
  p.role = PathRole::Hatch;
  p.points = {{80, 10, 0}, {85, 10, 0}};
  layer.paths.push_back(p);
  LaserSetup s = laser_setup(2, {0, 0, 50, 50, 0, 40, 50, 90}, 1, ScanTiming{});
  s.axis = LaserAxis::Y;
  try {
    split_among_lasers(layer, s, 3);
    FAIL() << "a vector outside every field was accepted";
  } catch (const GeometryError& e) {
    EXPECT_NE(std::string(e.what()).find("from (80.000, 10.000) to (85.000, 10.000)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(layer.paths[0].points[0].x, 80);  // the layer is left as it was
}

namespace {

// The profile's own laser as the test layers' paths are exposed (contour 100 W at 800 mm/s,
// hatch 100 W at 1000 mm/s), and one laser that differs from it.
LaserParameters profile_of_random_layer() {
  LaserParameters p;
  p.contour_power = p.hatch_power = 100;
  p.contour_speed = p.timing.contour_speed = 800;
  p.hatch_speed = p.timing.hatch_speed = 1000;
  return p;
}

// A hatched layer as pbf scans it: contour rings around [0, 100] × [0, 50] mm, then 200 hatch
// lines across Y in X order, alternating direction (short jumps: marking dominates).
Layer hatch_layer(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> end(0, 4);
  Layer l;
  l.z = 0.02;
  for (int k = 0; k < 200; ++k) {
    Path p;
    p.role = k % 50 == 0 ? PathRole::Contour : PathRole::Hatch;
    p.speed = p.role == PathRole::Hatch ? 1000 : 800;
    p.power = 100;
    const double x = 0.25 + 0.5 * k, a = end(rng), b = 50 - end(rng);
    p.points = {{x, k % 2 ? b : a, l.z}, {x, k % 2 ? a : b, l.z}};
    l.paths.push_back(std::move(p));
  }
  return l;
}

LaserParameters faster(double factor, double power, double mark_delay) {
  LaserParameters l = profile_of_random_layer();
  l.contour_speed = l.timing.contour_speed = 800 * factor;
  l.hatch_speed = l.timing.hatch_speed = 1000 * factor;
  l.contour_power = 0.8 * power, l.hatch_power = power;
  l.timing.mark_delay = mark_delay;
  return l;
}

}  // namespace

// Lasers that differ (lasers.*): each vector is exposed with its laser's power and speed, each
// laser's time is reckoned with its own speeds and delays, the times are balanced, and so the
// faster laser scans more: its share of the vector length grows with its speed.
TEST(PbfLasers, UnequalLasersAreBalancedOnTheirOwnSpeedsAndDelays) {
  const LaserParameters profile = profile_of_random_layer();
  for (unsigned seed = 1; seed <= 6; ++seed)
    for (const auto& each :
         {std::vector<LaserParameters>{faster(2, 200, 100), faster(1, 100, 100)},
          std::vector<LaserParameters>{faster(1, 100, 60), faster(1, 120, 5000)},
          std::vector<LaserParameters>{faster(1, 100, 100), faster(1.5, 150, 100),
                                       faster(3, 300, 100)}}) {
      const std::string what = "seed " + std::to_string(seed) + ", " + std::to_string(each.size()) +
                               " lasers, laser 1 at " + std::to_string(each[0].hatch_speed) +
                               " mm/s";
      const Layer before = hatch_layer(seed);
      Layer layer = before;
      const LaserSetup setup = laser_setup({}, 1, profile, each);
      const LaserSplit s = split_among_lasers(layer, setup, 0);
      std::vector<double> share(each.size(), 0.0);
      for (const Path& p : layer.paths) {
        const LaserParameters& l = each.at(static_cast<std::size_t>(p.tool));
        const bool hatch = p.role == PathRole::Hatch;
        EXPECT_EQ(p.power, hatch ? l.hatch_power : l.contour_power) << what;
        EXPECT_EQ(p.speed, hatch ? l.hatch_speed : l.contour_speed) << what;
        share[static_cast<std::size_t>(p.tool)] += length(p.points);
      }
      for (std::size_t l = 0; l < each.size(); ++l) {
        std::vector<const Path*> mine;
        for (const Path& p : layer.paths)
          if (p.tool == static_cast<int>(l)) mine.push_back(&p);
        EXPECT_NEAR(s.seconds[l], scan_time(mine, each[l].timing), 1e-12) << what;
      }
      const double hi = *std::max_element(s.seconds.begin(), s.seconds.end());
      const double lo = *std::min_element(s.seconds.begin(), s.seconds.end());
      EXPECT_LE(hi / lo, 1.15) << what;
      // The faster laser (higher speed, or a shorter mark delay) scans more length.
      for (std::size_t l = 1; l < each.size(); ++l) {
        const bool quicker = each[l].hatch_speed > each[l - 1].hatch_speed ||
                             each[l].timing.mark_delay < each[l - 1].timing.mark_delay;
        EXPECT_EQ(share[l] > share[l - 1], quicker) << what << ": laser " << l + 1;
      }
      if (each.size() == 2 && each[0].hatch_speed == 2 * each[1].hatch_speed) {
        EXPECT_GT(share[0], 1.5 * share[1]) << what;
      }
      // The same paths at the same profile values on equal lasers split as before (no lasers).
      Layer plain = before;
      const LaserSplit e = split_among_lasers(
          plain, laser_setup({}, 1, profile, std::vector<LaserParameters>(each.size(), profile)),
          0);
      Layer old = before;
      const LaserSplit o = split_among_lasers(
          old, laser_setup(static_cast<int>(each.size()), {}, 1, profile.timing), 0);
      EXPECT_EQ(e.seconds, o.seconds) << what;
      EXPECT_EQ(e.boundaries, o.boundaries) << what;
    }
}
