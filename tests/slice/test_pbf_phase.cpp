// Scan time with every scanner delay, the hatch phase and the paper's split by inclination, as
// properties: a layer's time grows by exactly its counted jumps, vectors and corners times their
// delays; with the origin phase the hatch lines of separate parts lie on one grid through the
// machine origin; the split's c stays between 0 and the sheet's c.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/toolpath/scan_time.hpp"

using namespace trellis;

namespace {

constexpr double kDeg = std::numbers::pi / 180;

PbfDesign gyroid_design() {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.15"};
  d.envelope = rectprism({2.5, 2.5, 2.5});
  return d;
}

// Two parallel walls 0.2 mm thick, far apart (y = −0.4437 and y = 0.31): φ = min(y − a, b − y)
// is zero on both planes, so the sheet |φ| < 0.1 is the two walls.
PbfDesign two_walls() {
  PbfDesign d;
  d.phi = expression_field({"min(y + 0.4437, 0.31 - y)"});
  d.c = {"0.1"};
  d.envelope = rectprism({2, 2, 0.1});
  return d;
}

// Where a point lies across the hatch lines of angle `deg` through `o`, in hatch distances.
double across(Vec2 p, Vec2 o, double deg, double h) {
  const Vec2 n{-std::sin(deg * kDeg), std::cos(deg * kDeg)};
  return ((p.x - o.x) * n.x + (p.y - o.y) * n.y) / h;
}
double off_grid(double t) {
  return std::abs(t - std::round(t));
}

}  // namespace

// Every delay counted independently from the layer's own vectors: a jump wherever a vector does
// not start where the previous one ended, a corner per inner point of a polyline. The time with
// delays is the time without plus jumps × jump delay + vectors × (mark + laser on + laser off
// delay) + corners × polygon delay; with skywriting the skywriting time replaces the mark delay.
TEST(PbfPhase, LayerTimeWithDelaysIsTheTimeWithoutPlusTheCountedDelays) {
  const PbfDesign d = gyroid_design();
  PbfOptions o;
  o.layer = 0.25;
  ScanTiming none;
  none.jump_delay = none.mark_delay = none.polygon_delay = 0;
  none.laser_on_delay = none.laser_off_delay = 0;
  o.timing = none;
  const PbfResult bare = plan_pbf(d, o);
  ScanTiming t = none;
  t.jump_delay = 310;
  t.mark_delay = 120;
  t.polygon_delay = 40;
  t.laser_on_delay = 25;
  t.laser_off_delay = 70;
  for (const bool sky : {false, true}) {
    t.skywriting = sky;
    t.skywriting_time = 210;
    o.timing = t;
    const PbfResult r = plan_pbf(d, o);
    ASSERT_EQ(r.layers.size(), bare.layers.size());
    std::size_t total_jumps = 0;
    for (std::size_t i = 0; i < r.layers.size(); ++i) {
      const PbfLayer& L = r.layers[i];
      std::size_t vectors = 0, jumps = 0, corners = 0;
      bool started = false;
      Vec2 at{};
      auto count = [&](const Vec2* p, std::size_t n) {
        if (started && (p[0].x != at.x || p[0].y != at.y)) ++jumps;
        started = true;
        ++vectors;
        corners += n - 2;
        at = p[n - 1];
      };
      for (const auto& c : L.contours) count(c.data(), c.size());
      for (const auto& h : L.hatches) {
        const Vec2 p[2] = {h.a, h.b};
        count(p, 2);
      }
      const double per_vector =
          (sky ? t.skywriting_time : t.mark_delay) + t.laser_on_delay + t.laser_off_delay;
      const double expected =
          bare.layers[i].scan_time + 1e-6 * (static_cast<double>(jumps) * t.jump_delay +
                                             static_cast<double>(vectors) * per_vector +
                                             static_cast<double>(corners) * t.polygon_delay);
      EXPECT_NEAR(L.scan_time, expected, 1e-9 * (1 + expected)) << "layer " << i;
      total_jumps += jumps;
    }
    EXPECT_GT(total_jumps, 100u);
    EXPECT_GT(r.scan_time, bare.scan_time);
  }
}

// The origin phase: on every layer (the hatch turning 67° a layer), every hatch vector of both
// walls lies on one grid of lines a hatch distance apart through the machine origin. The wall
// phase puts them on the grid through the design's origin instead, which is another grid here.
TEST(PbfPhase, OriginPhaseHatchesSeparatePartsOnOneGridThroughTheMachineOrigin) {
  const PbfDesign d = two_walls();
  PbfOptions o;
  o.layer = 0.02;
  o.hybrid = false;
  o.hatch_phase = HatchPhase::Origin;
  o.machine_origin = {-50.0123, -49.9871};
  const PbfResult r = plan_pbf(d, o);
  ASSERT_EQ(r.layers.size(), 5u);
  o.hatch_phase = HatchPhase::Wall;
  const PbfResult w = plan_pbf(d, o);
  std::size_t lower = 0, upper = 0, off_wall_grid = 0;
  for (std::size_t i = 0; i < r.layers.size(); ++i) {
    const PbfLayer& L = r.layers[i];
    for (const auto& h : L.hatches) {
      for (const Vec2 p : {h.a, h.b}) {
        EXPECT_LT(off_grid(across(p, o.machine_origin, L.hatch_angle, o.hatch_distance)), 1e-6)
            << "layer " << i << " at " << p.x << "," << p.y;
        if (off_grid(across(p, {0, 0}, L.hatch_angle, o.hatch_distance)) > 0.01) ++off_wall_grid;
      }
      (h.a.y + h.b.y < 0 ? lower : upper) += 1;
    }
    for (const auto& h : w.layers[i].hatches)
      EXPECT_LT(off_grid(across(h.a, {0, 0}, L.hatch_angle, o.hatch_distance)), 1e-6);
  }
  EXPECT_GT(lower, 20u);
  EXPECT_GT(upper, 20u);
  EXPECT_GT(off_wall_grid, 40u);  // the two grids differ: the check above can fail
}

// The random phase: each layer's grid moved by its own fraction of the hatch distance, the same
// for the same seed, another for another seed.
TEST(PbfPhase, RandomPhaseIsSeededAndDiffersBetweenLayers) {
  const PbfDesign d = two_walls();
  PbfOptions o;
  o.layer = 0.02;
  o.hybrid = false;
  o.hatch_rotation = 0;
  o.hatch_phase = HatchPhase::Random;
  o.hatch_seed = 7;
  const PbfResult a = plan_pbf(d, o), b = plan_pbf(d, o);
  o.hatch_seed = 8;
  const PbfResult c = plan_pbf(d, o);
  std::vector<double> phase;
  bool other = false;
  for (std::size_t i = 0; i < a.layers.size(); ++i) {
    ASSERT_FALSE(a.layers[i].hatches.empty());
    ASSERT_EQ(a.layers[i].hatches.size(), b.layers[i].hatches.size());
    for (std::size_t k = 0; k < a.layers[i].hatches.size(); ++k)
      EXPECT_EQ(a.layers[i].hatches[k].a.y, b.layers[i].hatches[k].a.y);
    const double t = across(a.layers[i].hatches[0].a, {0, 0}, 0, o.hatch_distance);
    phase.push_back(t - std::floor(t));
    const double u = across(c.layers[i].hatches[0].a, {0, 0}, 0, o.hatch_distance);
    if (std::abs(u - t) > 1e-3) other = true;
    // All of a layer's lines share its phase.
    for (const auto& h : a.layers[i].hatches)
      EXPECT_LT(off_grid(across(h.a, {0, 0}, 0, o.hatch_distance) - t), 1e-6);
  }
  EXPECT_TRUE(other);
  double spread = 0;
  for (const double p : phase) spread = std::max(spread, std::abs(p - phase[0]));
  EXPECT_GT(spread, 0.05);
}

// The paper's c by inclination (Eq. 6, Fig. S5): never outside [0, c], 0 below the threshold,
// the whole c from the threshold + the band up, never falling as the wall steepens.
TEST(PbfPhase, SplitCByInclinationStaysBetweenZeroAndC) {
  const double c = 0.15, lo = 20;
  double last = 0;
  for (double a = 0; a <= 90; a += 0.5) {
    const double s = pbf_split_c(c, a, lo);
    EXPECT_GE(s, 0);
    EXPECT_LE(s, c);
    EXPECT_GE(s, last);
    if (a <= lo) {
      EXPECT_EQ(s, 0) << a;
    }
    if (a >= lo + kSplitBand) {
      EXPECT_EQ(s, c) << a;
    }
    last = s;
  }
}

// In the planner: with split = inclination, thin-wall contours lie only where the mid-surface is
// steeper than the threshold (c > 0 there), and hatch fills where it is shallower; a steep thin
// wall is all contour under either split, a shallow one (15°) all hatch.
TEST(PbfPhase, InclinationSplitContoursSteepWallsAndHatchesShallowOnes) {
  PbfOptions o;
  o.layer = 0.02;
  o.hatch_rotation = 0;
  o.hatch_angle = 90;
  o.split = PbfSplit::Inclination;
  const PbfResult steep = plan_pbf(plane_wall(0.07, 80, 0, {0.8, 0.8, 0.02}), o);
  ASSERT_EQ(steep.layers.size(), 1u);
  EXPECT_FALSE(steep.layers[0].contours.empty());
  EXPECT_TRUE(steep.layers[0].hatches.empty());
  const PbfResult flat = plan_pbf(plane_wall(0.07, 15, 0, {0.8, 0.8, 0.02}), o);
  ASSERT_EQ(flat.layers.size(), 1u);
  EXPECT_TRUE(flat.layers[0].contours.empty());
  EXPECT_FALSE(flat.layers[0].hatches.empty());
  // A gyroid: every contour point's mid-surface inclination is at least the threshold.
  const PbfDesign g = gyroid_design();
  o.layer = 0.25;
  o.hatch_angle = 0;
  o.hatch_rotation = 67;
  const PbfResult r = plan_pbf(g, o);
  Evaluator phi(g.phi);
  std::size_t points = 0;
  for (const auto& L : r.layers)
    for (const auto& v : L.contours)
      for (const Vec2 p : v) {
        const Vec3 n = phi.gradient({p.x, p.y, L.z});
        const double incl =
            std::acos(std::min(1.0, std::abs(n.z) / std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z)));
        EXPECT_GE(incl / kDeg, o.min_inclination - 2.0) << p.x << "," << p.y << " z " << L.z;
        ++points;
      }
  EXPECT_GT(points, 100u);
}
