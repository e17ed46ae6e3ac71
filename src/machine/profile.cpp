#include "trellis/machine/profile.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

using P = MachineProfile;

namespace {

// Each choice's names, in its enum's order.
constexpr std::array kFlavorNames =
    std::to_array<const char*>({"marlin", "reprap", "klipper", "pneumatic", "embedded"});
constexpr std::array kFirmwareNames = std::to_array<const char*>({"", "prusa"});
constexpr std::array kBedShapeNames = std::to_array<const char*>({"rectangle", "circle"});
constexpr std::array kBedOriginNames = std::to_array<const char*>({"corner", "center"});
constexpr std::array kGradientModeNames =
    std::to_array<const char*>({"mixing", "tools", "temperature"});
constexpr std::array kFlowModelNames = std::to_array<const char*>({"", "pla", "tpu"});
constexpr std::array kEmbeddedDriveNames = std::to_array<const char*>({"pressure", "syringe"});
constexpr std::array kPurgePositionNames = std::to_array<const char*>({"auto", "fixed"});
constexpr std::array kGcodeEncodingNames = std::to_array<const char*>({"none", "meatpack"});
constexpr std::array kMixingDialectNames =
    std::to_array<const char*>({"m165", "m163", "m567", "template"});

template <class E, std::size_t N>
const char* name_of(E v, const std::array<const char*, N>& names) {
  return names.at(static_cast<std::size_t>(v));
}

// An enum member as a table entry: its names, read and written by index.
template <class E, std::size_t N>
MachineChoice choice(E P::*member, const std::array<const char*, N>& names) {
  return {std::vector<const char*>(names.begin(), names.end()),
          [member](const P& p) { return static_cast<int>(p.*member); },
          [member](P& p, int i) { p.*member = static_cast<E>(i); }};
}

}  // namespace

const char* to_string(Flavor v) {
  return name_of(v, kFlavorNames);
}
const char* to_string(Firmware v) {
  return name_of(v, kFirmwareNames);
}
const char* to_string(BedShape v) {
  return name_of(v, kBedShapeNames);
}
const char* to_string(BedOrigin v) {
  return name_of(v, kBedOriginNames);
}
const char* to_string(GradientMode v) {
  return name_of(v, kGradientModeNames);
}
const char* to_string(FlowModel v) {
  return name_of(v, kFlowModelNames);
}
const char* to_string(EmbeddedDrive v) {
  return name_of(v, kEmbeddedDriveNames);
}
const char* to_string(PurgePosition v) {
  return name_of(v, kPurgePositionNames);
}
const char* to_string(MixingDialect v) {
  return name_of(v, kMixingDialectNames);
}

namespace {

template <class E, std::size_t N>
E from_name(const std::string& name, const std::array<const char*, N>& names, const char* key) {
  std::string all;
  for (std::size_t i = 0; i < N; ++i) {
    if (name == names[i]) return static_cast<E>(i);
    all += std::string(i ? ", " : "") + names[i];
  }
  throw SettingError("unknown value '" + name + "' (expected one of " + all + ")", {"", 0, key});
}

}  // namespace

Flavor flavor_from_string(const std::string& name) {
  return from_name<Flavor>(name, kFlavorNames, "machine.flavor");
}
MixingDialect mixing_dialect_from_string(const std::string& name) {
  return from_name<MixingDialect>(name, kMixingDialectNames, "gradient.dialect");
}

const std::vector<SettingDecl>& machine_settings() {
  static const std::vector<SettingDecl> table = {
      {"machine.name", "", "printer name, written into headers", 0, 0, &P::name},
      {"machine.flavor", "",
       "G-code dialect: marlin (E values), reprap (RepRapFirmware: M568/M116 heaters), klipper "
       "(SET_HEATER_TEMPERATURE, ACTIVATE_EXTRUDER), pneumatic (valve + pressure) or embedded "
       "(pneumatic in a support bath: vertical lifts out of the bath for travel, tools with "
       "offsets)",
       0, 0, choice(&P::flavor, kFlavorNames)},
      {"machine.firmware", "",
       "the firmware, where an output format depends on it: prusa (Prusa's Buddy firmware: MK4, "
       "MK3.9, XL, MINI, Core One; reads binary G-code) or empty (not declared)",
       0, 0, choice(&P::firmware, kFirmwareNames)},
      {"machine.printer_model", "",
       "the printer model as Prusa's firmware names it (MK4S, MK4, MK3.9, XL, MINI, COREONE): "
       "written as printer_model in binary G-code's printer metadata, which the firmware checks "
       "against the printer; empty = not written",
       0, 0, &P::printer_model},
      {"machine.bed_x", "mm", "build area in X (a circular bed: its diameter)", 1, 10000,
       &P::bed_x},
      {"machine.bed_y", "mm", "build area in Y (ignored for a circular bed)", 1, 10000, &P::bed_y},
      {"machine.bed_z", "mm", "build height", 1, 10000, &P::bed_z},
      {"machine.bed_shape", "", "shape of the build area: rectangle or circle (diameter bed_x)", 0,
       0, choice(&P::bed_shape, kBedShapeNames)},
      {"machine.origin", "",
       "where X0 Y0 is: corner (the bed runs 0..bed_x) or center (-bed_x/2..bed_x/2; delta "
       "printers)",
       0, 0, choice(&P::origin, kBedOriginNames)},
      {"machine.tools", "",
       "tools or nozzles the machine has (tool changer, multi-nozzle head); paths for a tool it "
       "lacks are refused",
       1, 64, &P::tool_count},
      {"machine.mixing_inputs", "",
       "filament inputs of a mixing hotend (M165 A B C ...); 1 = no mixing hotend", 1, 6,
       &P::mixing_inputs},
      {"machine.extruder_clearance_radius", "mm",
       "sequential plates (plate.sequence = parts): parts at least this far apart, so the "
       "printhead around the nozzle misses finished parts; 0 = not known (sequential refused)",
       0, 10000, &P::extruder_clearance_radius},
      {"machine.extruder_clearance_height", "mm",
       "sequential plates: height of the gantry (X carriage) above the nozzle tip; only the last "
       "part may be taller; 0 = not known (sequential refused)",
       0, 10000, &P::extruder_clearance_height},
      {"placement.center", "",
       "move the part's XY centre to the bed centre (false: design coordinates are bed "
       "coordinates)",
       0, 0, &P::center, "center"},
      {"placement.lift", "",
       "a toolpath reaching below Z 0 is lifted so that its lowest point is on the bed (false: "
       "below the bed is an error)",
       0, 0, &P::lift},
      {"placement.offset_x", "mm", "X offset added after centring", -10000, 10000, &P::offset_x},
      {"placement.offset_y", "mm", "Y offset added after centring", -10000, 10000, &P::offset_y},
      {"extrusion.nozzle_diameter", "mm", "nozzle diameter d_n (Eq. 4)", 0.01, 10,
       &P::nozzle_diameter},
      {"extrusion.filament_diameter", "mm",
       "filament diameter f_d (Eq. 4; a syringe: the barrel bore)", 0.1, 100,
       &P::filament_diameter},
      {"extrusion.layer_height", "mm", "layer thickness LT when a path has none (Eq. 4)", 0.001, 10,
       &P::layer_height, "layer-height"},
      {"extrusion.multiplier", "", "extrusion multiplier EM (Eq. 4)", 0, 10,
       &P::extrusion_multiplier},
      {"extrusion.k", "", "correction factor k for the bead shape (Eq. 4)", 0, 10, &P::k},
      {"extrusion.relative_e", "", "relative E (M83) instead of absolute (M82)", 0, 0,
       &P::relative_e},
      {"extrusion.down_flow", "",
       "flow factor for steep downward moves, \"deg,factor;...\": a segment descending at least "
       "deg below horizontal gets factor (E x factor; pneumatic/embedded: feed / factor)",
       0, 0, &P::down_flow},
      {"speed.print", "mm/s", "printing speed", 0.01, 1000, &P::print_speed, "speed"},
      {"speed.travel", "mm/s", "travel speed", 0.01, 2000, &P::travel_speed},
      {"speed.z", "mm/s", "speed of Z moves", 0.01, 1000, &P::z_speed},
      {"speed.acceleration", "mm/s²",
       "acceleration for print-time estimates (trapezoidal moves, as the firmware plans them), 0 "
       "= feed rates only",
       0, 100000, &P::acceleration},
      {"speed.jerk", "mm/s",
       "print-time estimates: the speed change a corner takes without slowing (Marlin's classic "
       "jerk per axis)",
       0, 1000, &P::jerk},
      {"speed.max", "mm/s", "fastest feed the machine moves at; faster settings are refused", 0.01,
       10000, &P::max_speed},
      {"speed.short_path_factor", "", "speed factor for short paths (paper: 0.6)", 0.01, 10,
       &P::short_path_factor},
      {"speed.short_path_segments", "", "paths with fewer segments than this are short", 0, 1000000,
       &P::short_path_segments},
      {"temperature.nozzle", "°C", "nozzle temperature, 0 = leave unset", 0, 500,
       &P::nozzle_temperature},
      {"temperature.bed", "°C", "bed temperature, 0 = leave unset", 0, 200, &P::bed_temperature},
      {"temperature.fan", "%", "part-cooling fan", 0, 100, &P::fan_percent},
      {"temperature.standby", "°C",
       "temperature of idle tools on a multi-tool machine; 0 = they stay at the printing "
       "temperature",
       0, 500, &P::standby_temperature},
      {"temperature.max_nozzle", "°C", "hottest nozzle temperature the machine allows", 0, 500,
       &P::max_nozzle_temperature},
      {"temperature.max_bed", "°C", "hottest bed temperature the machine allows", 0, 200,
       &P::max_bed_temperature},
      {"temperature.settle", "s",
       "dwell (G4) after each nozzle temperature change a process field (fprocess) makes, so "
       "the melt reaches it before printing on (foaming filament); counted in the time estimate",
       0, 600, &P::settle_time},
      {"retraction.length", "mm", "filament retracted before travel", 0, 50, &P::retract_length},
      {"retraction.speed", "mm/s", "retraction speed", 0.01, 500, &P::retract_speed},
      {"retraction.z_hop", "mm", "lift during travel", 0, 50, &P::z_hop},
      {"retraction.min_travel", "mm", "no retraction or lift for shorter travel", 0, 1000,
       &P::min_travel},
      {"retraction.inside_max", "mm",
       "a travel the slicer keeps inside the part (crossing no outer wall) retracts and lifts "
       "only when longer than this; 0 = never",
       0, 100000, &P::inside_max},
      {"flow.pre", "mm", "extra filament primed at each path start (marlin)", 0, 50, &P::pre_flow},
      {"flow.post", "mm", "extra filament pushed at each path end (marlin)", 0, 50, &P::post_flow},
      {"flow.pre_dwell", "s", "dwell at each path start after priming / opening", 0, 60,
       &P::pre_flow_dwell},
      {"flow.post_dwell", "s", "dwell at each path end before retracting / closing", 0, 60,
       &P::post_flow_dwell},
      {"pneumatic.pressure", "kPa", "extrusion pressure per path", 0, 10000, &P::pressure},
      {"pneumatic.pressure_command", "",
       "command setting the pressure, {pressure} is replaced; empty = none", 0, 0,
       &P::pressure_command},
      {"pneumatic.valve_on", "", "command opening the valve", 0, 0, &P::valve_on},
      {"pneumatic.valve_off", "", "command closing the valve", 0, 0, &P::valve_off},
      {"embedded.bath_surface", "mm",
       "Z of the support bath surface; travel lifts out of it (the part top if lower)", -10000,
       10000, &P::bath_surface},
      {"embedded.travel_clearance", "mm", "travel this far above the bath surface", 0, 1000,
       &P::travel_clearance},
      {"embedded.node_dwell", "s", "dwell at every node inside a path", 0, 60, &P::node_dwell},
      {"embedded.node_overlap", "mm", "extend each path end this far past its end node", 0, 10,
       &P::node_overlap},
      {"embedded.tool_offsets", "mm",
       "where each nozzle sits relative to nozzle 0, \"x,y;x,y;...\" (tool 0 first): the writer "
       "puts nozzle t on design XY by moving the head to design - offset, unless "
       "embedded.firmware_offsets",
       0, 0, &P::tool_offsets},
      {"embedded.firmware_offsets", "",
       "the firmware applies each tool's offset itself (tool definitions, G10): the writer "
       "commands design XY and leaves the offsets to it",
       0, 0, &P::firmware_offsets},
      {"embedded.floor_z", "mm",
       "Z of the bath's floor (the container bottom) above machine Z0: the design's Z 0, where "
       "the first strut is printed; below embedded.bath_surface",
       0, 10000, &P::floor_z},
      {"embedded.tool_pressures", "kPa",
       "pressure per tool as \"p0,p1,...\" (replaces pneumatic.pressure)", 0, 0,
       &P::tool_pressures},
      {"embedded.tool_change", "", "command selecting a tool; {tool} is its number", 0, 0,
       &P::tool_change},
      {"embedded.drive", "",
       "how ink is pushed: pressure (valve on/off, pneumatic.pressure) or syringe (a stepper "
       "syringe pump on E, Eq. 4 with extrusion.filament_diameter = the plunger diameter)",
       0, 0, choice(&P::embedded_drive, kEmbeddedDriveNames)},
      {"embedded.bath_travel", "mm",
       "travel moves up to this long stay inside the bath instead of lifting out (e.g. between "
       "non-planar layers); tool changes always lift",
       0, 10000, &P::bath_travel},
      {"embedded.raise_idle", "", "command raising the nozzle {tool} that goes idle; empty = none",
       0, 0, &P::raise_idle},
      {"gradient.mode", "",
       "how a path's mixture is made: mixing (M165 A.. B..), tools (T<n>, the nearest of "
       "gradient.tools) or temperature (M104 S<t>, foaming filament)",
       0, 0, choice(&P::gradient_mode, kGradientModeNames)},
      {"gradient.tools", "",
       "tools: how many tools hold the gradient, tool 0 = material A ... last = material B (0 = "
       "all of machine.tools)",
       0, 64, &P::gradient_tools},
      {"gradient.temperature_a", "°C", "temperature: nozzle temperature for 100% material A", 0,
       500, &P::temperature_a},
      {"gradient.temperature_b", "°C", "temperature: nozzle temperature for 100% material B", 0,
       500, &P::temperature_b},
      {"gradient.flow", "",
       "temperature: flow compensation M221 S<F> with each M104: pla (FGM paper Eq. 3) or tpu "
       "(Eq. 4); empty = none",
       0, 0, choice(&P::flow_model, kFlowModelNames)},
      {"gradient.lookahead", "mm",
       "issue each mixture change this much printed path before the region (dead volume, FGM "
       "paper A.1: L = V_melt / (h(w-h) + pi h^2/4))",
       0, 100000, &P::lookahead, "lookahead"},
      {"gradient.dialect", "",
       "mixing: how a mixture is commanded: m165 (Marlin M165 A B C), m163 (Marlin M163 S<i> "
       "P<share> per input + M164 S0, virtual tool 0), m567 (RepRapFirmware M567 P0 E<a>:<b>) "
       "or template (gradient.template)",
       0, 0, choice(&P::gradient_dialect, kMixingDialectNames)},
      {"gradient.template", "",
       "mixing, dialect template: the command for one mixture, {a} {b} {c} … replaced by each "
       "input's share (0..1), other {setting} placeholders as in gcode.start; e.g. a Klipper "
       "mixing macro or an ink writer's valves",
       0, 0, &P::gradient_template},
      {"gradient.quantize", "",
       "tools: allow more palette colours than tools, each printed by the nearest tool (the "
       "palette becomes the tools' mixes and the error reported is theirs); off = an error",
       0, 0, &P::quantize},
      {"purge.melt_volume", "mm³",
       "Strategy 1 and tool changers: dead volume V_melt flushed into the prime tower after each "
       "colour change, as a purge of L = V/(h(w-h)+pi h^2/4) mm (0 = no tower)",
       0, 100000, &P::melt_volume},
      {"purge.threshold", "", "Strategy 1: mixture change (0..1) above which a purge is printed", 0,
       1, &P::purge_threshold},
      {"purge.position", "",
       "where the prime tower stands: auto (beside the part on free bed space, clearance apart) "
       "or fixed (centred at purge.x, purge.y)",
       0, 0, choice(&P::purge_position, kPurgePositionNames)},
      {"purge.x", "mm", "prime tower centre X when purge.position = fixed (design coordinates)",
       -10000, 10000, &P::purge_x},
      {"purge.y", "mm", "prime tower centre Y when purge.position = fixed", -10000, 10000,
       &P::purge_y},
      {"purge.side", "mm",
       "smallest prime tower side; the tower grows until its busiest layer holds that layer's "
       "purges",
       1, 1000, &P::purge_side},
      {"purge.clearance", "mm", "gap between the prime tower and the part's footprint", 0, 1000,
       &P::purge_clearance},
      {"purge.density_a", "g/cm³", "density of material A (tower mass per colour)", 0.01, 30,
       &P::density_a},
      {"purge.density_b", "g/cm³", "density of material B", 0.01, 30, &P::density_b},
      {"purge.density_c", "g/cm³", "density of material C (three-material designs)", 0.01, 30,
       &P::density_c},
      {"gcode.start", "", "start template; {section.key} or {key} inserts a setting", 0, 0,
       &P::start_gcode},
      {"gcode.end", "", "end template", 0, 0, &P::end_gcode},
      {"gcode.extension", "", "default output extension (.gcode for marlin, .nc for pneumatic)", 0,
       0, &P::file_extension},
      {"gcode.thumbnails", "px",
       "PNG previews embedded in the G-code header for printer screens and front ends, "
       "\"WxH,WxH\" (PrusaSlicer's thumbnail format); empty = none",
       0, 0, &P::thumbnails},
      {"gcode.binary", "",
       "write PrusaSlicer's binary G-code (.bgcode: metadata, PNG thumbnails and Heatshrink-"
       "compressed G-code blocks with CRC32, as Prusa's firmware reads them) instead of text; "
       "machines with machine.firmware = prusa only; an output named .bgcode is binary without "
       "it",
       0, 0, &P::binary_gcode, "binary-gcode"},
      {"gcode.binary_encoding", "",
       "binary G-code's G-code blocks: meatpack (Marlin's MeatPack 4-bit packing before the "
       "compression, comments kept, as PrusaSlicer 2.7+ writes them) or none (plain text)",
       0, 0, choice(&P::binary_encoding, kGcodeEncodingNames)},
      {"gcode.prime_line", "mm",
       "prime line: this much line drawn along the bed's front edge, 5 mm in, before the first "
       "layer (valve open for pneumatic machines; not in a bath); 0 = none",
       0, 1000, &P::prime_line},
      {"gcode.label_objects", "",
       "build plates: each part's moves between the firmware's object start and end, so the "
       "printer can cancel one part (M486 S<id> A\"<label>\" ... M486 S-1 for Marlin, Prusa and "
       "RepRapFirmware; EXCLUDE_OBJECT_DEFINE / _START / _END for Klipper)",
       0, 0, &P::label_objects},
  };
  return table;
}

namespace {

// Numbers of a list "a,b;c,d" split at `sep` and ','.
std::vector<std::vector<double>> number_groups(const std::string& text, char sep, const char* key) {
  std::vector<std::vector<double>> out;
  if (text.find_first_not_of(" \t") == std::string::npos) return out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const auto end = std::min(text.find(sep, start), text.size());
    std::vector<double> group;
    std::size_t p = start;
    while (p <= end) {
      const auto comma = std::min(text.find(',', p), end);
      std::string item = text.substr(p, comma - p);
      item.erase(0, item.find_first_not_of(" \t"));
      item.erase(item.find_last_not_of(" \t") + 1);
      double v = 0;
      const auto r = std::from_chars(item.data(), item.data() + item.size(), v);
      if (item.empty() || r.ec != std::errc() || r.ptr != item.data() + item.size() ||
          !std::isfinite(v) || std::abs(v) > 1e5)
        throw SettingError("'" + item + "' is not a number in \"" + text + "\"", {"", 0, key});
      group.push_back(v);
      p = comma + 1;
    }
    out.push_back(std::move(group));
    if (end == text.size()) break;
    start = end + 1;
  }
  return out;
}

}  // namespace

Vec2 MachineProfile::tool_offset(int tool) const {
  const auto groups = number_groups(tool_offsets, ';', "embedded.tool_offsets");
  for (const auto& g : groups)
    if (g.size() != 2)
      throw SettingError("each tool offset is \"x,y\"", {"", 0, "embedded.tool_offsets"});
  if (tool < 0 || static_cast<std::size_t>(tool) >= groups.size()) {
    if (groups.empty() || tool == 0) return {0, 0};
    throw SettingError("no offset for tool " + std::to_string(tool) + " (" +
                           std::to_string(groups.size()) + " given)",
                       {"", 0, "embedded.tool_offsets"});
  }
  return {groups[static_cast<std::size_t>(tool)][0], groups[static_cast<std::size_t>(tool)][1]};
}

double MachineProfile::tool_pressure(int tool) const {
  const auto groups = number_groups(tool_pressures, ';', "embedded.tool_pressures");
  if (groups.empty()) return pressure;
  const auto& list = groups.front();
  if (groups.size() != 1 || tool < 0 || static_cast<std::size_t>(tool) >= list.size())
    throw SettingError("no pressure for tool " + std::to_string(tool),
                       {"", 0, "embedded.tool_pressures"});
  return list[static_cast<std::size_t>(tool)];
}

std::vector<std::pair<double, double>> MachineProfile::down_flow_table() const {
  std::vector<std::pair<double, double>> out;
  for (const auto& g : number_groups(down_flow, ';', "extrusion.down_flow")) {
    if (g.size() != 2 || !(g[0] >= 0 && g[0] <= 90) || !(g[1] > 0 && g[1] <= 10))
      throw SettingError(
          "each entry is \"angle,factor\" with angle 0..90 degrees and factor in (0, 10]",
          {"", 0, "extrusion.down_flow"});
    out.emplace_back(g[0], g[1]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

namespace {

std::string number_text(double v) {
  char buf[32];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, ptr);
}

}  // namespace

std::vector<std::pair<int, int>> MachineProfile::thumbnail_sizes() const {
  std::vector<std::pair<int, int>> out;
  std::size_t a = 0;
  while (a < thumbnails.size()) {
    std::size_t b = thumbnails.find(',', a);
    if (b == std::string::npos) b = thumbnails.size();
    const std::string item = thumbnails.substr(a, b - a);
    const auto x = item.find('x');
    int w = 0, h = 0;
    const bool ok = x != std::string::npos &&
                    std::from_chars(item.data(), item.data() + x, w).ptr == item.data() + x &&
                    std::from_chars(item.data() + x + 1, item.data() + item.size(), h).ptr ==
                        item.data() + item.size() &&
                    w >= 1 && h >= 1 && w <= 1024 && h <= 1024;
    if (!ok)
      throw SettingError(
          "thumbnail size '" + item + "' is not WxH with 1..1024 pixels each way (e.g. 220x124)",
          {"", 0, "gcode.thumbnails"});
    out.push_back({w, h});
    a = b + 1;
  }
  return out;
}

void validate(const MachineProfile& p) {
  p.thumbnail_sizes();
  p.tool_offset(0);
  p.tool_pressure(0);
  p.down_flow_table();
  if (p.floor_z > 0 && p.bath_surface > 0 && p.floor_z >= p.bath_surface)
    throw SettingError("the bath's floor (embedded.floor_z = " + number_text(p.floor_z) +
                           " mm) must be below its surface (embedded.bath_surface = " +
                           number_text(p.bath_surface) + " mm)",
                       {"", 0, "embedded.floor_z"});
  if (p.floor_z > 0 && !p.has_bath())
    throw SettingError(
        std::string("embedded.floor_z is for bath machines (machine.flavor = embedded), not ") +
            to_string(p.flavor),
        {"", 0, "embedded.floor_z"});
  if (p.floor_z >= p.bed_z)
    throw SettingError("the bath's floor (embedded.floor_z = " + number_text(p.floor_z) +
                           " mm) is not below the machine's build height (machine.bed_z = " +
                           number_text(p.bed_z) + " mm)",
                       {"", 0, "embedded.floor_z"});
  if (p.prime_line > 0 && p.has_bath())
    throw SettingError(
        "a prime line is drawn on a bed, not in a support bath (machine.flavor = "
        "embedded): leave gcode.prime_line at 0",
        {"", 0, "gcode.prime_line"});
}

std::string setting_text(const MachineProfile& p, const SettingDecl& d) {
  return std::visit(
      [&](const auto& member) -> std::string {
        using M = std::remove_cvref_t<decltype(member)>;
        if constexpr (std::is_same_v<M, MachineChoice>) {
          return member.names.at(static_cast<std::size_t>(member.get(p)));
        } else {
          using T = std::remove_cvref_t<decltype(p.*member)>;
          if constexpr (std::is_same_v<T, double>)
            return number_text(p.*member);
          else if constexpr (std::is_same_v<T, int>)
            return std::to_string(p.*member);
          else if constexpr (std::is_same_v<T, bool>)
            return p.*member ? "true" : "false";
          else
            return p.*member;
        }
      },
      d.member);
}

}  // namespace trellis
