#include "trellis/machine/laser.hpp"

#include <fmt/format.h>

#include <toml++/toml.h>

#include <cmath>
#include <map>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

namespace {

struct Key {
  double LaserProfile::*member;
  double lo, hi;
};

const std::map<std::string, Key>& keys() {
  static const std::map<std::string, Key> k = {
      {"laser.spot_diameter", {&LaserProfile::spot_diameter, 0.001, 5}},
      {"laser.melt_pool_width", {&LaserProfile::melt_pool_width, 0.001, 5}},
      {"laser.contour_power", {&LaserProfile::contour_power, 0, 10000}},
      {"laser.contour_speed", {&LaserProfile::contour_speed, 0.1, 100000}},
      {"laser.hatch_power", {&LaserProfile::hatch_power, 0, 10000}},
      {"laser.hatch_speed", {&LaserProfile::hatch_speed, 0.1, 100000}},
      {"scan.layer", {&LaserProfile::layer, 0.001, 1}},
      {"scan.hatch_distance", {&LaserProfile::hatch_distance, 0.001, 5}},
      {"scan.beam_compensation", {&LaserProfile::beam_compensation, 0, 1}},
      // Any SL/LHD a scanner can mark (the paper tested 5–400 / 0–120 µm; the planner warns).
      {"scan.segment_length", {&LaserProfile::segment_length, 0.0001, 1000}},
      {"scan.segment_gap", {&LaserProfile::segment_gap, 0, 1000}},
      {"timing.jump_speed", {&LaserProfile::jump_speed, 1, 1e6}},
      {"timing.jump_delay", {&LaserProfile::jump_delay, 0, 1e5}},
      {"timing.mark_delay", {&LaserProfile::mark_delay, 0, 1e5}},
      {"timing.polygon_delay", {&LaserProfile::polygon_delay, 0, 1e5}},
      {"timing.skywriting_time", {&LaserProfile::skywriting_time, 0, 1e5}},
  };
  return k;
}

void walk(LaserProfile& p, const toml::table& t, const std::string& prefix, const std::string& origin) {
  for (const auto& [k, node] : t) {
    const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    const Where where{origin, static_cast<long>(node.source().begin.line), key};
    if (const auto* sub = node.as_table()) {
      walk(p, *sub, key, origin);
      continue;
    }
    if (key == "timing.skywriting") {
      if (!node.is_boolean()) throw SettingError("expected true or false", where);
      p.skywriting = *node.value<bool>();
      continue;
    }
    if (key == "machine.name") {
      if (!node.is_string()) throw SettingError("expected a string", where);
      p.name = *node.value<std::string>();
      continue;
    }
    const auto it = keys().find(key);
    if (it == keys().end()) throw SettingError("unknown laser setting", where);
    if (!(node.is_floating_point() || node.is_integer())) throw SettingError("expected a number", where);
    const double v = *node.value<double>();
    if (!(v >= it->second.lo && v <= it->second.hi))
      throw SettingError(fmt::format("must be within {}..{}", it->second.lo, it->second.hi), where);
    p.*(it->second.member) = v;
  }
}

}  // namespace

LaserProfile laser_profile_from_toml(const std::string& text, const std::string& origin) {
  toml::table t;
  try {
    t = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    throw SettingError(std::string(e.description()), {origin, static_cast<long>(e.source().begin.line)});
  }
  LaserProfile p;
  walk(p, t, "", origin);
  return p;
}

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
  return t;
}

LaserProfile load_laser_profile(const std::string& path) {
  return laser_profile_from_toml(read_file(path), path);
}

}  // namespace trellis
