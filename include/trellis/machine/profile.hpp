// Machine profiles. Every setting is declared once in a table (key, type, unit, default, range,
// doc); the TOML reader, `--set key=value` overrides, help text and the G-code header all come
// from that table. Layers merge: defaults < profile file < overrides.
#pragma once
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis {

// The choices of a profile, parsed once where settings are read (their names: to_string below).
// machine.flavor: Marlin, RepRapFirmware and Klipper are one family (E axis, G-code moves; heaters
// and tools in each firmware's own words); pneumatic pushes ink by valve and pressure, embedded
// does so in a support bath.
enum class Flavor { Marlin, RepRap, Klipper, Pneumatic, Embedded };
enum class Firmware { None, Prusa };                      // machine.firmware: "" | prusa
enum class BedShape { Rectangle, Circle };                // machine.bed_shape
enum class BedOrigin { Corner, Center };                  // machine.origin
enum class GradientMode { Mixing, Tools, Temperature };   // gradient.mode
enum class FlowModel { None, Pla, Tpu };                  // gradient.flow: "" | pla | tpu
enum class MixingDialect { M165, M163, M567, Template };  // gradient.dialect
enum class EmbeddedDrive { Pressure, Syringe };           // embedded.drive
enum class PurgePosition { Auto, Fixed };                 // purge.position
enum class GcodeEncoding { None, MeatPack };              // gcode.binary_encoding

const char* to_string(Flavor v);
const char* to_string(Firmware v);
const char* to_string(BedShape v);
const char* to_string(BedOrigin v);
const char* to_string(GradientMode v);
const char* to_string(FlowModel v);
const char* to_string(MixingDialect v);
const char* to_string(EmbeddedDrive v);
const char* to_string(PurgePosition v);
// The inverse of to_string for the choices read by name outside a profile file (tests, G-code
// headers); throws SettingError naming the key and its choices.
Flavor flavor_from_string(const std::string& name);
MixingDialect mixing_dialect_from_string(const std::string& name);

struct MachineProfile {
  // [machine]
  std::string name = "generic Marlin FDM";
  Flavor flavor = Flavor::Marlin;
  // The firmware, where a format depends on it: Prusa's Buddy firmware (reads binary G-code) or
  // not declared.
  Firmware firmware = Firmware::None;
  // The printer model as Prusa's firmware names itself (MK4S, MK4, MK3.9, XL, MINI, COREONE):
  // binary G-code's printer metadata "printer_model", which the firmware compares with its own
  // model before printing; empty = not written.
  std::string printer_model;
  // Capabilities: what the machine can do. Every writer checks the toolpath against them before
  // it writes (machine/machine_check.hpp).
  double bed_x = 220, bed_y = 220;  // build area (mm); a circle: bed_x is its diameter
  double bed_z = 250;               // build height (mm)
  BedShape bed_shape = BedShape::Rectangle;
  BedOrigin origin = BedOrigin::Corner;  // 0,0 at a corner or at the centre
  int tool_count = 1;                    // tools / nozzles (tool changers, multi-nozzle heads)
  int mixing_inputs = 1;                 // filament inputs of a mixing hotend; 1 = no mixing
  // Sequential printing (plate.sequence = parts): the radius around the nozzle kept clear of
  // finished parts and the height of the gantry above the nozzle tip (PrusaSlicer's
  // extruder_clearance_radius / _height); 0 = not known, sequential printing refused.
  double extruder_clearance_radius = 0, extruder_clearance_height = 0;
  // [placement]
  bool center = true;                 // move the part's XY centre to the bed centre
  double offset_x = 0, offset_y = 0;  // added after centring (mm)
  bool lift = true;  // a toolpath reaching below Z 0 is lifted so its lowest point is at Z 0
  // [extrusion] (Eq. 4: E = k·4·L·LT·EM·d_n / (π·f_d²))
  double nozzle_diameter = 0.4;       // d_n (mm)
  double filament_diameter = 1.75;    // f_d (mm)
  double layer_height = 0.2;          // LT when a path has no height (mm)
  double extrusion_multiplier = 1.0;  // EM
  double k = 1.0;                     // k, bead shape correction
  bool relative_e = false;            // M83 instead of M82
  // Steep downward moves (non-planar paths) deposit wider beads (non-planar paper, Fig. 2: from
  // 45° down). "deg,factor;deg,factor;..." : a segment descending at least `deg` below the
  // horizontal gets the factor of the steepest such entry: E × factor (marlin), feed ÷ factor
  // (pneumatic / embedded, same flow over more length). Empty = no compensation.
  std::string down_flow;
  // [speed] (mm/s)
  double print_speed = 20;
  double travel_speed = 100;
  double z_speed = 10;
  double acceleration = 0;  // mm/s², for time estimates; 0 = feed rates only
  double jerk = 10;         // mm/s, the speed change taken at a corner without slowing (estimates)
  double max_speed = 500;   // fastest feed the machine moves at (mm/s)
  double short_path_factor = 0.6;  // speed factor for paths under short_path_segments
  int short_path_segments = 4;
  // [temperature] (°C, 0 = leave unset) and fan (%)
  double nozzle_temperature = 0;
  double bed_temperature = 0;
  double fan_percent = 0;
  double standby_temperature = 0;  // idle tools of a multi-tool machine (°C), 0 = stay hot
  double max_nozzle_temperature = 300;
  double max_bed_temperature = 120;
  double settle_time = 5;  // s dwelt after each temperature change a process field makes
  // [retraction]
  double retract_length = 0;  // filament (mm)
  double retract_speed = 30;  // mm/s
  double z_hop = 0;           // lift during travel (mm)
  double min_travel = 0.5;    // travel shorter than this: no retract / hop (mm)
  // A travel the slicer kept inside the part (Path::inside) retracts and hops only when longer
  // than this (mm); 0 = never.
  double inside_max = 0;
  // [flow]
  double pre_flow = 0;         // extra filament primed at each path start (mm)
  double post_flow = 0;        // extra filament pushed at each path end (mm)
  double pre_flow_dwell = 0;   // dwell after opening / priming (s)
  double post_flow_dwell = 0;  // dwell before closing (s)
  // [pneumatic]
  double pressure = 0;             // kPa, sent with pressure_command per path
  std::string pressure_command;    // e.g. "M42 P{pressure}"; empty = none
  std::string valve_on = "M106";   // opens the valve
  std::string valve_off = "M107";  // closes the valve
  // [embedded] printing inside a support bath (valve and pressure as [pneumatic])
  double bath_surface = 0;      // Z of the bath surface (mm); below the part top, the part top
  double travel_clearance = 2;  // travel this far above the bath surface (mm)
  double node_dwell = 0;        // dwell at every node inside a path (s)
  double node_overlap = 0;      // extend each path end this far past its node (mm)
  // Where each nozzle sits relative to nozzle 0, "x,y;x,y;..." (mm), tool 0 first; empty = all
  // 0,0. The writer puts nozzle t at design XY by commanding the head to design - offset(t),
  // unless firmware_offsets says the firmware shifts the head itself (then it writes design XY).
  std::string tool_offsets;
  bool firmware_offsets = false;
  double floor_z = 0;          // Z of the bath's floor above machine Z0: the design's Z0 (mm)
  std::string tool_pressures;  // per tool "p0,p1,..." replacing pneumatic.pressure; empty = same
  std::string tool_change = "T{tool}";  // command selecting tool {tool}
  std::string raise_idle;  // command raising the nozzle {tool} that goes idle; empty = none
  EmbeddedDrive embedded_drive = EmbeddedDrive::Pressure;  // valve + kPa, or E (Eq. 4)
  double bath_travel = 0;  // travel up to this long stays inside the bath (mm)
  // [gradient] how a path's material mixture (graded designs) is made
  GradientMode gradient_mode = GradientMode::Mixing;  // M165 | T<n> | M104
  int gradient_tools = 0;      // tools: tools holding the gradient (0 = all of tool_count); tool 0
                               // holds material A, the last material B
  double temperature_a = 190;  // temperature: °C for 100% material A ...
  double temperature_b = 225;  // ... and for 100% material B (linear between)
  FlowModel flow_model = FlowModel::None;  // temperature: M221 by Eq. 3 (pla) / 4 (tpu)
  double lookahead = 0;                    // issue each change this many mm of path earlier
  MixingDialect gradient_dialect = MixingDialect::M165;  // mixing: M165 | M163 | M567 | template
  std::string gradient_template;  // mixing, dialect template: {a} {b} {c} = shares
  bool quantize = false;          // tools: print more colours than tools, each by the nearest
  // [purge] Strategy 1 purge towers (FGM paper A.1)
  double melt_volume = 0;      // hotend dead volume V_melt (mm³); 0 = no towers
  double purge_threshold = 0;  // mixture change (0..1) that needs a purge
  PurgePosition purge_position = PurgePosition::Auto;  // beside the part | at purge_x, purge_y
  double purge_x = -20, purge_y = 0, purge_side = 10;  // tower centre (fixed) and least side (mm)
  double purge_clearance = 5;                          // gap between the tower and the part (mm)
  // material densities (g/cm³) for tower masses per colour
  double density_a = 1.24, density_b = 1.24, density_c = 1.24;
  // [gcode] templates; {key} is replaced by that setting's value, e.g. {nozzle_temperature}
  std::string start_gcode = "G28";
  std::string end_gcode = "M84";
  std::string file_extension = "";           // default output extension: "" = by flavor
  std::string thumbnails = "16x16,220x124";  // PNG previews in the G-code header, "WxH,..."
  bool binary_gcode = false;  // write binary G-code (.bgcode; machine/bgcode_writer.hpp)
  GcodeEncoding binary_encoding = GcodeEncoding::MeatPack;  // its G-code blocks' encoding
  // A prime line drawn along the bed's front edge before the first layer (mm of line; 0 = none).
  double prime_line = 0;
  bool label_objects =
      true;  // plates: each part's moves labelled for the firmware (M486 / Klipper)

  // RepRapFirmware and Klipper are Marlin's family: E axis, retraction, fan, M73 progress.
  bool marlin_family() const {
    return flavor == Flavor::Marlin || flavor == Flavor::RepRap || flavor == Flavor::Klipper;
  }
  // Tools used for a gradient in `tools` mode (gradient_tools, or all tools).
  int gradient_tool_count() const { return gradient_tools > 0 ? gradient_tools : tool_count; }
  // A support bath: the embedded flavour.
  bool has_bath() const { return flavor == Flavor::Embedded; }
  // Per-tool XY offset and pressure from tool_offsets / tool_pressures (throws SettingError).
  Vec2 tool_offset(int tool) const;
  double tool_pressure(int tool) const;
  // down_flow as (descent angle in degrees, factor), sorted by angle (throws SettingError).
  std::vector<std::pair<double, double>> down_flow_table() const;
  // thumbnails as (width, height) pairs (throws SettingError).
  std::vector<std::pair<int, int>> thumbnail_sizes() const;
};

// An enum member of the profile with its names in the enum's order (its values as int).
struct MachineChoice {
  std::vector<const char*> names;
  std::function<int(const MachineProfile&)> get;
  std::function<void(MachineProfile&, int)> set;
};

// One machine setting, declared once: key, unit, doc, range, the member it sets (a choice with its
// names) and its CLI flag. The settings schema (settings/schema.cpp) takes these entries as its
// machine sections as they are; the G-code writer, below the schema, records them in its header
// and expands {key} placeholders from them, which is why they live here.
struct SettingDecl {
  const char* key;   // TOML key "section.name"
  const char* unit;  // "mm", "mm/s", "" ...
  const char* doc;
  double min, max;  // numeric range (inclusive)
  std::variant<double MachineProfile::*, int MachineProfile::*, bool MachineProfile::*,
               std::string MachineProfile::*, MachineChoice>
      member;
  const char* flag = "";  // long CLI flag without dashes; "" = --set only
};

const std::vector<SettingDecl>& machine_settings();

// Profiles are read through the settings schema (settings/settings.hpp load_machine_profile).
// Validates cross-setting rules; throws SettingError.
void validate(const MachineProfile& profile);
// Value of a setting as text (for headers and templates).
std::string setting_text(const MachineProfile& profile, const SettingDecl& decl);

}  // namespace trellis
