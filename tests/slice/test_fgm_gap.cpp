// fill_gaps (Strategy 2's uncovered parts of a fill) against the whole computation it replaces:
// the fill minus every line stroked two radii wide, opened by a radius.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "../../src/slice/fgm_outline.hpp"
#include "trellis/geom/regions.hpp"

using namespace trellis;

namespace {

Regions whole(const Regions& fill, const std::vector<std::vector<Vec2>>& lines, double r) {
  return offset(offset(difference(fill, stroke(lines, 2 * r)), -r), r);
}

double symmetric_difference(const Regions& a, const Regions& b) {
  return area(difference(a, b)) + area(difference(b, a));
}

// A plate with a round hole; wavy lines across it at random spacings (some too wide for the
// beads to meet), closed rings around a point, and a missing band.
struct Case {
  Regions fill;
  std::vector<std::vector<Vec2>> lines;
};

Case random_case(std::mt19937& rng, double r) {
  std::uniform_real_distribution<double> u(0, 1);
  Case c;
  Polygon2 plate;
  const double w = 15 + 15 * u(rng), h = 12 + 12 * u(rng);
  plate.outer = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  std::vector<Vec2> hole;
  const Vec2 hc{w * (0.3 + 0.4 * u(rng)), h * (0.3 + 0.4 * u(rng))};
  for (int k = 0; k < 48; ++k) {
    const double t = -2 * std::numbers::pi * k / 48;  // clockwise
    hole.push_back(hc + Vec2{3 * std::cos(t), 3 * std::sin(t)});
  }
  plate.holes.push_back(hole);
  c.fill = {plate};
  const double amp = 2 * u(rng), freq = 0.2 + 0.5 * u(rng);
  const double skip_lo = h * u(rng), skip_hi = skip_lo + 4 * r * u(rng);
  for (double y = 0.3 * r; y < h;) {
    if (y < skip_lo || y > skip_hi) {
      std::vector<Vec2> line;
      for (double x = 0; x <= w; x += 0.1) line.push_back({x, y + amp * std::sin(freq * x)});
      c.lines.push_back(std::move(line));
    }
    y += 2 * r * (0.6 + 1.4 * u(rng));  // 0.6 to 2 bead widths apart
  }
  const Vec2 rc{w * u(rng), h * u(rng)};
  for (double rad = 4 * r; rad < 4 * r + 8 * r; rad += 2 * r) {
    std::vector<Vec2> ring;
    for (int k = 0; k <= 64; ++k) {
      const double t = 2 * std::numbers::pi * (k % 64) / 64;
      ring.push_back(rc + Vec2{rad * std::cos(t), rad * std::sin(t)});
    }
    c.lines.push_back(std::move(ring));
  }
  return c;
}

}  // namespace

TEST(FgmGap, SameRegionsAsStrokingEveryLine) {
  std::mt19937 rng(45);
  const double r = 0.4;
  int with_gaps = 0;
  for (int n = 0; n < 8; ++n) {
    const Case c = random_case(rng, r);
    const Regions fast = fgm::fill_gaps(c.fill, c.lines, r);
    const Regions slow = whole(c.fill, c.lines, r);
    with_gaps += !slow.empty();
    // Within 1e-6 of the fill's area (Clipper's rounding where the strokes are cut).
    EXPECT_LE(symmetric_difference(fast, slow), 1e-6 * area(c.fill))
        << "case " << n << ": fast " << area(fast) << " mm², whole " << area(slow) << " mm²";
  }
  EXPECT_GE(with_gaps, 4);  // the cases do exercise gaps
}

TEST(FgmGap, LinesOneBeadApartLeaveNoGap) {
  const double r = 0.4;
  Polygon2 plate;
  plate.outer = {{0, 0}, {30, 0}, {30, 20}, {0, 20}};
  std::vector<std::vector<Vec2>> lines;
  for (double y = r; y < 20; y += 2 * r) lines.push_back({{0, y}, {30, y}});
  EXPECT_TRUE(fgm::fill_gaps({plate}, lines, r).empty());
  // Take three lines out: one gap, the band between the neighbours less a radius each side.
  lines.erase(lines.begin() + 10, lines.begin() + 13);
  const Regions gap = fgm::fill_gaps({plate}, lines, r);
  ASSERT_EQ(gap.size(), 1u);
  EXPECT_NEAR(area(gap), 30 * (4 * 2 * r - 2 * r), 0.2);  // corners mitred or rounded
  EXPECT_LE(symmetric_difference(gap, whole({plate}, lines, r)), 1e-6 * 600);
}
