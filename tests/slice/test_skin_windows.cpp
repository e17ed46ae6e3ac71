// SkinWindows (the planar slicer's sliding window of layer intersections): each window is the
// intersection of its layers (checked against intersecting them one by one, by area), the same
// regions however the layers are added (one at a time, in runs of any length, all at once), each
// window intersected once (no run is redone when more layers come), and a stack of equal layers
// costs a few intersections, not a few per layer.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "trellis/slice/slice.hpp"

using namespace trellis;

namespace {

using Ptr = SkinWindows::Ptr;

Polygon2 blob(Vec2 c, double r, double wobble, int n, double phase) {
  Polygon2 p;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    const double rr = r * (1 + wobble * std::sin(3 * a + phase));
    p.outer.push_back({c.x + rr * std::cos(a), c.y + rr * std::sin(a)});
  }
  return p;
}

// A part of `n` layers: one or two islands drifting and swelling from layer to layer, some
// layers repeating the one before (a prism's), some empty.
std::vector<Ptr> part(std::mt19937& rng, std::size_t n) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Ptr> layers;
  Regions last;
  for (std::size_t i = 0; i < n; ++i) {
    const double roll = u(rng);
    Regions r;
    if (i > 0 && roll < 0.3) {
      r = last;  // equal to the layer below (its own copy)
    } else if (roll < 0.36) {
      r = {};
    } else {
      const double t = static_cast<double>(i);
      r.push_back(blob({0.3 * std::sin(0.2 * t), 0.2 * t * u(rng)}, 5 + u(rng), 0.1 * u(rng),
                       12 + static_cast<int>(20 * u(rng)), u(rng)));
      if (u(rng) < 0.5) r.push_back(blob({14 + u(rng), 0}, 3 + u(rng), 0.2, 9, u(rng)));
    }
    last = r;
    layers.push_back(std::make_shared<const Regions>(std::move(r)));
  }
  return layers;
}

// Layers [a, b) intersected one by one (empty when the range leaves the part).
Regions one_by_one(const std::vector<Ptr>& layers, long a, long b) {
  if (a < 0 || b > static_cast<long>(layers.size())) return {};
  Regions r = *layers[static_cast<std::size_t>(a)];
  for (long k = a + 1; k < b && !r.empty(); ++k)
    r = intersection(r, *layers[static_cast<std::size_t>(k)]);
  return r;
}

bool same(const Regions& a, const Regions& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (a[k].outer != b[k].outer || a[k].holes != b[k].holes) return false;
  return true;
}

void expect_near_set(const Regions& got, const Regions& want, const std::string& at) {
  const double tol = 1e-6 * (1 + area(want));
  EXPECT_NEAR(area(got), area(want), tol) << at;
  EXPECT_LT(area(difference(got, want)), tol) << at;
  EXPECT_LT(area(difference(want, got)), tol) << at;
}

}  // namespace

TEST(SkinWindows, EachWindowIsItsLayersIntersectionWhateverTheRunsAdded) {
  std::mt19937 rng(29);
  for (int trial = 0; trial < 60; ++trial) {
    const std::size_t n = 1 + rng() % 40;
    const int below = static_cast<int>(rng() % 7), above = static_cast<int>(rng() % 7);
    const std::vector<Ptr> layers = part(rng, n);
    const std::string at = "trial " + std::to_string(trial) + " n " + std::to_string(n) +
                           " below " + std::to_string(below) + " above " + std::to_string(above);
    SkinWindows all(n, below, above);
    all.add(layers);
    // Added in runs of random length, every window asked for as soon as its layers are in.
    SkinWindows runs(n, below, above);
    std::size_t next = 0;  // the next layer whose windows are checked
    while (runs.size() < n) {
      const std::size_t m = std::min(n - runs.size(), std::size_t{1} + rng() % 9);
      runs.add(std::vector<Ptr>(layers.begin() + static_cast<long>(runs.size()),
                                layers.begin() + static_cast<long>(runs.size() + m)));
      for (; next < n && (runs.size() == n || next + above < runs.size()); ++next) {
        const std::string where = at + " layer " + std::to_string(next);
        const Ptr u = runs.under(next), o = runs.over(next);
        ASSERT_EQ(u == nullptr, below == 0) << where;
        ASSERT_EQ(o == nullptr, above == 0) << where;
        if (u) {
          EXPECT_TRUE(same(*u, *all.under(next))) << where;
          const long l = static_cast<long>(next);
          expect_near_set(*u, one_by_one(layers, l - below, l), where + " under");
        }
        if (o) {
          EXPECT_TRUE(same(*o, *all.over(next))) << where;
          const long l = static_cast<long>(next);
          expect_near_set(*o, one_by_one(layers, l + 1, l + 1 + above), where + " over");
        }
        runs.forget_before(next);
      }
    }
    EXPECT_EQ(next, n) << at;
    // No window is intersected again at the end of a run of layers.
    EXPECT_EQ(runs.intersections(), all.intersections()) << at;
    // At most one intersection a level of the sparse table and one for each window width, a
    // layer.
    int levels = 0;
    while ((2 << levels) <= std::max(below, above)) ++levels;
    EXPECT_LE(runs.intersections(), n * static_cast<std::size_t>(levels + 2)) << at;
  }
}

TEST(SkinWindows, AStackOfEqualLayersSharesItsIntersections) {
  std::mt19937 rng(7);
  const std::size_t n = 200;
  const Regions r{blob({0, 0}, 10, 0.2, 64, 0.5), blob({30, 0}, 4, 0.1, 20, 0)};
  std::vector<Ptr> layers;
  for (std::size_t i = 0; i < n; ++i) layers.push_back(std::make_shared<const Regions>(r));
  SkinWindows w(n, 4, 3);
  for (std::size_t i = 0; i < n; i += 16)
    w.add(std::vector<Ptr>(layers.begin() + static_cast<long>(i),
                           layers.begin() + static_cast<long>(std::min(n, i + 16))));
  // One intersection for each level of runs and each window width, whatever the layer count.
  EXPECT_LE(w.intersections(), 4u);
  for (std::size_t i = 4; i + 3 < n; ++i) {
    expect_near_set(*w.under(i), r, "under " + std::to_string(i));
    expect_near_set(*w.over(i), r, "over " + std::to_string(i));
  }
  // Past the part: empty, so the top and bottom layers get skins.
  EXPECT_TRUE(w.under(3)->empty());
  EXPECT_TRUE(w.over(n - 3)->empty());
}

TEST(SkinWindows, AWindowNotYetIntersectedOrForgottenIsAnError) {
  std::mt19937 rng(3);
  const std::vector<Ptr> layers = part(rng, 20);
  SkinWindows w(20, 2, 2);
  w.add(std::vector<Ptr>(layers.begin(), layers.begin() + 10));
  EXPECT_THROW(w.over(9), std::logic_error);  // reads layers 10 and 11
  EXPECT_NO_THROW(w.over(7));
  w.forget_before(8);
  EXPECT_THROW(w.under(7), std::logic_error);
  EXPECT_NO_THROW(w.under(8));
  EXPECT_THROW(w.add(std::vector<Ptr>(layers.begin(), layers.begin() + 11)), std::logic_error);
}
