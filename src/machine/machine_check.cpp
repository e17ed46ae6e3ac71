#include "trellis/machine/machine_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

namespace trellis {

Vec2 placement_offset(const Toolpath& tp, const MachineProfile& p) {
  return placement_offset(p.center ? points_box(tp) : BBox3{}, p);
}

Vec2 placement_offset(const BBox3& box, const MachineProfile& p) {
  Vec2 d{0, 0};
  if (p.center) {
    if (!box.empty()) {
      const Vec2 bed_centre =
          p.origin == BedOrigin::Center ? Vec2{0, 0} : Vec2{p.bed_x / 2, p.bed_y / 2};
      d = {bed_centre.x - box.center().x, bed_centre.y - box.center().y};
    }
  }
  // Whole micrometres, the G-code's resolution: a placed point rounds as the design point does,
  // so placement never changes the geometry that is written.
  auto um = [](double v) { return std::round(v * 1000) / 1000; };
  return {um(d.x + p.offset_x), um(d.y + p.offset_y)};
}

double placement_lift(const Toolpath& tp, const MachineProfile& p) {
  return p.lift ? placement_lift(points_box(tp), p) : 0;
}

double placement_lift(const BBox3& box, const MachineProfile& p) {
  const double floor = p.has_bath() ? p.floor_z : 0;  // the design's Z 0 on the bath's floor
  if (!p.lift) return floor;
  const double low = box.empty() ? 0 : std::min(0.0, box.min.z);
  return floor + std::ceil(-low * 1000 - 1e-9) / 1000;  // whole micrometres, at least -low
}

Vec3 design_shift(std::string_view text) {
  // sscanf reads a NUL-terminated line: the one the key is on.
  auto line_at = [&](std::string_view key) {
    const auto at = text.find(key);
    if (at == std::string_view::npos) return std::string();
    return std::string(text.substr(at, text.find('\n', at) - at));
  };
  double dx = 0, dy = 0, dz = 0;
  const std::string offset = line_at("; placement offset = ");
  if (!offset.empty() &&
      std::sscanf(offset.c_str(), "; placement offset = %lf, %lf", &dx, &dy) != 2)
    dx = dy = 0;
  const std::string lift = line_at("; placement lift = ");
  if (!lift.empty() && std::sscanf(lift.c_str(), "; placement lift = %lf", &dz) != 1) dz = 0;
  return {dx, dy, dz};
}

void to_design_coordinates(Layer& layer, Vec3 shift) {
  layer.z -= shift.z;
  for (auto& p : layer.paths)
    for (auto& q : p.points) {
      q.x -= shift.x;
      q.y -= shift.y;
      q.z -= shift.z;
    }
}

void to_design_coordinates(Toolpath& tp, const std::string& text) {
  const Vec3 shift = design_shift(text);
  for (auto& l : tp.layers) to_design_coordinates(l, shift);
}

namespace {

std::string num(double v) {
  return fmt::format("{:.6g}", v);
}

// Collects errors of one kind with a count and the first place each was seen.
class Problems {
 public:
  void add(const std::string& kind, const std::string& message) {
    auto [it, fresh] = count_.try_emplace(kind, 0);
    if (fresh) order_.push_back({kind, message});
    ++it->second;
  }
  void throw_if_any() const {
    if (order_.empty()) return;
    std::string text;
    for (std::size_t i = 0; i < order_.size(); ++i) {
      if (i) text += "\n  ";
      text += order_[i].second;
      const std::size_t n = count_.at(order_[i].first);
      if (n > 1) text += fmt::format(" (and {} more like it)", n - 1);
    }
    throw MachineError(text);
  }

 private:
  std::map<std::string, std::size_t> count_;
  std::vector<std::pair<std::string, std::string>> order_;
};

std::string where(std::size_t layer, std::size_t path) {
  return fmt::format("layer {} path {}", layer, path);
}

}  // namespace

BBox3 path_extent(const std::vector<Vec3>& points) {
  BBox3 box;
  bool nan = false;
  for (const Vec3& q : points) {
    box.add(q);
    nan |= (q.x != q.x) | (q.y != q.y) | (q.z != q.z);
  }
  if (nan) box.min.x = std::numeric_limits<double>::quiet_NaN();
  return box;
}

std::vector<MachineWarning> check_for_machine(const Toolpath& tp, const MachineProfile& p) {
  return check_for_machine(layers_of(tp), p.center ? points_box(tp) : BBox3{}, p);
}

std::vector<MachineWarning> check_for_machine(const LayerSource& layers, const BBox3& box,
                                              const MachineProfile& p,
                                              const std::vector<BBox3>* extents) {
  validate(p);
  Problems errors;
  std::vector<MachineWarning> warnings;
  const Vec2 shift = placement_offset(box, p);
  const bool circle = p.bed_shape == BedShape::Circle;
  const bool centred_origin = p.origin == BedOrigin::Center;
  const double x0 = centred_origin ? -p.bed_x / 2 : 0, y0 = centred_origin ? -p.bed_y / 2 : 0;
  const double x1 = x0 + p.bed_x, y1 = y0 + p.bed_y;
  const Vec2 bed_centre{(x0 + x1) / 2, (y0 + y1) / 2};
  const double eps = 1e-6;
  // Extent after placement, for the error message.
  BBox3 placed;
  bool outside = false;
  std::vector<Vec2> tool_offsets;
  // The embedded writer moves the head to design - offset (unless the firmware applies them).
  const bool offsets_apply = p.has_bath() && !p.firmware_offsets;
  const int gradient_tools = p.gradient_tool_count();
  bool mixed = false;
  std::size_t max_materials = 0;
  const bool fdm = p.marlin_family();
  std::size_t next_path = 0;  // in layer order, for `extents`
  layers([&](std::size_t li, const Layer& layer) {
    for (std::size_t pi = 0; pi < layer.paths.size(); ++pi) {
      const Path& path = layer.paths[pi];
      const std::size_t k = next_path++;
      if (path.points.size() < 2) continue;
      if (path.tool < 0 || path.tool >= p.tool_count) {
        errors.add("tool", fmt::format("{} uses tool {} but the machine '{}' has {} tool{} "
                                       "(machine.tools = {}; tools are numbered from 0)",
                                       where(li, pi), path.tool, p.name, p.tool_count,
                                       p.tool_count == 1 ? "" : "s", p.tool_count));
        continue;
      }
      Vec2 toff{0, 0};
      if (offsets_apply) {
        try {
          toff = p.tool_offset(path.tool);
        } catch (const SettingError& e) {
          errors.add("tool_offset",
                     where(li, pi) + ": " + e.message() + " (" + e.where().element + ")");
        }
      }
      if (!path.mixture.empty()) {
        mixed = true;
        max_materials = std::max(max_materials, path.mixture.size());
        // A fraction outside 0..1 would be written as it is (M165 B1.5) and make the
        // firmware's mix whatever it makes of it.
        for (std::size_t m = 0; m < path.mixture.size(); ++m)
          if (!(path.mixture[m] >= -eps && path.mixture[m] <= 1 + eps)) {
            errors.add("mixture", fmt::format("{} has mixture[{}] = {}: each material fraction "
                                              "must be within 0..1",
                                              where(li, pi), m, num(path.mixture[m])));
            break;
          }
      }
      if (path.speed > p.max_speed + eps)
        errors.add("speed", fmt::format("{} is printed at {} mm/s, faster than the machine's "
                                        "speed.max = {} mm/s",
                                        where(li, pi), num(path.speed), num(p.max_speed)));
      if (!fdm && ((path.flow > 0 && std::abs(path.flow - 1) > eps) || path.fan >= 0))
        errors.add("process_flavor",
                   fmt::format("{} sets a {} (a process field) but machine.flavor = {} has no E "
                               "axis and no fan to set: print it on an FDM profile",
                               where(li, pi), path.fan >= 0 ? "fan" : "flow", to_string(p.flavor)));
      if (path.temperature > p.max_nozzle_temperature + eps)
        errors.add(
            "path_temperature",
            fmt::format("{} asks for {} °C, above temperature.max_nozzle = {} °C", where(li, pi),
                        num(path.temperature), num(p.max_nozzle_temperature)));
      auto place = [&](Vec3 q) {
        return Vec3{q.x + shift.x - toff.x, q.y + shift.y - toff.y, q.z};
      };
      // A rectangle: the path's extent placed is its points' placed extent (placing is monotone
      // in each coordinate), and every point is in when both corners are. A NaN, which the
      // extent would not show, and a round bed take each point.
      if (const BBox3 raw = circle    ? BBox3{}
                            : extents ? (*extents)[k]
                                      : path_extent(path.points);
          !circle && !std::isnan(raw.min.x)) {
        const Vec3 lo = place(raw.min), hi = place(raw.max);
        placed.add(lo);
        placed.add(hi);
        outside = outside || !(lo.z >= -eps && hi.z <= p.bed_z + eps && lo.x >= x0 - eps &&
                               hi.x <= x1 + eps && lo.y >= y0 - eps && hi.y <= y1 + eps);
        continue;
      }
      for (const Vec3& q : path.points) {
        const Vec3 at = place(q);
        placed.add(at);
        bool in = at.z >= -eps && at.z <= p.bed_z + eps;
        if (circle)
          in = in && std::hypot(at.x - bed_centre.x, at.y - bed_centre.y) <= p.bed_x / 2 + eps;
        else
          in = in && at.x >= x0 - eps && at.x <= x1 + eps && at.y >= y0 - eps && at.y <= y1 + eps;
        outside = outside || !in;
      }
    }
  });
  if (outside) {
    const std::string area =
        circle ? fmt::format("a circle of diameter {} mm", num(p.bed_x))
               : fmt::format("X {}..{}, Y {}..{}", num(x0), num(x1), num(y0), num(y1));
    errors.add(
        "bed",
        fmt::format("the toolpath spans X {}..{}, Y {}..{}, Z {}..{} mm on the bed but the "
                    "machine '{}' builds in {}, Z 0..{} mm (machine.bed_x/bed_y/bed_z, "
                    "machine.bed_shape, machine.origin; move it with placement.center or "
                    "placement.offset_x/y; placement.lift puts a part below Z 0 on the bed)",
                    num(placed.min.x), num(placed.max.x), num(placed.min.y), num(placed.max.y),
                    num(placed.min.z), num(placed.max.z), p.name, area, num(p.bed_z)));
  }
  if (mixed) {
    if (p.gradient_mode == GradientMode::Mixing &&
        static_cast<int>(max_materials) > p.mixing_inputs) {
      if (p.mixing_inputs < 2)
        errors.add("mixing",
                   fmt::format("the toolpath mixes {} materials but the machine '{}' has no "
                               "mixing hotend (machine.mixing_inputs = 1): use a mixing or "
                               "tool-changer profile (gradient.mode = tools), or slice with "
                               "slice.strategy = 0 to print one material",
                               max_materials, p.name));
      else
        errors.add("mixing", fmt::format("the toolpath mixes {} materials but the hotend of '{}' "
                                         "has machine.mixing_inputs = {}",
                                         max_materials, p.name, p.mixing_inputs));
    }
    if (p.gradient_mode != GradientMode::Mixing && max_materials > 2)
      errors.add("mixing", fmt::format("a {}-material mixture needs a mixing hotend "
                                       "(gradient.mode = mixing); tools and temperature make "
                                       "mixtures of two materials",
                                       max_materials));
    if (p.gradient_mode == GradientMode::Tools) {
      if (gradient_tools > p.tool_count)
        errors.add("tools",
                   fmt::format("gradient.tools = {} but the machine '{}' has {} tool{} "
                               "(machine.tools)",
                               gradient_tools, p.name, p.tool_count, p.tool_count == 1 ? "" : "s"));
      else if (gradient_tools < 2)
        errors.add("tools", fmt::format("gradient.mode = tools needs at least two tools but the "
                                        "machine '{}' has machine.tools = {}",
                                        p.name, p.tool_count));
    }
    if (p.gradient_mode == GradientMode::Temperature)
      for (const auto& [key, t] : {std::pair{"gradient.temperature_a", p.temperature_a},
                                   std::pair{"gradient.temperature_b", p.temperature_b}})
        if (t > p.max_nozzle_temperature + eps)
          errors.add("temperature",
                     fmt::format("{} = {} °C is above temperature.max_nozzle = {} °C", key, num(t),
                                 num(p.max_nozzle_temperature)));
  }
  // The prime line: along a rectangle's front edge, 5 mm clear at each end; on a circle, the
  // chord half-way between the centre and the front (sqrt(3)/2 of the diameter), 5 mm clear.
  const double prime_room = (circle ? p.bed_x * std::sqrt(3.0) / 2 : p.bed_x) - 10;
  if (p.prime_line > 0 && p.prime_line > prime_room + eps)
    errors.add("prime_line", fmt::format("the prime line (gcode.prime_line = {} mm) does not fit "
                                         "on the bed: at most {} mm along its front "
                                         "(machine.bed_x, machine.bed_shape)",
                                         num(p.prime_line), num(std::max(0.0, prime_room))));
  if (p.nozzle_temperature > p.max_nozzle_temperature + eps)
    errors.add("temperature",
               fmt::format("temperature.nozzle = {} °C is above the machine's "
                           "temperature.max_nozzle = {} °C",
                           num(p.nozzle_temperature), num(p.max_nozzle_temperature)));
  if (p.standby_temperature > p.max_nozzle_temperature + eps)
    errors.add("temperature",
               fmt::format("temperature.standby = {} °C is above "
                           "temperature.max_nozzle = {} °C",
                           num(p.standby_temperature), num(p.max_nozzle_temperature)));
  if (p.bed_temperature > p.max_bed_temperature + eps)
    errors.add("temperature", fmt::format("temperature.bed = {} °C is above the machine's "
                                          "temperature.max_bed = {} °C",
                                          num(p.bed_temperature), num(p.max_bed_temperature)));
  for (const auto& [key, v] :
       {std::pair{"speed.print", p.print_speed}, std::pair{"speed.travel", p.travel_speed},
        std::pair{"speed.z", p.z_speed}, std::pair{"retraction.speed", p.retract_speed}})
    if (v > p.max_speed + eps)
      errors.add(key, fmt::format("{} = {} mm/s is faster than the machine's speed.max = {} mm/s",
                                  key, num(v), num(p.max_speed)));
  errors.throw_if_any();
  if (p.marlin_family() && p.nozzle_temperature == 0 &&
      p.gradient_mode != GradientMode::Temperature)
    warnings.push_back({"temperature_unset",
                        "temperature.nozzle is 0: the G-code sets no nozzle temperature and "
                        "relies on the start G-code or the printer"});
  return warnings;
}

std::vector<MachineWarning> check_for_laser(const Toolpath& tp, const LaserProfile& p) {
  return check_for_laser(tp, p, 0);
}

std::vector<MachineWarning> check_for_laser(const Toolpath& tp, const LaserProfile& p,
                                            std::size_t first_layer) {
  Problems errors;
  const double eps = 1e-9;
  BBox3 box;
  for (std::size_t li = 0; li < tp.layers.size(); ++li)
    for (std::size_t pi = 0; pi < tp.layers[li].paths.size(); ++pi) {
      const Path& path = tp.layers[li].paths[pi];
      for (const Vec3& q : path.points) box.add(q);
      if (path.power > p.max_power + eps)
        errors.add("power",
                   fmt::format("{} is scanned at {} W, above laser.max_power = {} W",
                               where(first_layer + li, pi), num(path.power), num(p.max_power)));
      if (path.speed > p.max_speed + eps)
        errors.add("speed",
                   fmt::format("{} is scanned at {} mm/s, above laser.max_speed = {} mm/s",
                               where(first_layer + li, pi), num(path.speed), num(p.max_speed)));
    }
  for (const auto& [key, w] : {std::pair{"laser.contour_power", p.contour_power},
                               std::pair{"laser.hatch_power", p.hatch_power}})
    if (w > p.max_power + eps)
      errors.add(key, fmt::format("{} = {} W is above the laser's laser.max_power = {} W", key,
                                  num(w), num(p.max_power)));
  for (const auto& [key, v] : {std::pair{"laser.contour_speed", p.contour_speed},
                               std::pair{"laser.hatch_speed", p.hatch_speed}})
    if (v > p.max_speed + eps)
      errors.add(key, fmt::format("{} = {} mm/s is above the laser's laser.max_speed = {} mm/s",
                                  key, num(v), num(p.max_speed)));
  if (!box.empty()) {
    const Vec3 size = box.max - box.min;
    if (size.x > p.build_x + eps || size.y > p.build_y + eps || box.max.z > p.build_z + eps)
      errors.add("build", fmt::format("the part measures {} x {} mm and reaches Z {} mm but '{}' "
                                      "builds on a {} x {} mm plate up to Z {} mm "
                                      "(laser.build_x/build_y/build_z)",
                                      num(size.x), num(size.y), num(box.max.z), p.name,
                                      num(p.build_x), num(p.build_y), num(p.build_z)));
  }
  errors.throw_if_any();
  return {};
}

}  // namespace trellis
