#include "trellis/toolpath/check.hpp"

#include <cmath>

namespace trellis {

namespace {

// Beyond ±1e6 (1 km, or 1000 km/s) nothing is printable, and writers could overflow.
constexpr double kLimit = 1e6;

bool in_range(double v) {
  return std::isfinite(v) && std::abs(v) <= kLimit;
}
bool in_range(Vec3 p) {
  return in_range(p.x) && in_range(p.y) && in_range(p.z);
}

}  // namespace

std::optional<PathProblem> path_problem(const Path& p) {
  if (p.points.size() < 2) return PathProblem{"points", 0, "a path needs at least 2 points"};
  for (std::size_t i = 0; i < p.points.size(); ++i)
    if (!in_range(p.points[i])) return PathProblem{"points", i, "is not finite or beyond ±1e6 mm"};
  for (std::size_t i = 0; i < p.via.size(); ++i)
    if (!in_range(p.via[i])) return PathProblem{"via", i, "is not finite or beyond ±1e6 mm"};
  for (std::size_t i = 0; i < p.mixture.size(); ++i)
    if (!in_range(p.mixture[i]) || p.mixture[i] < 0)
      return PathProblem{"mixture", i, "must be a finite fraction >= 0"};
  if (p.tool < 0) return PathProblem{"tool", 0, "must be >= 0"};
  const std::pair<const char*, double> values[] = {
      {"width", p.width}, {"height", p.height},     {"speed", p.speed},
      {"power", p.power}, {"filament", p.filament}, {"temperature", p.temperature},
      {"flow", p.flow}};
  for (const auto& [name, v] : values)
    if (!in_range(v) || v < 0) return PathProblem{name, 0, "must be a finite number >= 0"};
  if (!std::isfinite(p.fan) || p.fan > 100)
    return PathProblem{"fan", 0, "must be 0..100 % (< 0: not set)"};
  return std::nullopt;
}

}  // namespace trellis
