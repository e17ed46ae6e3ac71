#include "trellis/toolpath/scan_time.hpp"

#include <cmath>
#include <vector>

#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

void ScanClock::mark(const Vec2* p, std::size_t n, double speed) {
  if (n < 2) return;
  if (started_) {
    const double d = std::hypot(p[0].x - at_.x, p[0].y - at_.y);
    if (d > 0) {
      jump_s_ += d / t_.jump_speed;
      delay_s_ += t_.jump_delay * 1e-6;
      ++jumps_;
    }
  }
  started_ = true;
  double len = 0;
  for (std::size_t k = 1; k < n; ++k) len += std::hypot(p[k].x - p[k - 1].x, p[k].y - p[k - 1].y);
  mark_s_ += len / speed;
  delay_s_ += (t_.skywriting ? t_.skywriting_time : t_.mark_delay) * 1e-6;
  delay_s_ += (t_.laser_on_delay + t_.laser_off_delay) * 1e-6;
  delay_s_ += static_cast<double>(n - 2) * t_.polygon_delay * 1e-6;
  corners_ += n - 2;
  at_ = p[n - 1];
  ++vectors_;
}

namespace {

// A path marked at its own speed (when set; else the hatch or contour speed by its role).
void mark_path(ScanClock& clock, const Path& p, const ScanTiming& timing, std::vector<Vec2>& xy) {
  if (p.points.size() < 2) return;
  xy.clear();
  for (const Vec3& q : p.points) xy.push_back({q.x, q.y});
  const bool hatch = p.role == PathRole::Hatch || p.role == PathRole::Infill;
  clock.mark(xy.data(), xy.size(),
             p.speed > 0 ? p.speed : (hatch ? timing.hatch_speed : timing.contour_speed));
}

}  // namespace

ScanClock layer_scan_clock(const Layer& layer, const ScanTiming& timing) {
  ScanClock clock(timing);
  std::vector<Vec2> xy;
  for (const Path& p : layer.paths) mark_path(clock, p, timing, xy);
  return clock;
}

std::vector<double> path_scan_seconds(const Layer& layer, const ScanTiming& timing) {
  ScanClock clock(timing);
  std::vector<Vec2> xy;
  std::vector<double> out;
  out.reserve(layer.paths.size());
  for (const Path& p : layer.paths) {
    const double before = clock.seconds();
    mark_path(clock, p, timing, xy);
    out.push_back(clock.seconds() - before);
  }
  return out;
}

double scan_time(const std::vector<const Path*>& vectors, const ScanTiming& laser) {
  ScanClock clock(laser);
  std::vector<Vec2> xy;
  for (const Path* p : vectors) mark_path(clock, *p, laser, xy);
  return clock.seconds();
}

}  // namespace trellis
