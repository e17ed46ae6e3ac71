// Laser paths as the PBF paper means them, checked on generated walls: beam compensation keeps
// every hatch vector off the boundary at any angle, contour vectors are straight chords of
// length SL, FR_a follows the line-filling ratio, and the scan-time model adds up.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "trellis/core/error.hpp"
#include "trellis/field/field.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/toolpath/scan_time.hpp"

using namespace trellis;

namespace {

constexpr double kPi = std::numbers::pi;

// Distance from p to the part's boundary, by bisection on the field along a fan of rays (the
// smallest over 72 directions; 5° apart it overestimates a plane's distance by < 0.1%), each
// searched out to `reach`. Returns reach when no ray leaves the part within it.
double boundary_distance(Evaluator& part, Vec2 p, double z, double reach) {
  double best = reach;
  for (int k = 0; k < 72; ++k) {
    const double a = k * kPi / 36;
    const Vec2 d{std::cos(a), std::sin(a)};
    auto f = [&](double t) { return part.value({p.x + d.x * t, p.y + d.y * t, z}); };
    if (f(best) < 0) continue;  // still inside at the best distance so far
    double lo = 0, hi = best;
    for (int it = 0; it < 40; ++it) {
      const double m = 0.5 * (lo + hi);
      (f(m) < 0 ? lo : hi) = m;
    }
    best = 0.5 * (lo + hi);
  }
  return best;
}

// Plane walls 50–200 µm thick at 0–90° to the hatch (vertical, and one inclined at 60°), R67 and
// hybrid: every point along every hatch vector (every 5 µm and both ends) is at least the beam
// compensation − 1 µm from the sheet's boundary, and the ends touch the compensated boundary
// (within 1.5 µm of it) — the compensation is applied, not exceeded.
TEST(PbfLaser, HatchKeepsTheBeamCompensationFromPlaneWallsAtEveryAngle) {
  PbfOptions o;
  o.layer = 0.02;
  o.hatch_rotation = 0;
  std::size_t vectors = 0, ends = 0, contour_points = 0;
  for (const double t : {0.05, 0.07, 0.12, 0.2})
    for (const double angle : {0.0, 10.0, 30.0, 45.0, 60.0, 80.0, 90.0})
      for (const double inclination : {90.0, 60.0})
        for (const bool hybrid : {false, true}) {
          if (inclination != 90 && angle != 30 && angle != 90) continue;
          PbfDesign d = plane_wall(t, inclination, 0, {0.8, 0.8, 0.02});
          o.hatch_angle = angle;
          o.hybrid = hybrid;
          const PbfResult r = plan_pbf(d, o);
          ASSERT_EQ(r.layers.size(), 1u);
          Evaluator part(d.part());
          const PbfLayer& L = r.layers[0];
          if (t < 2 * o.beam_compensation) EXPECT_TRUE(L.hatches.empty()) << t;
          // Contour tracks stay inside the sheet: on the mid-plane, t/2 from the faces, and
          // the compensation from the box where they end.
          for (const auto& v : L.contours)
            for (const Vec2 p : v)
              EXPECT_GE(boundary_distance(part, p, L.z, 0.2),
                        std::min(o.beam_compensation, 0.5 * t) - 1e-3)
                  << "contour, t " << t << " angle " << angle << " at " << p.x << "," << p.y;
          for (const auto& v : L.contours) contour_points += v.size();
          for (const auto& h : L.hatches) {
            const double len = std::hypot(h.b.x - h.a.x, h.b.y - h.a.y);
            const int n = std::max(1, static_cast<int>(std::ceil(len / 0.005)));
            for (int k = 0; k <= n; ++k) {
              const Vec2 p = h.a + (h.b - h.a) * (static_cast<double>(k) / n);
              const double dist = boundary_distance(part, p, L.z, 0.2);
              EXPECT_GE(dist, o.beam_compensation - 1e-3)
                  << "t " << t << " angle " << angle << " inclination " << inclination
                  << (hybrid ? " hybrid" : " r67") << " at " << p.x << "," << p.y;
              if (k == 0 || k == n) {
                // Every end on the compensated boundary (the compensation applied, not more).
                EXPECT_LE(dist, o.beam_compensation + 1.5e-3)
                    << "t " << t << " angle " << angle << " inclination " << inclination
                    << (hybrid ? " hybrid" : " r67") << " at " << p.x << "," << p.y;
                ++ends;
              }
            }
            ++vectors;
          }
        }
  EXPECT_GT(vectors, 300u);
  EXPECT_GT(ends, 600u);
  EXPECT_GT(contour_points, 200u);
}

// The same on a gyroid sheet (curved walls, joints): the section's chords are moved onto the
// field, so the offset keeps the compensation within 1 µm there too.
TEST(PbfLaser, HatchKeepsTheBeamCompensationInAGyroid) {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.3"};
  d.envelope = rectprism({2.5, 2.5, 2.5});
  PbfOptions o;
  o.layer = 0.5;
  for (const bool hybrid : {false, true}) {
    o.hybrid = hybrid;
    const PbfResult r = plan_pbf(d, o);
    Evaluator part(d.part());
    std::size_t checked = 0;
    for (const auto& L : r.layers)
      for (std::size_t i = 0; i < L.hatches.size(); i += 3) {  // every 3rd vector, both ends
        for (const Vec2 p : {L.hatches[i].a, L.hatches[i].b}) {
          EXPECT_GE(boundary_distance(part, p, L.z, 0.1), o.beam_compensation - 1e-3);
          ++checked;
        }
      }
    EXPECT_GT(checked, 200u);
  }
}

// Fig. 3(b-ii): a 70 µm wall, hatched by R67 at angles from across to along it, the wall moved
// across the hatch lines' phase (8 positions a hatch distance). Across, every position gets
// about the same FR_a; turning parallel, the lines hit the narrow compensated strip or miss it,
// and the worst layer's FR_a falls to nothing. The hybrid contour track does not care.
TEST(PbfLaser, R67FillingRatioFallsAsTheHatchTurnsParallelToAThinWall) {
  PbfOptions o;
  o.layer = 0.02;
  o.hatch_rotation = 0;
  const double t = 0.07;
  std::vector<double> worst, hybrid;
  const std::vector<double> angles = {90, 60, 30, 10, 3, 0};
  for (const double angle : angles) {
    double lo = 1e9, sum = 0;
    for (int k = 0; k < 8; ++k) {
      PbfDesign d = plane_wall(t, 90, 0, {2, 1, 0.02});
      d.phi = translate(d.phi, {0, k * o.hatch_distance / 8 + 0.0013, 0});
      o.hatch_angle = angle;
      const PbfResult r = plan_pbf(d, o);
      ASSERT_EQ(r.layers.size(), 1u);
      lo = std::min(lo, r.layers[0].fr_r67);
      sum += r.layers[0].fr;
    }
    worst.push_back(lo);
    hybrid.push_back(sum / 8);
  }
  for (std::size_t i = 1; i < angles.size(); ++i) {
    EXPECT_LE(worst[i], worst[i - 1] * 1.05 + 1e-9) << angles[i] << "° vs " << angles[i - 1] << "°";
    EXPECT_NEAR(hybrid[i], hybrid[0], 0.01 * hybrid[0]) << angles[i];
  }
  // Across: the compensated strip (t − 2·bc wide) is hit every hatch distance.
  const double across = 0.0638 * (t - 2 * o.beam_compensation) / o.hatch_distance / t;
  EXPECT_NEAR(worst[0], across, 0.1 * across);
  EXPECT_LT(worst.back(), 0.05 * worst[0]);
}

// Contour vectors on a ring wall (a closed mid-curve of radius 0.5 mm): straight chords of
// length SL (all but the loop's last), gaps LHD, ends on φ = 0 within 1 µm, and the chord's
// middle off the curve by the sagitta R − √(R² − SL²/4) — a chord, not an arc.
TEST(PbfLaser, ContourVectorsAreStraightChordsOfLengthSlWithGapsLhd) {
  const double R = 0.5;
  PbfDesign d;
  d.phi = expression_field({"sqrt(x*x + y*y) - 0.5"});
  d.c = {"0.035"};
  d.envelope = rectprism({1.5, 1.5, 0.06});
  Evaluator phi(d.phi);
  for (const double sl : {0.005, 0.1, 0.4})
    for (const double lhd : {0.0, 0.06, 0.12}) {
      PbfOptions o;
      o.layer = 0.02;
      o.segment_length = sl;
      o.segment_gap = lhd;
      const PbfResult r = plan_pbf(d, o);
      ASSERT_EQ(r.layers.size(), 3u);
      EXPECT_EQ(r.hatch_vectors, 0u);
      for (const auto& L : r.layers) {
        ASSERT_GE(L.contours.size(), 2u);
        for (std::size_t i = 0; i < L.contours.size(); ++i) {
          const auto& v = L.contours[i];
          ASSERT_EQ(v.size(), 2u);
          for (const Vec2 q : v) EXPECT_LT(std::abs(phi.value({q.x, q.y, L.z})), 1e-3);
          const double len = std::hypot(v[1].x - v[0].x, v[1].y - v[0].y);
          if (i + 1 < L.contours.size()) {
            EXPECT_NEAR(len, sl, 1e-3) << "SL " << sl << " LHD " << lhd << " chord " << i;
            const Vec2 n = L.contours[i + 1][0];
            EXPECT_NEAR(std::hypot(n.x - v[1].x, n.y - v[1].y), lhd, 1e-3) << "SL " << sl;
            const Vec2 m = (v[0] + v[1]) * 0.5;
            EXPECT_NEAR(R - std::hypot(m.x, m.y), R - std::sqrt(R * R - sl * sl / 4), 1e-3);
          } else {
            EXPECT_LE(len, sl + 1e-3);
          }
        }
      }
      // Starts move between layers.
      EXPECT_GT(std::hypot(r.layers[0].contours[0][0].x - r.layers[1].contours[0][0].x,
                           r.layers[0].contours[0][0].y - r.layers[1].contours[0][0].y),
                1e-3);
    }
}

// FR_a of a straight thin wall follows the line-filling ratio SL/(SL + LHD) over the paper's
// grid and beyond it (SL = 1 mm, LHD = 0.3 mm: planned, with warnings).
TEST(PbfLaser, FillingRatioFollowsTheLineFillingRatio) {
  const PbfDesign d = plane_wall(0.065, 90, 0, {20, 0.5, 0.1});
  for (const auto [sl, lhd] : {std::pair{0.005, 0.0}, std::pair{0.005, 0.12}, std::pair{0.1, 0.02},
                               std::pair{0.4, 0.0}, std::pair{0.4, 0.12}, std::pair{1.0, 0.3}}) {
    PbfOptions o;
    o.layer = 0.02;
    o.segment_length = sl;
    o.segment_gap = lhd;
    const PbfResult r = plan_pbf(d, o);
    const PbfStats h = fr_stats(r.layers, false);
    const double expected = 0.0638 / 0.065 * sl / (sl + lhd) * (20 - 2 * o.beam_compensation) / 20;
    EXPECT_NEAR(h.mean, expected, 0.03 * expected) << "SL " << sl << " LHD " << lhd;
    EXPECT_EQ(r.diagnostics.count("pbf.sl_untested") + r.diagnostics.count("pbf.lhd_untested"),
              sl > 0.4 ? 2u : 0u);
  }
}

// Scan time: marks at their speed, jumps at the jump speed, delays per jump, vector and corner.
TEST(PbfLaser, ScanClockAddsMarksJumpsAndDelays) {
  ScanTiming t;
  t.jump_speed = 4000;
  t.jump_delay = 200;
  t.mark_delay = 100;
  t.polygon_delay = 50;
  ScanClock c(t);
  c.mark({0, 0}, {1, 0}, 500);  // 2 ms + mark delay
  const Vec2 poly[3] = {{1, 2}, {2, 2}, {2, 3}};
  c.mark(poly, 3, 1000);  // jump 2 mm: 0.5 ms + jump delay; 2 ms; 1 corner
  const double expected = 2e-3 + 100e-6 + 0.5e-3 + 200e-6 + 2e-3 + 100e-6 + 50e-6;
  EXPECT_NEAR(c.seconds(), expected, 1e-12);
  EXPECT_NEAR(c.jump_seconds(), 0.5e-3, 1e-12);
  t.skywriting = true;
  t.skywriting_time = 300;
  ScanClock s(t);
  s.mark({0, 0}, {1, 0}, 500);
  EXPECT_NEAR(s.seconds(), 2e-3 + 300e-6, 1e-12);
}

// Per layer, the planner's scan times are the clock over the layer's own vectors (contours then
// hatches), and over the R67 baseline; on a gyroid the hybrid path scans faster than R67.
TEST(PbfLaser, LayerScanTimesAreTheClockOverTheVectors) {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.15"};
  d.envelope = rectprism({2.5, 2.5, 2.5});
  PbfOptions o;
  o.layer = 0.25;
  const PbfResult r = plan_pbf(d, o);
  double sum = 0;
  for (const auto& L : r.layers) {
    ScanClock c(o.timing);
    for (const auto& v : L.contours) c.mark(v.data(), v.size(), o.timing.contour_speed);
    for (const auto& h : L.hatches) c.mark(h.a, h.b, o.timing.hatch_speed);
    EXPECT_NEAR(L.scan_time, c.seconds(), 1e-12);
    sum += L.scan_time;
    EXPECT_GT(L.scan_time_r67, 0);
  }
  EXPECT_NEAR(r.scan_time, sum, 1e-9);
  EXPECT_LT(r.scan_time, r.scan_time_r67);
}

// The memory guard: a budget below the estimate refuses the job before it runs.
TEST(PbfLaser, MemoryBudgetRefusesAJobAboveIt) {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.15"};
  d.envelope = rectprism({2.5, 2.5, 2.5});
  PbfOptions o;
  o.layer = 0.5;
  const double estimate = pbf_memory_estimate(d, o, 2);
  EXPECT_GT(estimate, 1e5);
  RunContext context;
  context.budget.memory = 1e4;
  EXPECT_THROW(plan_pbf(d, o, context), ResourceError);
  context.budget.force = true;
  EXPECT_GT(plan_pbf(d, o, context).memory_estimate, 0);
  context.budget = {};
  EXPECT_GT(plan_pbf(d, o, context).memory_estimate, 0);
}

}  // namespace

namespace {

// Fig. 3(b): over 1,000 layers the hybrid path's FR_a stays steady on plane walls of every
// thickness from thin (contoured) to thick (hatched), at an angle to the first hatch.
TEST(PbfLaser, HybridFillingRatioIsSteadyOver1000LayersOnWalls50To200Micrometres) {
  for (const double t : {0.05, 0.1, 0.15, 0.2}) {
    PbfOptions o;
    o.layer = 0.02;
    const PbfResult r = plan_pbf(plane_wall(t, 90, 30, {1, 1, 20}), o);
    ASSERT_EQ(r.layers.size(), 1000u);
    const PbfStats h = fr_stats(r.layers, false);
    EXPECT_GT(h.mean, 0.3) << t;
    EXPECT_LT(h.cv, 0.05) << t;
  }
}

}  // namespace
