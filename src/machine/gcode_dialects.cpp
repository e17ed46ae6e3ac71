// The G-code reader's dialect commands (gcode_reader.hpp): tools, nozzle temperatures per tool
// and mixtures as Marlin, RepRapFirmware and Klipper write them, and the ;TYPE: vocabulary.
#include <cmath>

#include "gcode_lex.hpp"
#include "trellis/core/text.hpp"
#include "trellis/machine/gcode_reader.hpp"

namespace trellis {

using namespace gcode_lex;

namespace {

// "a:b:c" (RepRapFirmware lists) as numbers; false if one does not parse.
// The label of "M486 S<id> A"<label>"" (or A<label> without quotes, to the next blank); empty if
// none.
std::string_view m486_label(std::string_view args) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    if ((args[i] != 'A' && args[i] != 'a') || (i > 0 && args[i - 1] != ' ' && args[i - 1] != '\t'))
      continue;
    std::string_view v = args.substr(i + 1);
    if (!v.empty() && v[0] == '"') {
      v.remove_prefix(1);
      return v.substr(0, v.find('"'));
    }
    return v.substr(0, v.find_first_of(" \t"));
  }
  return {};
}

// Klipper's NAME=<label>, NAME='<label>' or NAME="<label>".
std::string_view unquoted(std::string_view v) {
  if (v.size() >= 2 && (v[0] == '\'' || v[0] == '"') && v.back() == v[0])
    return v.substr(1, v.size() - 2);
  return v;
}

bool number_list(std::string_view s, std::vector<double>& out) {
  out.clear();
  while (!s.empty()) {
    const auto colon = s.find(':');
    const std::string_view item = s.substr(0, colon);
    double v = 0;
    if (!parse_number(item.data(), item.data() + item.size(), v) || !std::isfinite(v)) return false;
    out.push_back(v);
    if (colon == std::string_view::npos) break;
    s.remove_prefix(colon + 1);
  }
  return !out.empty();
}

}  // namespace

// ;TYPE: names, both ways. PrusaSlicer's vocabulary where it has the role (Cura's names are read
// too); Trellis' own roles (Strut, Contour, Handle) under their own names. See docs/gcode.md.
const char* gcode_type_name(PathRole role) {
  switch (role) {
    case PathRole::Perimeter:
      return "Perimeter";
    case PathRole::Infill:
      return "Internal infill";
    case PathRole::Skin:
      return "Solid infill";
    case PathRole::Purge:
      return "Wipe tower";
    case PathRole::Strut:
      return "Strut";
    case PathRole::Contour:
      return "Contour";
    case PathRole::Handle:
      return "Handle";
    case PathRole::Hatch:
      return "Hatch";
    case PathRole::Nonplanar:
      return "Non-planar";
    case PathRole::Other:
      break;
  }
  return "Custom";
}

PathRole role_from_gcode_type(std::string_view t) {
  t = trim(t);
  auto has = [&](std::string_view w) { return t.find(w) != t.npos; };
  // Cura: WALL-OUTER, WALL-INNER, SKIN, FILL, SUPPORT, SKIRT, PRIME-TOWER; PrusaSlicer: External
  // perimeter, Perimeter, Overhang perimeter, Solid infill, Top solid infill, Bridge infill,
  // Internal infill, Gap fill, Skirt/Brim, Support material, Wipe tower, Custom.
  if (has("WALL") || has("erimeter")) return PathRole::Perimeter;
  if (has("SKIN") || has("olid infill") || has("ridge infill") || has("Gap fill"))
    return PathRole::Skin;
  if (has("FILL") || has("nfill")) return PathRole::Infill;
  if (has("ipe tower") || has("PRIME-TOWER") || has("urge")) return PathRole::Purge;
  if (has("STRUT") || has("trut")) return PathRole::Strut;
  if (has("ontour")) return PathRole::Contour;
  if (has("andle")) return PathRole::Handle;
  if (has("atch")) return PathRole::Hatch;
  if (has("on-planar") || has("onplanar")) return PathRole::Nonplanar;
  return PathRole::Other;
}

void GcodeScanner::set_temperature(int tool, double t) {
  if (tool < 0 || tool > 255) return bad("tool number out of range");
  if (tool_temp_.size() <= static_cast<std::size_t>(tool))
    tool_temp_.resize(tool + 1, std::nan(""));
  tool_temp_[tool] = t;
  if (tool == tool_ && !(t == reported_temp_)) {
    reported_temp_ = t;
    sink_.temperature(t);
  }
}

void GcodeScanner::select_tool(int tool) {
  tool_ = tool;
  update_offset();
  sink_.tool_change(tool);
  if (static_cast<std::size_t>(tool) < tool_temp_.size() && std::isfinite(tool_temp_[tool]) &&
      !(tool_temp_[tool] == reported_temp_)) {
    reported_temp_ = tool_temp_[tool];
    sink_.temperature(reported_temp_);
  }
  if (static_cast<std::size_t>(tool) < tool_mix_.size() && !tool_mix_[tool].empty())
    sink_.mixture(tool_mix_[tool]);
}

void GcodeScanner::set_mixture(int tool, std::vector<double> mix) {
  if (tool < 0 || tool > 255) return bad("tool number out of range");
  if (tool_mix_.size() <= static_cast<std::size_t>(tool)) tool_mix_.resize(tool + 1);
  tool_mix_[tool] = mix;
  if (tool == tool_) sink_.mixture(mix);
}

void GcodeScanner::mcode(int code, std::string_view args) {
  // A parameter's number, or NaN when it is absent; a bad number is a bad line.
  bool ok = true;
  auto num = [&](std::string_view key) {
    const std::string_view v = param(args, key);
    double x = 0;
    if (v.empty()) return std::nan("");
    std::string_view n = v.substr(0, v.find_first_of("*:"));
    if (!parse_number(n.data(), n.data() + n.size(), x) || !std::isfinite(x)) {
      ok = false;
      return std::nan("");
    }
    return x;
  };
  auto tool_param = [&](std::string_view key) {
    const double t = num(key);
    return std::isfinite(t) ? static_cast<int>(t) : tool_;
  };
  switch (code) {
    case 82:
      abs_e_ = true;
      return;
    case 83:
      abs_e_ = false;
      return;
    case 104:
    case 109:
    case 568: {  // Marlin / Klipper M104 S [T]; M109 S or R; RepRapFirmware M568 P<tool> S<t>
      double t = num("S");
      if (!std::isfinite(t) && code == 109) t = num("R");
      const int tool = tool_param(code == 568 ? "P" : "T");
      if (!ok) return bad("bad number in '" + std::string(args.substr(0, 40)) + "'");
      if (!std::isfinite(t)) return;
      if (t < 0 || t > 1000)
        return bad("bad temperature in '" + std::string(args.substr(0, 30)) + "'");
      if (code != 568 || num("A") != 0) sink_.heater(tool, t, code == 109);
      return set_temperature(tool, t);
    }
    case 140:
    case 190: {  // bed: M140 S<t>, M190 S<t> (or R<t>) waits
      double t = num("S");
      if (!std::isfinite(t) && code == 190) t = num("R");
      if (!ok || (std::isfinite(t) && (t < 0 || t > 1000)))
        return bad("bad temperature in '" + std::string(args.substr(0, 30)) + "'");
      sink_.heater(PrintTimeEstimator::kBed, t, code == 190);
      return;
    }
    case 116: {  // RepRapFirmware: wait for every heater, or tool P's
      const double p = num("P");
      if (!ok) return bad("bad number in '" + std::string(args.substr(0, 40)) + "'");
      sink_.heater(std::isfinite(p) ? static_cast<int>(p) : GcodeSink::kAllHeaters, std::nan(""),
                   true);
      return;
    }
    case 201:
    case 203:
    case 204:
    case 205:
      return limit_command(code, args);
    case 165: {  // Marlin mixing: A B C D H I
      std::vector<double> mix;
      for (const char* k : {"A", "B", "C", "D", "H", "I"}) {
        const double v = num(k);
        if (!std::isfinite(v)) break;
        mix.push_back(v);
      }
      if (!ok) return bad("bad number in '" + std::string(args.substr(0, 40)) + "'");
      if (!mix.empty()) set_mixture(tool_, std::move(mix));
      return;
    }
    case 163: {  // Marlin: M163 S<input> P<weight>, committed by M164
      const double i = num("S"), w = num("P");
      if (!ok || !std::isfinite(i) || !std::isfinite(w) || i < 0 || i > 15)
        return bad("bad M163 '" + std::string(args.substr(0, 40)) + "'");
      if (m163_.size() <= static_cast<std::size_t>(i))
        m163_.resize(static_cast<std::size_t>(i) + 1, 0);
      m163_[static_cast<std::size_t>(i)] = w;
      return;
    }
    case 164: {
      double sum = 0;
      for (double w : m163_) sum += w;
      if (sum > 0) {
        std::vector<double> mix = m163_;
        for (double& w : mix) w /= sum;
        set_mixture(tool_, std::move(mix));
      }
      m163_.clear();
      return;
    }
    case 567: {  // RepRapFirmware: M567 P<tool> E<a>:<b>:...
      const int tool = tool_param("P");
      std::vector<double> mix;
      if (!ok || !number_list(param(args, "E"), mix))
        return bad("bad mix ratio in '" + std::string(args.substr(0, 40)) + "'");
      return set_mixture(tool, std::move(mix));
    }
    case 486: {  // object labels: M486 S<id> [A"<label>"], M486 S-1 (M486 T<count> and P/U:
                 // cancels, not read)
      const double id = num("S");
      if (!ok) return bad("bad number in '" + std::string(args.substr(0, 40)) + "'");
      if (!std::isfinite(id)) return;
      if (id == -1) return sink_.object({});
      if (id < 0 || id > 9999 || id != std::floor(id))
        return bad("bad object id in '" + std::string(args.substr(0, 40)) + "'");
      const auto k = static_cast<std::size_t>(id);
      if (object_labels_.size() <= k) object_labels_.resize(k + 1);
      const std::string_view label = m486_label(args);
      if (!label.empty()) object_labels_[k] = std::string(label);
      if (object_labels_[k].empty()) object_labels_[k] = std::to_string(k);
      return sink_.object(object_labels_[k]);
    }
    default:
      return;
  }
}

// The motion limits of the time estimate: M201 X Y Z E (max accelerations), M203 (max feeds:
// mm/s for Marlin and Klipper, mm/min for RepRapFirmware, known from our header), M204 P|S
// (printing) R (retraction) T (travel), M205 X Y Z E (jerk, mm/s; RepRapFirmware writes its jerk as
// M566 in mm/min, not read).
void GcodeScanner::limit_command(int code, std::string_view args) {
  bool changed = false, ok = true;
  auto value = [&](std::string_view key, double& into, double scale) {
    const std::string_view v = param(args, key);
    if (v.empty()) return;
    double x = 0;
    if (!parse_number(v.data(), v.data() + v.size(), x) || !std::isfinite(x) || x < 0) {
      ok = false;
      return;
    }
    into = x * scale;
    changed = true;
  };
  static constexpr const char* kAxes[] = {"X", "Y", "Z", "E"};
  for (int i = 0; i < 4; ++i) {
    if (code == 201) value(kAxes[i], limits_.max_acceleration[static_cast<std::size_t>(i)], 1);
    if (code == 203)
      value(kAxes[i], limits_.max_feed[static_cast<std::size_t>(i)], reprap_header_ ? 1.0 / 60 : 1);
    if (code == 205) value(kAxes[i], limits_.jerk[static_cast<std::size_t>(i)], 1);
  }
  if (code == 204) {
    value("S", limits_.acceleration, 1);
    value("P", limits_.acceleration, 1);
    value("R", limits_.retract_acceleration, 1);
    value("T", limits_.travel_acceleration, 1);
  }
  if (!ok) return bad("bad number in '" + std::string(args.substr(0, 40)) + "'");
  if (changed) sink_.limits(limits_);
}

// Klipper's extended commands the reader needs: ACTIVATE_EXTRUDER EXTRUDER=extruder<N> and
// SET_HEATER_TEMPERATURE HEATER=extruder<N> TARGET=<t> (extruder = 0, extruder1 = 1, ...).
void GcodeScanner::extended(std::string_view s) {
  const auto blank = s.find_first_of(" \t");
  const std::string_view name = s.substr(0, blank);
  const std::string_view args =
      blank == std::string_view::npos ? std::string_view{} : s.substr(blank);
  auto extruder = [&](std::string_view v) {
    if (v.size() < 8 || v.substr(0, 8) != "extruder") return -1;
    if (v.size() == 8) return 0;
    double n = 0;
    if (!parse_number(v.data() + 8, v.data() + v.size(), n) || n < 0 || n > 255) return -1;
    return static_cast<int>(n);
  };
  if (name == "ACTIVATE_EXTRUDER") {
    const int t = extruder(param(args, "EXTRUDER="));
    if (t < 0) return bad("unknown extruder in '" + std::string(s.substr(0, 60)) + "'");
    if (t != tool_) select_tool(t);
  } else if (name == "EXCLUDE_OBJECT_START" || name == "EXCLUDE_OBJECT_END") {
    const std::string_view label = unquoted(param(args, "NAME="));
    if (name.back() == 'T' && label.empty())
      return bad("EXCLUDE_OBJECT_START without NAME= in '" + std::string(s.substr(0, 60)) + "'");
    sink_.object(name.back() == 'T' ? label : std::string_view{});
  } else if (name == "TEMPERATURE_WAIT") {
    const std::string_view sensor = param(args, "SENSOR="), v = param(args, "MINIMUM=");
    const int t = sensor == "heater_bed" ? PrintTimeEstimator::kBed : extruder(sensor);
    double c = std::nan("");
    if (!v.empty() && (!parse_number(v.data(), v.data() + v.size(), c) || !std::isfinite(c)))
      return bad("bad temperature in '" + std::string(s.substr(0, 60)) + "'");
    if (t >= PrintTimeEstimator::kBed) sink_.heater(t, c, true);
  } else if (name == "SET_VELOCITY_LIMIT") {
    const std::string_view v = param(args, "ACCEL=");
    double a = 0;
    if (!v.empty() && parse_number(v.data(), v.data() + v.size(), a) && std::isfinite(a) &&
        a >= 0) {
      limits_.acceleration = a;
      limits_.travel_acceleration = limits_.retract_acceleration = 0;
      sink_.limits(limits_);
    }
  } else if (name == "SET_HEATER_TEMPERATURE") {
    const std::string_view heater_name = param(args, "HEATER=");
    const int t = extruder(heater_name);
    if (heater_name == "heater_bed") {
      const std::string_view v = param(args, "TARGET=");
      double c = 0;
      if (!v.empty() && parse_number(v.data(), v.data() + v.size(), c) && std::isfinite(c))
        sink_.heater(PrintTimeEstimator::kBed, c, false);
      return;
    }
    if (t < 0) return;  // a chamber
    const std::string_view v = param(args, "TARGET=");
    double c = 0;
    if (v.empty())
      c = 0;
    else if (!parse_number(v.data(), v.data() + v.size(), c) || !std::isfinite(c) || c < 0 ||
             c > 1000)
      return bad("bad temperature in '" + std::string(s.substr(0, 60)) + "'");
    sink_.heater(t, c, false);
    set_temperature(t, c);
  }
}

}  // namespace trellis
