#include "trellis/machine/laser.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "trellis/core/error.hpp"

namespace trellis {

ScanTiming scan_timing(const LaserProfile& p) {
  ScanTiming t;
  t.contour_speed = p.contour_speed;
  t.hatch_speed = p.hatch_speed;
  t.jump_speed = p.jump_speed;
  t.jump_delay = p.jump_delay;
  t.mark_delay = p.mark_delay;
  t.polygon_delay = p.polygon_delay;
  t.skywriting = p.skywriting;
  t.skywriting_time = p.skywriting_time;
  t.laser_on_delay = p.laser_on_delay;
  t.laser_off_delay = p.laser_off_delay;
  return t;
}

LaserParameters profile_laser(const LaserProfile& p) {
  return {p.contour_power, p.contour_speed, p.hatch_power,
          p.hatch_speed,   p.spot_diameter, scan_timing(p)};
}

std::vector<LaserParameters> laser_parameters(const LaserProfile& p) {
  const auto n = static_cast<std::size_t>(std::max(1, p.lasers));
  std::vector<LaserParameters> out(n, profile_laser(p));
  const auto each = [&](const std::vector<double>& values, const char* key, auto&& set) {
    if (values.empty()) return;
    if (values.size() != n)
      throw SettingError(
          fmt::format("{} values for {} laser(s): give one per laser (laser.lasers), "
                      "in the order of laser.fields, or none",
                      values.size(), n),
          {"", 0, key});
    for (std::size_t l = 0; l < n; ++l) set(out[l], values[l]);
  };
  const LaserProfile::PerLaser& e = p.each;
  each(e.contour_power, "lasers.contour_power", [](auto& l, double v) { l.contour_power = v; });
  each(e.contour_speed, "lasers.contour_speed",
       [](auto& l, double v) { l.contour_speed = l.timing.contour_speed = v; });
  each(e.hatch_power, "lasers.hatch_power", [](auto& l, double v) { l.hatch_power = v; });
  each(e.hatch_speed, "lasers.hatch_speed",
       [](auto& l, double v) { l.hatch_speed = l.timing.hatch_speed = v; });
  each(e.spot_diameter, "lasers.spot_diameter", [](auto& l, double v) { l.spot_diameter = v; });
  each(e.jump_speed, "lasers.jump_speed", [](auto& l, double v) { l.timing.jump_speed = v; });
  each(e.jump_delay, "lasers.jump_delay", [](auto& l, double v) { l.timing.jump_delay = v; });
  each(e.mark_delay, "lasers.mark_delay", [](auto& l, double v) { l.timing.mark_delay = v; });
  each(e.polygon_delay, "lasers.polygon_delay",
       [](auto& l, double v) { l.timing.polygon_delay = v; });
  each(e.laser_on_delay, "lasers.laser_on_delay",
       [](auto& l, double v) { l.timing.laser_on_delay = v; });
  each(e.laser_off_delay, "lasers.laser_off_delay",
       [](auto& l, double v) { l.timing.laser_off_delay = v; });
  each(e.skywriting, "lasers.skywriting", [](auto& l, double v) { l.timing.skywriting = v != 0; });
  each(e.skywriting_time, "lasers.skywriting_time",
       [](auto& l, double v) { l.timing.skywriting_time = v; });
  return out;
}

bool lasers_differ(const LaserProfile& p) {
  const LaserProfile::PerLaser& e = p.each;
  for (const auto* v :
       {&e.contour_power, &e.contour_speed, &e.hatch_power, &e.hatch_speed, &e.spot_diameter,
        &e.jump_speed, &e.jump_delay, &e.mark_delay, &e.polygon_delay, &e.laser_on_delay,
        &e.laser_off_delay, &e.skywriting, &e.skywriting_time})
    if (!v->empty()) return true;
  return false;
}

std::vector<ScanTiming> laser_timings(const LaserProfile& p) {
  std::vector<ScanTiming> out;
  for (const LaserParameters& l : laser_parameters(p)) out.push_back(l.timing);
  return out;
}

std::vector<LaserParameters> declared_lasers(const LaserProfile* p, const Toolpath& tp) {
  return p && lasers_differ(*p) ? laser_parameters(*p) : tp.lasers;
}

}  // namespace trellis
