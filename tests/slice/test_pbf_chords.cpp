// Contour chords (pbf_detail::chord_vectors) against an exact curve: the circle φ = |q|² − R².
// Each chord end is where the circle of radius SL (or LHD) around the previous end meets the
// curve, found by Newton steps on both together: a few evaluations of φ per chord.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "../../src/slice/pbf_chords.hpp"

using namespace trellis;

TEST(PbfChords, ChordsOnACircleAreExactAndTakeFewProjections) {
  const double R = 0.5, sl = 0.1, gap = 0.02;
  std::size_t calls = 0;
  const pbf_detail::Curve curve{[&](Vec2 q, Vec2* g) {
                                  ++calls;
                                  *g = q * 2.0;
                                  return q.x * q.x + q.y * q.y - R * R;
                                },
                                0.1};
  for (const bool closed : {true, false}) {
    // The curve as the marches leave it: points on it every ~50 µm (an arc when open).
    const int n = 63;
    const double span = closed ? 2 * std::numbers::pi : 4.0;
    std::vector<Vec2> line;
    for (int i = 0; i <= n; ++i) {
      const double a = span * i / n;
      line.push_back({R * std::cos(a), R * std::sin(a)});
    }
    if (closed) line.back() = line.front();
    for (const double phase : {0.0, 0.013, 0.11}) {
      std::vector<std::vector<Vec2>> out;
      calls = 0;
      pbf_detail::chord_vectors(line, closed, sl, gap, phase, curve, out);
      ASSERT_GT(out.size(), 10u);
      for (std::size_t i = 0; i < out.size(); ++i) {
        ASSERT_EQ(out[i].size(), 2u);
        for (const Vec2 p : out[i]) EXPECT_NEAR(std::hypot(p.x, p.y), R, 1e-10);
        const Vec2 a = out[i][0], b = out[i][1];
        // Every chord but a line's first (cut short by the phase) and last is SL long; the gap
        // to the next chord is LHD.
        if (i > 0 && i + 1 < out.size()) {
          EXPECT_NEAR(std::hypot(b.x - a.x, b.y - a.y), sl, 1e-8) << i;
        }
        if (i + 1 < out.size()) {
          const Vec2 c = out[i + 1][0];
          EXPECT_NEAR(std::hypot(c.x - b.x, c.y - b.y), gap, 1e-8) << i;
        }
      }
      // Two chord ends a chord (its end and the next start), each one to three Newton steps
      // from the line's point (~0.6 µm off the circle; the last step under 1e-5 mm):
      // about four evaluations a chord (the earlier rule, steps under 1e-7 mm, took six).
      EXPECT_LE(calls, 9 * out.size() / 2 + 6) << (closed ? "loop" : "arc") << " phase " << phase;
    }
  }
}
