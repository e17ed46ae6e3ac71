// Seeded random polygons with holes for property tests (slice: infill patterns, linking), and
// distances to their outlines.
#pragma once
#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include "trellis/core/rng.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis::test {

// A star-shaped ring about c, radii in [r0, r1], n vertices at jittered, evenly spread angles
// (no gap above two steps, so the ring stays outside r0·cos(2π/n)).
inline std::vector<Vec2> star(Rng& rng, Vec2 c, double r0, double r1, int n, bool ccw) {
  constexpr double kPi = std::numbers::pi;
  std::vector<Vec2> ring;
  const double phase = 2 * kPi * rng.uniform01();
  for (int i = 0; i < n; ++i) {
    const double a = phase + 2 * kPi * (i + 0.8 * rng.uniform01()) / n;
    const double r = r0 + (r1 - r0) * rng.uniform01();
    ring.push_back(c + Vec2{r * std::cos(a), r * std::sin(a)});
  }
  if (!ccw) std::reverse(ring.begin(), ring.end());
  return ring;
}

// An outer star of radius up to `scale` with 0-3 holes, and sometimes a second island.
inline Regions random_region(Rng& rng, double scale) {
  constexpr double kPi = std::numbers::pi;
  Polygon2 p;
  p.outer =
      star(rng, {0, 0}, 0.65 * scale, scale, 8 + static_cast<int>(rng.uniform_index(40)), true);
  std::vector<std::pair<Vec2, double>> placed;
  const auto holes = rng.uniform_index(4);
  for (std::uint64_t h = 0; h < holes; ++h) {
    const double d = 0.25 * scale * rng.uniform01(), a = 2 * kPi * rng.uniform01();
    const double r = scale * (0.05 + 0.1 * rng.uniform01());
    const Vec2 c{d * std::cos(a), d * std::sin(a)};
    if (std::any_of(placed.begin(), placed.end(), [&](const auto& q) {
          return std::sqrt(dist2(q.first, c)) < q.second + r + 0.05 * scale;
        }))
      continue;
    placed.push_back({c, r});
    p.holes.push_back(star(rng, c, 0.5 * r, r, 5 + static_cast<int>(rng.uniform_index(12)), false));
  }
  Regions out{p};
  if (rng.uniform_index(3) == 0) {
    Polygon2 island;
    island.outer = star(rng, {2.2 * scale, 0}, 0.3 * scale, 0.5 * scale, 10, true);
    out.push_back(island);
  }
  return out;
}

// Distance from p to segment a-b, and to the nearest ring of a region.
inline double segment_distance(Vec2 p, Vec2 a, Vec2 b) {
  return distance_to_segment({p.x, p.y, 0}, {a.x, a.y, 0}, {b.x, b.y, 0});
}
inline double outline_distance(Vec2 p, const Regions& r) {
  double best = 1e300;
  for (const auto& ring : rings_of(r))
    for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
      best = std::min(best, segment_distance(p, ring[j], ring[i]));
  return best;
}

}  // namespace trellis::test
