// Hatch with an inset (laser beam compensation) against exact point-to-polygon distances and
// against Clipper's inward offset followed by a plain hatch, on random star polygons with holes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "support/random_regions.hpp"
#include "trellis/geom/regions.hpp"

using namespace trellis;
using test::outline_distance;
using test::segment_distance;

namespace {

bool inside(Vec2 p, const Regions& r) {  // even-odd over all rings
  bool in = false;
  for (const auto& ring : rings_of(r))
    for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
      if ((ring[i].y > p.y) != (ring[j].y > p.y) &&
          p.x < (ring[j].x - ring[i].x) * (p.y - ring[i].y) / (ring[j].y - ring[i].y) + ring[i].x)
        in = !in;
  return in;
}

TEST(Regions, HatchInsetKeepsItsDistanceAndMatchesTheOffsetHatch) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> U(0, 1);
  auto star = [&](Vec2 c, double r0, double r1, int n) {
    std::vector<double> ang(n);
    for (auto& a : ang) a = 2 * std::numbers::pi * U(rng);
    std::sort(ang.begin(), ang.end());
    std::vector<Vec2> ring;
    for (double a : ang) {
      const double r = r0 + (r1 - r0) * U(rng);
      ring.push_back(c + Vec2{r * std::cos(a), r * std::sin(a)});
    }
    return ring;
  };
  std::size_t checked = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Polygon2 a;
    a.outer = star({0, 0}, 6, 15, 5 + static_cast<int>(rng() % 60));
    if (trial % 2) a.holes.push_back(star({0, 0}, 1, 4, 3 + static_cast<int>(rng() % 12)));
    const Regions keep = {a};
    Regions cut;
    if (trial % 3 == 0) cut = {Polygon2{star({8, 3}, 1, 3, 3 + static_cast<int>(rng() % 10)), {}}};
    const double angle = 180 * U(rng), spacing = 0.2 + 0.8 * U(rng), inset = 0.1 + 1.5 * U(rng);
    const Vec2 origin{U(rng), U(rng)};
    const auto got = hatch_inset(keep, cut, angle, spacing, inset, origin);
    double len = 0;
    for (const auto& s : got) {
      len += std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
      for (const double t : {0.0, 0.25, 0.5, 0.75, 1.0}) {
        const Vec2 p = s.a + (s.b - s.a) * t;
        const double d = std::min(outline_distance(p, keep), outline_distance(p, cut));
        EXPECT_GE(d, inset - 1e-9) << "trial " << trial;
        if (t == 0.0 || t == 1.0) {  // on the inset
          EXPECT_NEAR(d, inset, 1e-7) << "trial " << trial;
        }
        EXPECT_TRUE(inside(p, keep) && !inside(p, cut)) << "trial " << trial;
        ++checked;
      }
    }
    // Against Clipper's inward offset of keep − cut, hatched: its mitred reflex corners (up to
    // twice the inset) trim more than the exact inset, never less.
    const Regions region = cut.empty() ? keep : difference(keep, cut);
    double mitred = 0;
    for (const auto& s : hatch(offset(region, -inset, 1e-4), angle, spacing, origin))
      mitred += std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
    EXPECT_GE(len, mitred - 1e-6) << "trial " << trial;
    // Against sampling the plain hatch every δ: the samples at least the inset from both
    // outlines and outside the cut (each of the pieces' ends is off by at most δ).
    if (trial % 4 == 0) {
      const double delta = 0.01;
      const auto base = hatch(keep, angle, spacing, origin);
      double sampled = 0;
      for (const auto& s : base) {
        const double l = std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
        for (double x = 0.5 * delta; x < l; x += delta) {
          const Vec2 p = s.a + (s.b - s.a) * (x / l);
          if (!inside(p, cut) &&
              std::min(outline_distance(p, keep), outline_distance(p, cut)) >= inset)
            sampled += delta;
        }
      }
      EXPECT_NEAR(len, sampled, delta * (2.0 * static_cast<double>(got.size() + base.size()) + 2))
          << "trial " << trial;
    }
  }
  EXPECT_GT(checked, 5000u);
}

}  // namespace

namespace {

// Rings sampled finely (edges much shorter than the inset, as the PBF section after
// densification): consecutive edges' capsules overlap on every line, so trim_hatch widens spans
// instead of adding them. Distances and length against sampling as above.
TEST(Regions, HatchInsetOnFinelySampledRings) {
  auto wavy = [](Vec2 c, double r, double amp, int lobes, int n, bool cw) {
    std::vector<Vec2> ring;
    for (int i = 0; i < n; ++i) {
      const double a = 2 * std::numbers::pi * (cw ? n - i : i) / n;
      const double rr = r + amp * std::sin(lobes * a);
      ring.push_back(c + Vec2{rr * std::cos(a), rr * std::sin(a)});
    }
    return ring;
  };
  std::size_t checked = 0;
  for (int trial = 0; trial < 3; ++trial) {
    Polygon2 a;
    a.outer = wavy({0, 0}, 5, 0.8, 7, 2500 + 300 * trial, false);
    a.holes.push_back(wavy({0.3, -0.2}, 2, 0.4, 5, 1500, true));
    const Regions keep = {a};
    const double angle = 17.0 + 29.0 * trial, spacing = 0.15 + 0.02 * trial, inset = 0.3;
    const auto got = hatch_inset(keep, {}, angle, spacing, inset);
    double len = 0;
    for (const auto& s : got) {
      len += std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
      for (const double t : {0.0, 0.5, 1.0}) {
        const Vec2 p = s.a + (s.b - s.a) * t;
        const double d = outline_distance(p, keep);
        EXPECT_GE(d, inset - 1e-9) << "trial " << trial;
        if (t != 0.5) {
          EXPECT_NEAR(d, inset, 1e-7) << "trial " << trial;
        }
        ++checked;
      }
    }
    const double delta = 0.02;
    const auto base = hatch(keep, angle, spacing);
    double sampled = 0;
    for (const auto& s : base) {
      const double l = std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
      for (double x = 0.5 * delta; x < l; x += delta)
        if (outline_distance(s.a + (s.b - s.a) * (x / l), keep) >= inset) sampled += delta;
    }
    EXPECT_NEAR(len, sampled, delta * (2.0 * static_cast<double>(got.size() + base.size()) + 2))
        << "trial " << trial;
  }
  EXPECT_GT(checked, 500u);
}

}  // namespace
