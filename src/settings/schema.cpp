// The one table of settings. Each entry binds a dotted key to the member of Config that holds
// it; the default is that member's initialiser (Config{}), so it is written nowhere else.
#include <cmath>
#include <limits>
#include <map>
#include <string_view>

#include "trellis/core/error.hpp"
#include "trellis/settings/settings.hpp"

namespace trellis {

namespace {

// Builders. `Acc` is a lambda `(Config&) -> T&` naming the member.
template <class Acc>
Setting number(std::string key, std::string unit, double lo, double hi, std::string doc,
               std::string flag, Acc acc) {
  Setting s;
  s.key = std::move(key), s.unit = std::move(unit), s.doc = std::move(doc);
  s.flag = std::move(flag), s.min = lo, s.max = hi, s.kind = SettingKind::Number;
  s.get = [acc](const Config& c) { return SettingValue(acc(const_cast<Config&>(c))); };
  s.set = [acc](Config& c, const SettingValue& v) { acc(c) = std::get<double>(v); };
  return s;
}

// A number that must be > lo.
template <class Acc>
Setting positive(std::string key, std::string unit, double hi, std::string doc, std::string flag,
                 Acc acc) {
  Setting s = number(std::move(key), std::move(unit), 0, hi, std::move(doc), std::move(flag), acc);
  s.positive = true;
  return s;
}

template <class Acc>
Setting integer(std::string key, double lo, double hi, std::string doc, std::string flag, Acc acc) {
  Setting s;
  s.key = std::move(key), s.doc = std::move(doc), s.flag = std::move(flag);
  s.min = lo, s.max = hi, s.kind = SettingKind::Integer;
  s.get = [acc](const Config& c) {
    return SettingValue(static_cast<long long>(acc(const_cast<Config&>(c))));
  };
  s.set = [acc](Config& c, const SettingValue& v) {
    using T = std::remove_reference_t<decltype(acc(c))>;
    acc(c) = static_cast<T>(std::get<long long>(v));
  };
  return s;
}

template <class Acc>
Setting boolean(std::string key, std::string doc, std::string flag, Acc acc) {
  Setting s;
  s.key = std::move(key), s.doc = std::move(doc), s.flag = std::move(flag);
  s.kind = SettingKind::Bool;
  s.get = [acc](const Config& c) { return SettingValue(acc(const_cast<Config&>(c))); };
  s.set = [acc](Config& c, const SettingValue& v) { acc(c) = std::get<bool>(v); };
  return s;
}

template <class Acc>
Setting text(std::string key, std::string doc, std::string flag, Acc acc) {
  Setting s;
  s.key = std::move(key), s.doc = std::move(doc), s.flag = std::move(flag);
  s.kind = SettingKind::Text;
  s.get = [acc](const Config& c) { return SettingValue(acc(const_cast<Config&>(c))); };
  s.set = [acc](Config& c, const SettingValue& v) { acc(c) = std::get<std::string>(v); };
  return s;
}

// A file path: relative paths in a job are relative to the job file.
template <class Acc>
Setting path(std::string key, std::string doc, std::string flag, Acc acc) {
  Setting s = text(std::move(key), std::move(doc), std::move(flag), acc);
  s.unit = "path";
  return s;
}

// A choice stored as its name.
template <class Acc>
Setting choice(std::string key, std::vector<std::string> choices, std::string doc, std::string flag,
               Acc acc) {
  Setting s = text(std::move(key), std::move(doc), std::move(flag), acc);
  s.kind = SettingKind::Choice;
  s.choices = std::move(choices);
  return s;
}

// A choice stored as an enum.
template <class E, class Acc>
Setting choice_enum(std::string key, std::vector<std::pair<std::string, E>> map, std::string doc,
                    std::string flag, Acc acc) {
  Setting s;
  s.key = std::move(key), s.doc = std::move(doc), s.flag = std::move(flag);
  s.kind = SettingKind::Choice;
  for (const auto& [name, e] : map) s.choices.push_back(name);
  s.get = [acc, map](const Config& c) {
    const E e = acc(const_cast<Config&>(c));
    for (const auto& [name, v] : map)
      if (v == e) return SettingValue(name);
    return SettingValue(map.front().first);
  };
  s.set = [acc, map](Config& c, const SettingValue& v) {
    for (const auto& [name, e] : map)
      if (name == std::get<std::string>(v)) acc(c) = e;
  };
  return s;
}

// A choice stored as an enum whose values run 0 .. n - 1, named by its to_string (config.hpp).
template <class E, class Acc>
Setting choice_named(std::string key, int n, std::string doc, std::string flag, Acc acc) {
  std::vector<std::pair<std::string, E>> map;
  for (int i = 0; i < n; ++i) map.emplace_back(to_string(static_cast<E>(i)), static_cast<E>(i));
  return choice_enum<E>(std::move(key), std::move(map), std::move(doc), std::move(flag), acc);
}

template <class Acc>
Setting numbers(std::string key, std::string unit, double lo, double hi, int count, std::string doc,
                std::string flag, Acc acc) {
  Setting s;
  s.key = std::move(key), s.unit = std::move(unit), s.doc = std::move(doc);
  s.flag = std::move(flag), s.min = lo, s.max = hi, s.count = count;
  s.kind = SettingKind::Numbers;
  s.get = [acc](const Config& c) { return SettingValue(acc(const_cast<Config&>(c))); };
  s.set = [acc](Config& c, const SettingValue& v) { acc(c) = std::get<std::vector<double>>(v); };
  return s;
}

// A list of numbers kept in several members: `get`/`set` convert.
template <class Get, class Set>
Setting numbers_via(std::string key, std::string unit, double lo, double hi, int count,
                    std::string doc, std::string flag, Get get, Set set) {
  Setting s;
  s.key = std::move(key), s.unit = std::move(unit), s.doc = std::move(doc);
  s.flag = std::move(flag), s.min = lo, s.max = hi, s.count = count;
  s.kind = SettingKind::Numbers;
  s.get = [get](const Config& c) { return SettingValue(get(c)); };
  s.set = [set](Config& c, const SettingValue& v) { set(c, std::get<std::vector<double>>(v)); };
  return s;
}

// A switch per item (per laser): a list of true or false, held as 1 or 0 (Setting::flags); its
// type reads "list of true/false", its range "true or false, each".
template <class Acc>
Setting switches(std::string key, std::string doc, std::string flag, Acc acc) {
  Setting s = numbers(std::move(key), "", 0, 1, 0, std::move(doc), std::move(flag), acc);
  s.whole = s.flags = true;
  return s;
}

Setting derived(Setting s, std::string from) {
  s.derived = std::move(from);
  return s;
}

// A machine member of a plain type as a schema entry's kind, getter and setter.
template <class T>
void add_member(Setting& s, T MachineProfile::*member) {
  if constexpr (std::is_same_v<T, double>) {
    s.kind = SettingKind::Number;
    s.get = [member](const Config& c) { return SettingValue(c.machine.*member); };
    s.set = [member](Config& c, const SettingValue& v) { c.machine.*member = std::get<double>(v); };
  } else if constexpr (std::is_same_v<T, int>) {
    s.kind = SettingKind::Integer;
    s.get = [member](const Config& c) {
      return SettingValue(static_cast<long long>(c.machine.*member));
    };
    s.set = [member](Config& c, const SettingValue& v) {
      c.machine.*member = static_cast<int>(std::get<long long>(v));
    };
  } else if constexpr (std::is_same_v<T, bool>) {
    s.kind = SettingKind::Bool;
    s.get = [member](const Config& c) { return SettingValue(c.machine.*member); };
    s.set = [member](Config& c, const SettingValue& v) { c.machine.*member = std::get<bool>(v); };
  } else {
    s.kind = SettingKind::Text;
    s.get = [member](const Config& c) { return SettingValue(c.machine.*member); };
    s.set = [member](Config& c, const SettingValue& v) {
      c.machine.*member = std::get<std::string>(v);
    };
  }
}

// The machine sections, declared in machine/profile.cpp (the G-code writer below the schema
// reads them too), as schema entries: each declaration as it is, its default the member's.
void add_machine(std::vector<Setting>& out) {
  for (const auto& d : machine_settings()) {
    Setting s;
    s.key = d.key, s.unit = d.unit, s.doc = d.doc, s.min = d.min, s.max = d.max;
    std::visit(
        [&](const auto& member) {
          using M = std::remove_cvref_t<decltype(member)>;
          if constexpr (std::is_same_v<M, MachineChoice>) {
            s.kind = SettingKind::Choice;
            s.choices.assign(member.names.begin(), member.names.end());
            s.get = [member](const Config& c) {
              return SettingValue(
                  std::string(member.names.at(static_cast<std::size_t>(member.get(c.machine)))));
            };
            s.set = [member](Config& c, const SettingValue& v) {
              const auto& names = member.names;
              for (std::size_t i = 0; i < names.size(); ++i)
                if (names[i] == std::get<std::string>(v))
                  member.set(c.machine, static_cast<int>(i));
            };
          } else {
            add_member(s, member);
          }
        },
        d.member);
    s.flag = d.flag;
    out.push_back(std::move(s));
  }
}

}  // namespace

std::string to_string(LatticePlanner planner) {
  static const char* const names[] = {"gippo", "euler", "aero"};
  return names[static_cast<int>(planner)];
}

std::string to_string(PbfRoute route) {
  static const char* const names[] = {"direct", "stl"};
  return names[static_cast<int>(route)];
}

std::string to_string(PbfStrategy strategy) {
  static const char* const names[] = {"hybrid",  "r67",    "rectilinear",
                                      "meander", "stripe", "island"};
  return names[static_cast<int>(strategy)];
}

std::string to_string(PlateSequence sequence) {
  static const char* const names[] = {"layers", "parts"};
  return names[static_cast<int>(sequence)];
}

std::string to_string(Lattice3dKind kind) {
  static const char* const names[] = {"cells", "foam", "conformal"};
  return names[static_cast<int>(kind)];
}

std::string to_string(GradeAxis axis) {
  return axis == GradeAxis::Z ? "z" : "r";
}

std::string to_string(OntoKind kind) {
  static const char* const names[] = {"", "sphere-cap", "mesh", "function"};
  return names[static_cast<int>(kind)];
}

std::string to_string(RenderColour colour) {
  static const char* const names[] = {"auto",      "feature", "order", "mixture",
                                      "commanded", "tool",    "set"};
  return names[static_cast<int>(colour)];
}

std::string to_string(SurfaceKind kind) {
  static const char* const names[] = {"corrugation", "miura", "m-curve", "sphere-cap",
                                      "angle-test"};
  return names[static_cast<int>(kind)];
}

namespace {

const Setting* find_in(const std::vector<Setting>& table, const std::string& key) {
  for (const Setting& s : table)
    if (s.key == key) return &s;
  return nullptr;
}

// When each setting is used (Setting::when), beyond its route reading its section. A key ending
// in '.' covers its whole section; a later, longer entry adds its terms to the section's. These
// are what `run_job` refuses a given setting by, and what the settings matrix test
// (tests/settings_matrix_test.py) checks both ways: refused where a condition fails, changing the
// output where they all hold.
const std::vector<std::pair<const char*, const char*>>& when_table() {
  static const std::vector<std::pair<const char*, const char*>> t = {
      // The surface route makes an STL; a machine matters only for the angle test's G-code.
      {"machine.", "route!=surface or @gcode"},
      {"placement.", "route!=surface or @gcode"},
      {"extrusion.", "route!=surface or @gcode"},
      {"speed.", "route!=surface or @gcode"},
      {"machine.bed_z", "@gcode"},
      {"machine.bed_shape", "@gcode"},
      // Only the G-code writer reads these.
      {"temperature.", "@gcode"},
      {"retraction.", "@gcode; machine.flavor=marlin|reprap|klipper"},
      {"flow.", "@gcode"},
      {"retraction.inside_max", "route=slice|gcode"},
      {"flow.pre", "machine.flavor=marlin|reprap|klipper"},
      {"flow.post", "machine.flavor=marlin|reprap|klipper"},
      {"pneumatic.", "@gcode; machine.flavor=pneumatic|embedded"},
      {"embedded.", "@gcode; machine.flavor=embedded"},
      {"gradient.", "@gcode; @graded"},
      {"gradient.tools", "gradient.mode=tools"},
      {"gradient.quantize", "gradient.mode=tools"},
      {"gradient.temperature_a", "gradient.mode=temperature"},
      {"gradient.temperature_b", "gradient.mode=temperature"},
      {"gradient.flow", "gradient.mode=temperature"},
      {"gradient.dialect", "gradient.mode=mixing"},
      {"gradient.template", "gradient.mode=mixing; gradient.dialect=template"},
      {"purge.", "@gcode; @graded or @tools"},
      {"purge.x", "purge.position=fixed"},
      {"purge.y", "purge.position=fixed"},
      {"gcode.", "@gcode"},
      {"gcode.extension", "@job"},
      {"gcode.binary", "machine.firmware=prusa"},
      {"machine.firmware", "@bgcode or gcode.binary=true"},
      {"machine.printer_model", "@bgcode or gcode.binary=true"},
      {"gcode.binary_encoding", "@bgcode or gcode.binary=true"},
      {"extrusion.filament_diameter", "@gcode"},
      {"extrusion.multiplier", "@gcode"},
      {"extrusion.k", "@gcode"},
      {"extrusion.relative_e", "@gcode; machine.flavor=marlin|reprap|klipper"},
      {"extrusion.down_flow", "@gcode"},
      {"temperature.standby", "@tools"},
      {"temperature.settle", "@process"},
      {"machine.mixing_inputs", "@gcode; @graded"},
      {"machine.extruder_clearance_radius", "plate.sequence=parts"},
      {"machine.extruder_clearance_height", "plate.sequence=parts"},
      {"embedded.tool_offsets", "@tools"},
      {"embedded.tool_pressures", "@tools"},
      {"embedded.tool_change", "@tools"},
      {"embedded.raise_idle", "@tools"},
      // The 2D atlas, when the route makes its lattice (lattice2d, or plan without an input).
      {"lattice2d.", "route=lattice2d or !@input; plan.planner!=aero or route=lattice2d"},
      {"lattice2d.strand", "lattice2d.pattern=square|triangle|lines"},
      {"lattice2d.density", "lattice2d.pattern=voronoi"},
      {"lattice2d.seed", "lattice2d.pattern=voronoi"},
      {"lattice2d.size", "lattice2d.region=rectangle"},
      {"lattice2d.diameter", "lattice2d.region=circle"},
      {"lattice2d.ring_spacing", "lattice2d.rings>1"},
      {"lattice2d.handle_length", "lattice2d.handles=true"},
      {"lattice2d.handle_width", "lattice2d.handles=true"},
      {"lattice2d.handle_spacing", "lattice2d.handles=true"},
      {"lattice2d.reentrant_angle", "lattice2d.pattern=reentrant-honeycomb"},
      {"lattice2d.cell_height", "lattice2d.pattern=arrowhead|reentrant-honeycomb"},
      {"lattice2d.arrowhead_outer", "lattice2d.pattern=arrowhead"},
      {"lattice2d.arrowhead_inner", "lattice2d.pattern=arrowhead"},
      {"lattice2d.line_width",
       "lattice2d.target_porosity>0 or route=lattice2d"},  // the pore area said
      // 3D lattices, when the route makes one (lattice3d, or plan aero without an input).
      {"lattice3d.", "route=lattice3d or !@input; route=lattice3d or plan.planner=aero"},
      {"lattice3d.cell_type", "lattice3d.kind=cells|conformal"},
      {"lattice3d.count", "lattice3d.kind=cells"},
      {"lattice3d.cell", "lattice3d.kind=cells|conformal"},
      {"lattice3d.box", "lattice3d.kind=foam"},
      {"lattice3d.skin", "lattice3d.kind=conformal"},
      {"lattice3d.skin_density", "lattice3d.kind=conformal"},
      {"lattice3d.mesh", "lattice3d.kind=foam|conformal"},
      {"lattice3d.density", "lattice3d.kind=foam"},
      {"lattice3d.seed", "lattice3d.kind=foam|conformal"},
      {"lattice3d.radius", "@3mf"},
      {"lattice.", "@input"},
      {"lattice.merge_tolerance", "lattice.keep_graph=false"},
      {"onto.", "onto.kind"},
      {"onto.radius", "onto.kind=sphere-cap"},
      {"onto.diameter", "onto.kind=sphere-cap"},
      {"onto.file", "onto.kind=mesh"},
      {"onto.height_fn", "onto.kind=function"},
      {"onto.domain", "onto.kind=function"},
      {"gippo.", "plan.planner=gippo"},
      {"aero.", "plan.planner=aero"},
      {"aero.tries", "aero.method=dynamic"},
      {"aero.cell_type", "aero.method=periodic"},
      {"aero.cell", "aero.method=periodic"},
      {"aero.print_path", "aero.method=periodic"},
      {"aero.fewest_collisions", "aero.collisions=true"},
      {"aero.exact_struts", "aero.collisions=true"},
      {"nozzle.", "plan.planner=aero or route=check|view"},
      {"plan.seed", "plan.planner=gippo|aero"},
      {"output.preview_layers", "@preview; route=plan|slice|pbf|nonplanar"},
      {"output.image_size", "@preview"},
      {"output.frames", "@preview; plan.planner=aero"},
      {"output.gcode", "route=plan; @job"},
      {"output.png", "@job"},
      {"slice.infill_lattice", "slice.infill_pattern=lattice"},
      {"slice.infill_seed", "slice.infill_pattern=lattice; slice.infill_lattice=voronoi"},
      {"slice.seam_seed", "slice.seam=random"},
      {"slice.connect_max", "slice.connect=true"},
      {"slice.comb_detour", "slice.comb=true"},
      {"fgm.", "slice.strategy!=0"},
      {"fgm.order", "slice.strategy=1"},
      {"fgm.zipper", "slice.strategy=1"},
      {"fgm.concentric", "slice.strategy=2"},
      {"fgm.fixed_angle", "slice.strategy=2"},
      {"fgm.perimeters", "slice.strategy=2"},
      {"pbf.grade_axis", "pbf.grade_to"},
      {"pbf.grade_center", "pbf.grade_to"},
      {"pbf.grade_width", "pbf.grade_to"},
      {"pbf.wall_inclination", "pbf.wall_thickness"},
      {"pbf.wall_azimuth", "pbf.wall_thickness"},
      {"pbf.thin_multiple", "pbf.strategy=hybrid; !@mesh; pbf.split=width"},
      {"pbf.min_inclination", "pbf.strategy=hybrid; !@mesh"},
      {"pbf.split", "pbf.strategy=hybrid; !@mesh"},
      {"pbf.hatch_seed", "pbf.hatch_phase=random"},
      {"pbf.plate_position", "pbf.hatch_phase=origin"},
      {"pbf.route", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.contours", "@mesh or pbf.strategy=rectilinear|meander|stripe|island"},
      {"pbf.contour_distance", "@mesh or pbf.strategy=rectilinear|meander|stripe|island"},
      {"pbf.skin_thickness", "@mesh or pbf.strategy=rectilinear|meander|stripe|island"},
      {"pbf.upskin_thickness", "@mesh or pbf.strategy=rectilinear|meander|stripe|island"},
      {"pbf.downskin_thickness", "@mesh or pbf.strategy=rectilinear|meander|stripe|island"},
      {"pbf.core_hatch_distance", "pbf.skin_thickness>0"},
      {"pbf.core_hatch_rotation", "pbf.skin_thickness>0"},
      {"pbf.upskin_hatch_distance", "pbf.upskin_thickness>0"},
      {"pbf.upskin_hatch_rotation", "pbf.upskin_thickness>0"},
      {"pbf.downskin_hatch_distance", "pbf.downskin_thickness>0"},
      {"pbf.downskin_hatch_rotation", "pbf.downskin_thickness>0"},
      {"laser.contour_powers", "@mesh or pbf.strategy=rectilinear|meander|stripe|island"},
      {"laser.contour_speeds", "@mesh or pbf.strategy=rectilinear|meander|stripe|island"},
      {"laser.core_power", "pbf.skin_thickness>0"},
      {"laser.core_speed", "pbf.skin_thickness>0"},
      {"laser.upskin_power", "pbf.upskin_thickness>0"},
      {"laser.upskin_speed", "pbf.upskin_thickness>0"},
      {"laser.downskin_power", "pbf.downskin_thickness>0"},
      {"laser.downskin_speed", "pbf.downskin_thickness>0"},
      // The TPMS lattice's settings: a solid part (a mesh, a .vcad with a solid strategy) has none.
      {"pbf.cell_type", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.cell", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.c", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.thickness", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.size", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.envelope", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.solids", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.grade_to", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.grade_axis", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.grade_center", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.grade_width", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.hierarchical", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.wall_thickness", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.wall_inclination", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.wall_azimuth", "!@mesh; pbf.strategy=hybrid|r67"},
      {"pbf.resolution", "!@mesh"},
      {"pbf.laser_overlap", "laser.lasers>1"},
      {"lasers.", "laser.lasers>1"},
      {"pbf.laser_split_axis", "laser.lasers>1"},
      {"pbf.stripe_width", "pbf.strategy=stripe"},
      {"pbf.stripe_overlap", "pbf.strategy=stripe"},
      {"pbf.island_size", "pbf.strategy=island"},
      {"pbf.island_overlap", "pbf.strategy=island"},
      {"pbf.island_shift", "pbf.strategy=island"},
      {"nonplanar.domain", "nonplanar.height_fn"},
      // The planar control slices walls and solid fill flat: no non-planar lines to shape.
      {"nonplanar.surface_spacing", "nonplanar.planar_control=false"},
      {"nonplanar.chord_tolerance", "nonplanar.planar_control=false"},
      {"nonplanar.max_join", "nonplanar.planar_control=false"},
      {"surface.length", "surface.kind=corrugation|miura|m-curve"},
      {"surface.width", "surface.kind=corrugation|miura|m-curve"},
      {"surface.resolution", "surface.kind=miura|sphere-cap"},  // profiles are exact
      {"surface.periods", "surface.kind=corrugation"},
      {"surface.angle", "surface.kind=corrugation"},
      {"surface.amplitude_scale", "surface.kind=corrugation"},
      {"surface.fillet", "surface.kind=corrugation|m-curve"},
      {"surface.flat", "surface.kind=corrugation"},
      {"surface.depth", "surface.kind=miura"},
      {"surface.height", "surface.kind=m-curve"},
      {"surface.radius", "surface.kind=sphere-cap"},
      {"surface.diameter", "surface.kind=sphere-cap"},
      // The reader routes (RouteSpec::reads): each reads only some of the sections they share.
      {"read.valve_on", "route=analyze|compare|view|render"},
      {"read.valve_off", "route=analyze|compare|view|render"},
      {"read.commanded_mixtures", "route=check|analyze|compare"},
      {"read.strict", "route=analyze|compare"},
      {"analyze.filament_diameter", "route=analyze"},
      {"run.threads", "route!=check|analyze|compare|view|render"},
      {"run.max_memory", "route!=analyze|compare|view"},
      {"run.max_time", "route!=analyze|compare|view"},
      {"run.force", "route!=analyze|compare|view"},
      {"run.progress", "route!=check|analyze|compare|view"},
  };
  return t;
}

void apply_when(std::vector<Setting>& table) {
  // Keys as views (no string made per setting and entry: this runs at every start-up), each
  // setting against the entries of its section only (an entry covers keys of its own section),
  // in the table's order; and the exact keys found on the way.
  const auto& whens = when_table();
  const auto section_of = [](std::string_view k) { return k.substr(0, k.find('.') + 1); };
  std::map<std::string_view, std::vector<std::size_t>> by_section;
  for (std::size_t i = 0; i < whens.size(); ++i)
    by_section[section_of(whens[i].first)].push_back(i);
  std::vector<char> found(whens.size(), 0);
  for (Setting& s : table) {
    const auto it = by_section.find(section_of(s.key));
    if (it == by_section.end()) continue;
    for (const std::size_t i : it->second) {
      const std::string_view k = whens[i].first;
      const bool section = k.back() == '.';
      const bool covers = section ? std::string_view(s.key).substr(0, k.size()) == k : s.key == k;
      if (!covers) continue;
      if (!section) found[i] = 1;
      s.when += (s.when.empty() ? "" : "; ") + std::string(whens[i].second);
    }
  }
  for (std::size_t i = 0; i < whens.size(); ++i)
    if (std::string_view(whens[i].first).back() != '.' && !found[i])
      throw std::logic_error(std::string("the when table names an unknown setting ") +
                             whens[i].first);
}

// The table is laid out by hand: clang-format 14 breaks `[](C& c) -> auto&` into `(C & c)`.
// clang-format off
std::vector<Setting> make_table() {
  using C = Config;
  std::vector<Setting> t;
  add_machine(t);

  // laser.* and scan.*: the laser profile.
  t.push_back(positive("laser.spot_diameter", "mm", 5, "laser spot diameter", "",
                       [](C& c) -> auto& { return c.laser.spot_diameter; }));
  t.push_back(positive("laser.melt_pool_width", "mm", 5,
                       "melt pool width D (PBF paper Eq. 8: FR_a = D·ΣL/A)", "",
                       [](C& c) -> auto& { return c.laser.melt_pool_width; }));
  t.push_back(number("laser.contour_power", "W", 0, 10000, "laser power on contour vectors", "",
                     [](C& c) -> auto& { return c.laser.contour_power; }));
  t.push_back(positive("laser.contour_speed", "mm/s", 100000, "scan speed on contour vectors", "",
                       [](C& c) -> auto& { return c.laser.contour_speed; }));
  t.push_back(number("laser.hatch_power", "W", 0, 10000, "laser power on hatch vectors", "",
                     [](C& c) -> auto& { return c.laser.hatch_power; }));
  t.push_back(positive("laser.hatch_speed", "mm/s", 100000, "scan speed on hatch vectors", "",
                       [](C& c) -> auto& { return c.laser.hatch_speed; }));
  t.push_back(derived(numbers("laser.contour_powers", "W", 0, 10000, 0,
                              "solid parts: laser power of each contour offset, outermost first "
                              "(one per pbf.contours; each written as its own parameter set)",
                              "", [](C& c) -> auto& { return c.laser.contour_powers; }),
                      "laser.contour_power for every contour"));
  t.push_back(derived(numbers("laser.contour_speeds", "mm/s", 0, 100000, 0,
                              "solid parts: scan speed of each contour offset, outermost first "
                              "(one per pbf.contours)",
                              "", [](C& c) -> auto& { return c.laser.contour_speeds; }),
                      "laser.contour_speed for every contour"));
  t.push_back(derived(positive("laser.core_power", "W", 10000,
                               "solid parts: laser power on the core's hatch (pbf.skin_thickness)",
                               "", [](C& c) -> auto& { return c.laser.core_power; }),
                      "laser.hatch_power"));
  t.push_back(derived(positive("laser.core_speed", "mm/s", 100000,
                               "solid parts: scan speed on the core's hatch", "",
                               [](C& c) -> auto& { return c.laser.core_speed; }),
                      "laser.hatch_speed"));
  t.push_back(derived(positive("laser.upskin_power", "W", 10000,
                               "solid parts: laser power on the up-skin's hatch "
                               "(pbf.upskin_thickness)",
                               "", [](C& c) -> auto& { return c.laser.upskin_power; }),
                      "laser.hatch_power"));
  t.push_back(derived(positive("laser.upskin_speed", "mm/s", 100000,
                               "solid parts: scan speed on the up-skin's hatch", "",
                               [](C& c) -> auto& { return c.laser.upskin_speed; }),
                      "laser.hatch_speed"));
  t.push_back(derived(positive("laser.downskin_power", "W", 10000,
                               "solid parts: laser power on the down-skin's hatch, over powder "
                               "(pbf.downskin_thickness; typically lower than the hatch's)",
                               "", [](C& c) -> auto& { return c.laser.downskin_power; }),
                      "laser.hatch_power"));
  t.push_back(derived(positive("laser.downskin_speed", "mm/s", 100000,
                               "solid parts: scan speed on the down-skin's hatch", "",
                               [](C& c) -> auto& { return c.laser.downskin_speed; }),
                      "laser.hatch_speed"));
  t.push_back(positive("laser.max_power", "W", 100000,
                       "highest laser power the machine delivers; higher powers are refused", "",
                       [](C& c) -> auto& { return c.laser.max_power; }));
  t.push_back(positive("laser.max_speed", "mm/s", 1e6,
                       "fastest scan speed of the scanner; faster vectors are refused", "",
                       [](C& c) -> auto& { return c.laser.max_speed; }));
  t.push_back(positive("laser.build_x", "mm", 10000, "build plate size in X", "",
                       [](C& c) -> auto& { return c.laser.build_x; }));
  t.push_back(positive("laser.build_y", "mm", 10000, "build plate size in Y", "",
                       [](C& c) -> auto& { return c.laser.build_y; }));
  t.push_back(positive("laser.build_z", "mm", 10000, "build height", "",
                       [](C& c) -> auto& { return c.laser.build_z; }));
  t.push_back(integer(
      "laser.lasers", 1, 16,
      "lasers scanning each layer at once; pbf splits every layer among them in "
      "stripes along X balanced by scan time (docs/laser.md)",
      "lasers", [](C& c) -> auto& { return c.laser.lasers; }));
  t.push_back(derived(numbers("laser.fields", "mm", -1e5, 1e5, 0,
                              "each laser's field x0, y0, x1, y1 in the build file's "
                              "coordinates, laser by laser from left to right",
                              "", [](C& c) -> auto& { return c.laser.fields; }),
                      "every laser reaches the whole plate"));
  // lasers.*: lasers that differ, one value per laser (laser/laser.cpp: laser_parameters).
  const auto each = [&](const char* key, const char* unit, double lo, double hi, bool positive,
                        const char* doc, const char* from, auto acc) {
    Setting s = numbers(key, unit, lo, hi, 0, doc, "", acc);
    s.positive = positive;
    t.push_back(derived(std::move(s), from));
  };
  each("lasers.contour_power", "W", 0, 10000, false,
       "each laser's power on contour vectors, laser by laser as in laser.fields",
       "laser.contour_power for every laser",
       [](C& c) -> auto& { return c.laser.each.contour_power; });
  each("lasers.contour_speed", "mm/s", 0, 100000, true, "each laser's scan speed on contour vectors",
       "laser.contour_speed for every laser",
       [](C& c) -> auto& { return c.laser.each.contour_speed; });
  each("lasers.hatch_power", "W", 0, 10000, false, "each laser's power on hatch vectors",
       "laser.hatch_power for every laser",
       [](C& c) -> auto& { return c.laser.each.hatch_power; });
  each("lasers.hatch_speed", "mm/s", 0, 100000, true,
       "each laser's scan speed on hatch vectors (pbf balances the lasers' times with it)",
       "laser.hatch_speed for every laser",
       [](C& c) -> auto& { return c.laser.each.hatch_speed; });
  each("lasers.spot_diameter", "mm", 0, 5, true, "each laser's spot diameter",
       "laser.spot_diameter for every laser",
       [](C& c) -> auto& { return c.laser.each.spot_diameter; });
  each("lasers.jump_speed", "mm/s", 1, 1e6, false, "each laser's scanner positioning speed",
       "timing.jump_speed for every laser",
       [](C& c) -> auto& { return c.laser.each.jump_speed; });
  each("lasers.jump_delay", "µs", 0, 1e5, false, "each laser's wait after every jump",
       "timing.jump_delay for every laser",
       [](C& c) -> auto& { return c.laser.each.jump_delay; });
  each("lasers.mark_delay", "µs", 0, 1e5, false, "each laser's wait after every marked vector",
       "timing.mark_delay for every laser",
       [](C& c) -> auto& { return c.laser.each.mark_delay; });
  each("lasers.polygon_delay", "µs", 0, 1e5, false,
       "each laser's wait at every corner inside a polyline", "timing.polygon_delay for every laser",
       [](C& c) -> auto& { return c.laser.each.polygon_delay; });
  each("lasers.laser_on_delay", "µs", 0, 1e5, false,
       "each laser's wait before it fires at every vector", "timing.laser_on_delay for every laser",
       [](C& c) -> auto& { return c.laser.each.laser_on_delay; });
  each("lasers.laser_off_delay", "µs", 0, 1e5, false,
       "each laser's time kept on after every vector's end",
       "timing.laser_off_delay for every laser",
       [](C& c) -> auto& { return c.laser.each.laser_off_delay; });
  t.push_back(derived(
      switches("lasers.skywriting",
               "each laser's skywriting on or off, laser by laser as in laser.fields: on, it runs "
               "in and out of every vector instead of waiting its mark delay",
               "", [](C& c) -> auto& { return c.laser.each.skywriting; }),
      "timing.skywriting for every laser"));
  each("lasers.skywriting_time", "µs", 0, 1e5, false,
       "each laser's run-in + run-out per vector when it skywrites",
       "timing.skywriting_time for every laser",
       [](C& c) -> auto& { return c.laser.each.skywriting_time; });
  t.push_back(number("scan.layer", "mm", 0.001, 1, "powder layer thickness", "layer-height",
                     [](C& c) -> auto& { return c.laser.layer; }));
  t.push_back(number("scan.hatch_distance", "mm", 0.001, 5, "hatch distance", "hatch",
                     [](C& c) -> auto& { return c.laser.hatch_distance; }));
  t.push_back(number("scan.beam_compensation", "mm", 0, 1,
                     "beam compensation: hatch ends pulled in by this", "beam-comp",
                     [](C& c) -> auto& { return c.laser.beam_compensation; }));
  t.push_back(number("scan.segment_length", "mm", 0.0001, 1000,
                     "contour scan vector length SL: straight chords on φ = 0 (the paper tested "
                     "5-400 µm; outside is a warning)", "sl",
                     [](C& c) -> auto& { return c.laser.segment_length; }));
  t.push_back(number("scan.segment_gap", "mm", 0, 1000,
                     "gap LHD between contour scan vectors (the paper tested 0-120 µm; outside is "
                     "a warning)", "lhd", [](C& c) -> auto& { return c.laser.segment_gap; }));
  // timing.*: the scanner, for the scan-time model.
  t.push_back(number("timing.jump_speed", "mm/s", 1, 1e6, "positioning speed between vectors", "",
                     [](C& c) -> auto& { return c.laser.jump_speed; }));
  t.push_back(number("timing.jump_delay", "µs", 0, 1e5, "wait after every jump", "",
                     [](C& c) -> auto& { return c.laser.jump_delay; }));
  t.push_back(number("timing.mark_delay", "µs", 0, 1e5, "wait after every marked vector", "",
                     [](C& c) -> auto& { return c.laser.mark_delay; }));
  t.push_back(number("timing.polygon_delay", "µs", 0, 1e5, "wait at every corner inside a polyline",
                     "", [](C& c) -> auto& { return c.laser.polygon_delay; }));
  t.push_back(boolean("timing.skywriting", "run in and out of each vector instead of the mark delay",
                      "", [](C& c) -> auto& { return c.laser.skywriting; }));
  t.push_back(number("timing.skywriting_time", "µs", 0, 1e5, "run-in + run-out per vector with skywriting",
                     "", [](C& c) -> auto& { return c.laser.skywriting_time; }));
  t.push_back(number("timing.laser_on_delay", "µs", 0, 1e5,
                     "wait before the laser fires at every vector (0: within the jump delay)", "",
                     [](C& c) -> auto& { return c.laser.laser_on_delay; }));
  t.push_back(number("timing.laser_off_delay", "µs", 0, 1e5,
                     "laser kept on after every vector's end (0: within the mark delay)", "",
                     [](C& c) -> auto& { return c.laser.laser_off_delay; }));

  // lattice2d.*: the 2D atlas.
  t.push_back(choice_enum<Pattern>(
      "lattice2d.pattern",
      {{"honeycomb", Pattern::Honeycomb}, {"voronoi", Pattern::Voronoi},
       {"penrose", Pattern::Penrose}, {"snub-square", Pattern::SnubSquare},
       {"arrowhead", Pattern::Arrowhead}, {"reentrant-honeycomb", Pattern::ReentrantHoneycomb},
       {"square", Pattern::Square}, {"triangle", Pattern::Triangle}, {"lines", Pattern::Lines}},
      "atlas pattern", "pattern", [](C& c) -> auto& { return c.lattice2d.pattern; }));
  t.push_back(positive("lattice2d.cell", "mm", 1000,
                       "cell size: hexagon side, rhombus side, edge or period (see lattice2d --help)",
                       "cell", [](C& c) -> auto& { return c.lattice2d.cell_size; }));
  t.push_back(derived(positive("lattice2d.strand", "mm", 1000,
                               "strand distance of square, triangle and lines", "strand",
                               [](C& c) -> auto& { return c.lattice2d.strand_distance; }),
                      "the cell size"));
  t.push_back(number("lattice2d.rotation", "deg", -360, 360, "pattern rotation about the region centre",
                     "rotation", [](C& c) -> auto& { return c.lattice2d.rotation_deg; }));
  t.push_back(positive("lattice2d.density", "1/mm²", 1000, "Voronoi seeds per mm²", "density",
                       [](C& c) -> auto& { return c.lattice2d.voronoi_density; }));
  t.push_back(integer("lattice2d.seed", 0, 9e15, "Voronoi random seed", "seed",
                      [](C& c) -> auto& { return c.lattice2d.seed; }));
  t.push_back(choice_enum<RegionShape>(
      "lattice2d.region", {{"rectangle", RegionShape::Rectangle}, {"circle", RegionShape::Circle}},
      "crop region", "region", [](C& c) -> auto& { return c.lattice2d.region.shape; }));
  {
    Setting s = numbers_via("lattice2d.size", "mm", 0, 100000, 2, "rectangle width, height", "size",
        [](const Config& c) {
      return (std::vector<double>{c.lattice2d.region.width, c.lattice2d.region.height});
    },
        [](Config& c, const std::vector<double>& xs) {
      c.lattice2d.region.width = xs[0], c.lattice2d.region.height = xs[1];
    });
    s.positive = true;
    t.push_back(std::move(s));
  }
  t.push_back(positive("lattice2d.diameter", "mm", 100000, "circle diameter", "diameter",
                       [](C& c) -> auto& { return c.lattice2d.region.diameter; }));
  {
    Setting s = numbers_via("lattice2d.center", "mm", -1e5, 1e5, 2, "region centre x, y", "region-center",
        [](const Config& c) {
      return (std::vector<double>{c.lattice2d.region.center.x, c.lattice2d.region.center.y});
    },
        [](Config& c, const std::vector<double>& xs) {
      c.lattice2d.region.center = {xs[0], xs[1]};
    });
    t.push_back(derived(std::move(s), "the region's lower-left corner at 0,0 (on a surface: its centre)"));
  }
  t.push_back(number("lattice2d.z", "mm", -1e5, 1e5, "height of the lattice plane", "z",
                     [](C& c) -> auto& { return c.lattice2d.z; }));
  t.push_back(boolean("lattice2d.contour", "add the region outline as struts", "contour",
                      [](C& c) -> auto& { return c.lattice2d.contour; }));
  t.push_back(integer("lattice2d.rings", 0, 1000,
                      "clamping rings: concentric outlines at the region's rim, the pattern inside "
                      "the innermost (GIPPO's Ø48 ball-burst discs); 0 = none", "rings",
                      [](C& c) -> auto& { return c.lattice2d.rings; }));
  t.push_back(positive("lattice2d.ring_spacing", "mm", 100,
                       "distance between clamping rings (two or more)", "ring-spacing",
                       [](C& c) -> auto& { return c.lattice2d.ring_spacing; }));
  t.push_back(boolean("lattice2d.handles", "tensile-test handles at both x ends", "handles",
                      [](C& c) -> auto& { return c.lattice2d.handles; }));
  t.push_back(positive("lattice2d.handle_length", "mm", 1000, "handle length along x",
                       "handle-length", [](C& c) -> auto& { return c.lattice2d.handle_length; }));
  t.push_back(positive("lattice2d.handle_width", "mm", 1000, "handle width along y",
                       "handle-width", [](C& c) -> auto& { return c.lattice2d.handle_width; }));
  t.push_back(positive("lattice2d.handle_spacing", "mm", 100, "fill strand spacing in handles",
                       "", [](C& c) -> auto& { return c.lattice2d.handle_spacing; }));
  t.push_back(number("lattice2d.reentrant_angle", "deg", 1, 89,
                     "re-entrant honeycomb: strut angle below horizontal", "reentrant-angle",
                     [](C& c) -> auto& { return c.lattice2d.reentrant_angle_deg; }));
  t.push_back(number("lattice2d.cell_height", "mm", 0, 1e5,
                     "arrowhead and re-entrant honeycomb: the unit cell's vertical length (the "
                     "cell size is the horizontal one, GIPPO Table 1); sets the arrowhead's inner "
                     "angle or the re-entrant rib length; 0 = from the angles",
                     "cell-height", [](C& c) -> auto& { return c.lattice2d.cell_height; }));
  t.push_back(number("lattice2d.arrowhead_outer", "deg", 1, 89, "arrowhead: outer chevron angle",
                     "arrowhead-outer", [](C& c) -> auto& { return c.lattice2d.arrowhead_outer_deg; }));
  t.push_back(number("lattice2d.target_porosity", "%", 0, 99,
                     "tune the cell size (Voronoi: the density) until this share of the region is "
                     "pore, lines lattice2d.line_width wide, as GIPPO Table 1 designs; 0 = use "
                     "lattice2d.cell",
                     "target-porosity", [](C& c) -> auto& { return c.target_porosity; }));
  t.push_back(positive("lattice2d.line_width", "mm", 100,
                       "printed line width for the reported pore area", "line-width",
                       [](C& c) -> auto& { return c.line_width; }));
  t.push_back(number("lattice2d.arrowhead_inner", "deg", 1, 89, "arrowhead: inner chevron angle",
                     "arrowhead-inner", [](C& c) -> auto& { return c.lattice2d.arrowhead_inner_deg; }));

  // lattice3d.*
  t.push_back(choice_named<Lattice3dKind>("lattice3d.kind", 3,
                     "unit cells tessellated, a stochastic Voronoi foam, or cells clipped to a "
                     "closed mesh (lattice3d.mesh) with an optional stochastic skin", "kind",
                     [](C& c) -> auto& { return c.lattice3d.kind; }));
  t.push_back(choice_enum<UnitCell>(
      "lattice3d.cell_type",
      {{"cubic", UnitCell::Cubic}, {"bcc", UnitCell::Bcc}, {"fcc", UnitCell::Fcc},
       {"octet", UnitCell::Octet}, {"diamond", UnitCell::Diamond}, {"kelvin", UnitCell::Kelvin},
       {"rhombic-dodecahedron", UnitCell::RhombicDodecahedron}},
      "unit cell", "cell-type", [](C& c) -> auto& { return c.lattice3d.cells.cell; }));
  t.push_back(positive("lattice3d.cell", "mm", 10000, "unit cell side", "cell",
                       [](C& c) -> auto& { return c.lattice3d.cells.size; }));
  {
    Setting s = numbers_via("lattice3d.count", "", 1, 1000, 3, "cells along X, Y, Z", "count",
        [](const Config& c) {
      const auto& p = c.lattice3d.cells;
      return (std::vector<double>{double(p.nx), double(p.ny), double(p.nz)});
    },
        [](Config& c, const std::vector<double>& xs) {
      auto& p = c.lattice3d.cells;
      p.nx = int(xs[0]), p.ny = int(xs[1]), p.nz = int(xs[2]);
    });
    s.whole = true;
    t.push_back(std::move(s));
  }
  {
    Setting s = numbers_via("lattice3d.box", "mm", 0, 100000, 3, "foam box width, depth, height", "box",
        [](const Config& c) {
      const auto& f = c.lattice3d.foam;
      return (std::vector<double>{f.width, f.depth, f.height});
    },
        [](Config& c, const std::vector<double>& xs) {
      auto& f = c.lattice3d.foam;
      f.width = xs[0], f.depth = xs[1], f.height = xs[2];
    });
    s.positive = true;
    t.push_back(std::move(s));
  }
  t.push_back(derived(positive("lattice3d.skin", "mm", 1000,
                               "conformal: a stochastic (Voronoi) skin this thick", "skin",
                               [](C& c) -> auto& { return c.lattice3d.conformal.skin; }),
                      "none"));
  t.push_back(positive("lattice3d.skin_density", "1/mm³", 100, "conformal: skin foam seeds per mm³",
                       "skin-density", [](C& c) -> auto& { return c.lattice3d.conformal.skin_density; }));
  t.push_back(positive("lattice3d.radius", "mm", 100,
                       "strut radius written to a 3MF beam lattice (-o part.3mf)", "radius",
                       [](C& c) -> auto& { return c.lattice3d.radius; }));
  t.push_back(path("lattice3d.mesh", "foam: inside this closed mesh instead of the box; conformal: the mesh to fill", "mesh",
                   [](C& c) -> auto& { return c.lattice3d.foam.mesh; }));
  t.push_back(positive("lattice3d.density", "1/mm³", 100, "foam seeds per mm³", "density",
                       [](C& c) -> auto& { return c.lattice3d.foam.density; }));
  t.push_back(integer("lattice3d.seed", 0, 9e15, "foam random seed", "seed",
                      [](C& c) -> auto& { return c.lattice3d.foam.seed; }));
  t.push_back(choice_enum<MaterialRule>("lattice3d.materials",
                                        {{"none", MaterialRule::None},
                                         {"xy-plane", MaterialRule::XyPlane},
                                         {"component", MaterialRule::Component},
                                         {"vertical", MaterialRule::Vertical}},
                     "per-strut material rule", "materials",
                     [](C& c) -> auto& { return c.lattice3d.materials; }));

  // lattice.*: reading lattice files.
  t.push_back(number("lattice.merge_tolerance", "mm", 0, 1, "merge nodes closer than this",
                     "merge-tolerance", [](C& c) -> auto& { return c.merge_tolerance; }));
  t.push_back(boolean("lattice.keep_graph",
                      "the lattice exactly as given: no node merging, no T-junction splitting",
                      "keep-graph", [](C& c) -> auto& { return c.keep_graph; }));

  // layers.* and onto.*: GIPPO parts of many layers, on solids and surfaces.
  t.push_back(integer("layers.count", 0, 100000,
                      "layers of the 2D pattern (0 with layers.solid: from its height)", "layers",
                      [](C& c) -> auto& { return c.layers.count; }));
  t.push_back(number("layers.rotation", "deg", -360, 360, "pattern rotation added per layer",
                     "layer-rotation", [](C& c) -> auto& { return c.layers.rotation_deg; }));
  t.push_back(path("layers.solid", "closed mesh each layer's pattern is cropped to", "solid",
                   [](C& c) -> auto& { return c.layers.solid; }));
  t.push_back(choice_named<OntoKind>("onto.kind", 4,
                     "lay the planned layers on a surface (empty: flat)", "onto",
                     [](C& c) -> auto& { return c.onto.kind; }));
  t.push_back(positive("onto.radius", "mm", 1e5, "sphere-cap radius", "",
                       [](C& c) -> auto& { return c.onto.radius; }));
  t.push_back(positive("onto.diameter", "mm", 1e5, "sphere-cap footprint diameter", "",
                       [](C& c) -> auto& { return c.onto.diameter; }));
  t.push_back(path("onto.file", "surface mesh (onto.kind = mesh)", "",
                   [](C& c) -> auto& { return c.onto.file; }));
  t.push_back(text("onto.height_fn", "surface z = f(x, y) (onto.kind = function)", "",
                   [](C& c) -> auto& { return c.onto.height_fn; }));
  t.push_back(derived(numbers("onto.domain", "mm", -1e5, 1e5, 4, "x0, y0, x1, y1 of onto.height_fn",
                              "", [](C& c) -> auto& { return c.onto.domain; }),
                      "none (needed with onto.kind = function)"));
  t.push_back(choice_enum<OffsetMode>("onto.offset",
                                      {{"normal", OffsetMode::Normal}, {"vertical", OffsetMode::Vertical}},
                                      "layers stack along the surface normal or vertically", "",
                                      [](C& c) -> auto& { return c.onto.project.offset; }));
  t.push_back(positive("onto.chord_tolerance", "mm", 10, "max distance of a path from the surface",
                       "", [](C& c) -> auto& { return c.onto.project.chord_tolerance; }));

  // plan.*, gippo.*
  t.push_back(choice_named<LatticePlanner>("plan.planner", 3,
                     "gippo (paper), euler (minimum paths) or aero (3D, embedded)", "",
                     [](C& c) -> auto& { return c.planner; }));
  t.push_back(choice_enum<PathOrder>(
      "plan.order", {{"longest-first", PathOrder::LongestFirst}, {"travel", PathOrder::Travel}},
      "path order: longest-first (paper) or travel (nearest neighbour + 2-opt)", "order",
      [](C& c) -> auto& { return c.plan.order; }));
  t.push_back(boolean("plan.merge_ends",
                      "join paths that end at the same node into one (fewer paths and starts; "
                      "GIPPO keeps its paths as grown otherwise)",
                      "merge-ends", [](C& c) -> auto& { return c.plan.merge_ends; }));
  t.push_back(integer("plan.long_path_nodes", 2, 1e6, "LTS/OE: a path is long with this many nodes",
                      "long-nodes", [](C& c) -> auto& { return c.plan.long_path_nodes; }));
  t.push_back(integer("plan.seed", 0, 9e15, "random seed (gippo iterations, aero shuffled runs)",
                      "seed", [](C& c) -> auto& { return c.plan.gippo.seed; }));
  t.push_back(choice_enum<GippoMode>("gippo.mode", {{"max", GippoMode::Max}, {"min", GippoMode::Min}},
                                     "take the longest (max) or shortest (min) edge", "mode",
                                     [](C& c) -> auto& { return c.plan.gippo.mode; }));
  t.push_back(integer("gippo.iterations", 1, 1e7, "solutions generated, best kept (paper: 500)",
                      "iterations", [](C& c) -> auto& { return c.plan.gippo.iterations; }));
  t.push_back(boolean("gippo.worst",
                      "also write the lowest-score solution beside the best (NAME.worst.json, "
                      "worst_layer_*.png previews), as the paper compares them",
                      "worst", [](C& c) -> auto& { return c.plan.keep_worst; }));
  t.push_back(integer("gippo.seeds", 0, 100000,
                      "robustness: also run seeds plan.seed .. +N-1 and report the best score's "
                      "spread (paper Fig. 2 v-vi); 0 = off", "seeds",
                      [](C& c) -> auto& { return c.gippo_seeds; }));

  // aero.*, nozzle.*
  t.push_back(choice_enum<AeroMethod>(
      "aero.method",
      {{"dynamic", AeroMethod::Dynamic}, {"groups", AeroMethod::Groups}, {"periodic", AeroMethod::Periodic}},
      "dynamic (refresh after every trail), groups (the paper's) or periodic (the paper's "
      "semi-manual baseline: a hand-made cell path repeated per cell)", "method",
      [](C& c) -> auto& { return c.aero.method; }));
  t.push_back(derived(choice_enum<UnitCell>(
                          "aero.cell_type",
                          {{"octet", UnitCell::Octet}, {"bcc", UnitCell::Bcc}, {"cubic", UnitCell::Cubic}},
                          "periodic: the lattice's unit cell (its hand-made path is repeated)",
                          "periodic-cell", [](C& c) -> auto& { return c.aero.periodic.cell; }),
                      "lattice3d.cell_type"));
  t.push_back(derived(positive("aero.cell", "mm", 10000,
                               "periodic: the lattice's cell side (a cell corner at its lowest corner)",
                               "periodic-size", [](C& c) -> auto& { return c.aero.periodic.size; }),
                      "lattice3d.cell"));
  t.push_back(integer("aero.print_path", 1, 2,
                      "periodic bcc: Print Path 1 (nodes side by side) or 2 (crossing traces), "
                      "the paper's Fig. 3b", "print-path",
                      [](C& c) -> auto& { return c.aero.periodic.print_path; }));
  t.push_back(boolean("aero.collisions", "plan around the nozzle (false: trails = Euler lower bound)",
                      "collisions", [](C& c) -> auto& { return c.aero.collisions; }));
  t.push_back(boolean("aero.fewest_collisions",
                      "break obstruction cycles where it costs the fewest collisions (proven "
                      "minimal where the exact solver finishes); false = the greedy order",
                      "fewest-collisions", [](C& c) -> auto& { return c.aero.fewest_collisions; }));
  t.push_back(integer("aero.exact_struts", 0, 1e7,
                      "solve obstruction cycles exactly (integer program) in parts up to this many "
                      "struts; 0 = local search only", "exact-struts",
                      [](C& c) -> auto& { return c.aero.order.exact_max_struts; }));
  t.push_back(derived(integer("aero.tries", 1, 100000,
                              "dynamic: planner runs (strategies, then shuffled orders; best kept)",
                              "tries", [](C& c) -> auto& { return c.aero.tries; }),
                      "8, fewer above 25,000 struts"));
  t.push_back(positive("nozzle.radius", "mm", 100, "nozzle radius R (vertical cylinder)",
                       "nozzle-radius", [](C& c) -> auto& { return c.aero.nozzle.radius; }));
  t.push_back(number("nozzle.tip_clearance", "mm", 0, 100,
                     "material less than this above the tip is not hit", "tip-clearance",
                     [](C& c) -> auto& { return c.aero.nozzle.tip_clearance; }));
  t.push_back(number("nozzle.node_clearance", "mm", 0, 100,
                     "no collision within this of a node the two struts share", "node-clearance",
                     [](C& c) -> auto& { return c.aero.nozzle.node_clearance; }));
  t.push_back(number("nozzle.cone", "deg", 0, 90,
                     "struts within this angle of vertical print bottom-up", "cone",
                     [](C& c) -> auto& { return c.aero.nozzle.cone_half_angle_deg; }));
  t.push_back(number("nozzle.overlap", "mm", 0, 10,
                     "the writer's node overlap: struts planned as if this much longer", "overlap",
                     [](C& c) -> auto& { return c.aero.nozzle.end_overlap; }));

  // slice.*, fgm.*
  t.push_back(choice_enum<SliceRoute>(
      "slice.route", {{"auto", SliceRoute::Auto}, {"field", SliceRoute::Field}, {"mesh", SliceRoute::Mesh}},
      "auto (.vcad: field, meshes: mesh), field (contours of the implicit field) or mesh (plane cuts)",
      "route", [](C& c) -> auto& { return c.slice.route; }));
  t.push_back(integer("slice.walls", 0, 100, "number of walls", "walls",
                      [](C& c) -> auto& { return c.slice.planar.walls; }));
  t.push_back(number("slice.infill", "", 0, 1, "sparse infill density (fraction of solid)",
                     "infill", [](C& c) -> auto& { return c.slice.planar.infill_density; }));
  t.push_back(number("slice.infill_angle", "deg", -360, 360, "infill angle, +90 every other layer",
                     "infill-angle", [](C& c) -> auto& { return c.slice.planar.infill_angle; }));
  t.push_back(integer("slice.top", 0, 1000, "solid top layers", "top",
                      [](C& c) -> auto& { return c.slice.planar.top_layers; }));
  t.push_back(integer("slice.bottom", 0, 1000, "solid bottom layers", "bottom",
                      [](C& c) -> auto& { return c.slice.planar.bottom_layers; }));
  t.push_back(derived(positive("slice.bead_width", "mm", 10, "bead width (wall and fill spacing)",
                               "bead-width", [](C& c) -> auto& { return c.slice.planar.bead_width; }),
                      "extrusion.nozzle_diameter"));
  t.push_back(positive("slice.resolution", "mm", 10, "XY grid step of field contours",
                       "resolution", [](C& c) -> auto& { return c.slice.field.resolution; }));
  t.push_back(positive("slice.mesh_voxel", "mm", 10, "voxel of mesh distance fields (field route)",
                       "mesh-voxel", [](C& c) -> auto& { return c.slice.mesh_voxel; }));
  t.push_back(boolean("slice.repair",
                      "repair meshes that are not closed and manifold (stitch seams, drop "
                      "degenerate and duplicate faces, orient, fill small holes, split "
                      "non-manifold edges); --no-repair refuses them",
                      "repair", [](C& c) -> auto& { return c.slice.repair; }));
  t.push_back(choice_enum<InfillPattern>(
      "slice.infill_pattern",
      {{"rectilinear", InfillPattern::Rectilinear}, {"grid", InfillPattern::Grid},
       {"triangles", InfillPattern::Triangles}, {"honeycomb", InfillPattern::Honeycomb},
       {"gyroid", InfillPattern::Gyroid}, {"concentric", InfillPattern::Concentric},
       {"lattice", InfillPattern::Lattice}},
      "sparse infill: rectilinear (lines, turned 90° every layer), grid, triangles, honeycomb, "
      "gyroid, concentric, or lattice (the 2D lattice slice.infill_lattice cropped to the infill "
      "and planned by the Euler planner into the fewest paths); the density sets the spacing",
      "infill-pattern", [](C& c) -> auto& { return c.slice.planar.infill_pattern; }));
  t.push_back(choice("slice.infill_lattice", pattern_names(),
                     "slice.infill_pattern = lattice: which 2D lattice (lattice2d patterns), its "
                     "cell size set by the density",
                     "infill-lattice", [](C& c) -> auto& { return c.slice.planar.infill_lattice; }));
  t.push_back(integer("slice.infill_seed", 0, 9e15, "lattice infill: the Voronoi seed",
                      "infill-seed", [](C& c) -> auto& { return c.slice.planar.infill_seed; }));
  t.push_back(choice_enum<Seam>(
      "slice.seam",
      {{"aligned", Seam::Aligned}, {"nearest", Seam::Nearest}, {"rear", Seam::Rear},
       {"random", Seam::Random}},
      "where each wall loop starts: aligned (a sharp corner, else the rear-most point: the same "
      "place on every layer), nearest (where the nozzle is), rear (largest Y), random (drawn "
      "from slice.seam_seed)",
      "seam", [](C& c) -> auto& { return c.slice.planar.link.seam; }));
  t.push_back(integer("slice.seam_seed", 0, 9e15, "random seams: the seed", "seam-seed",
                      [](C& c) -> auto& { return c.slice.planar.link.seed; }));
  t.push_back(boolean("slice.connect",
                      "join skin and infill lines along the edge of their region into "
                      "serpentines (as PrusaSlicer's connected rectilinear infill); --no-connect "
                      "prints every line as a path of its own",
                      "connect", [](C& c) -> auto& { return c.slice.planar.link.connect; }));
  t.push_back(positive("slice.connect_max", "", 1000,
                       "longest connector between two fill lines along their region's edge, in "
                       "line spacings (a longer gap starts a new path)",
                       "connect-max", [](C& c) -> auto& { return c.slice.planar.link.connect_max; }));
  t.push_back(boolean("slice.comb",
                      "keep travel inside the part (crossing no outer wall) where a route inside "
                      "is at most slice.comb_detour times the straight distance; such travel does "
                      "not retract (retraction.inside_max); --no-comb: straight travel, every one "
                      "treated as leaving the part",
                      "comb", [](C& c) -> auto& { return c.slice.planar.link.comb; }));
  t.push_back(positive("slice.comb_detour", "", 100,
                       "longest route inside the part, as a multiple of the straight distance "
                       "(plus one bead); a longer one goes straight and retracts",
                       "comb-detour", [](C& c) -> auto& { return c.slice.planar.link.comb_detour; }));
  {
    Setting strategy = integer(
        "slice.strategy", 0, 2,
        "graded designs (FGM paper): 1 walls/infill cut by colour faces + purge, 2 colour faces "
        "filled densely, none (0) one material on purpose; a graded design without it is an error",
        "strategy", [](C& c) -> auto& { return c.slice.strategy; });
    strategy.names = {{"none", 0}};
    t.push_back(std::move(strategy));
  }
  t.push_back(integer("fgm.colors", 1, 1000,
                      "palette size (two materials: N bands; three: d² triangles, e.g. 9)",
                      "colors", [](C& c) -> auto& { return c.slice.fgm.palette.colors; }));
  t.push_back(choice_enum<FgmOrder>(
      "fgm.order", {{"paths", FgmOrder::Paths}, {"faces", FgmOrder::Faces}},
      "graded print order: paths (Strategy 1: the planar order kept, each path cut at the colour "
      "faces into one bead whose mixture changes where it crosses them, each change issued "
      "gradient.lookahead early, no prime tower; a tool changer groups the pieces by tool, nearest "
      "first; Strategy 2 on a mixing or temperature machine: each island filled whole, "
      "fgm.perimeters rings and lines along the iso-lines joined into few beads, cut at the colour "
      "faces the same way) or faces (the FGM paper's colour-by-colour order: Strategy 1 with a "
      "purge before each colour change, Strategy 2 each face filled on its own)",
      "order", [](C& c) -> auto& { return c.slice.fgm.order; }));
  t.push_back(boolean("fgm.concentric",
                      "Strategy 2: each colour face filled with concentric rings instead of lines "
                      "(face by face, in either order)",
                      "concentric", [](C& c) -> auto& { return c.slice.fgm.concentric; }));
  t.push_back(boolean("fgm.fixed_angle",
                      "Strategy 2: lines at slice.infill_angle instead of along the iso-lines",
                      "fixed-angle", [](C& c) -> auto& { return c.slice.fgm.fixed_angle; }));
  t.push_back(positive("fgm.material_resolution", "mm", 100,
                       "XY grid of the material iso-contours", "material-resolution",
                       [](C& c) -> auto& { return c.slice.fgm.material_resolution; }));
  t.push_back(number("fgm.zipper", "", 0, 1,
                     "Strategy 1: overlap band β (fraction of the gradient) where colours alternate",
                     "zipper", [](C& c) -> auto& { return c.slice.fgm.zipper; }));
  t.push_back(integer("fgm.perimeters", 1, 100,
                      "Strategy 2, rectilinear: rings around each island's outline (path order) or "
                      "each colour face (face order) before its lines (the FGM paper's palette "
                      "plates: 3)",
                      "fgm-perimeters", [](C& c) -> auto& { return c.slice.fgm.perimeters; }));
  t.push_back(number("fgm.min_segment", "mm", 0, 1000,
                     "pieces (Strategy 1) and paths (Strategy 2) shorter than this are joined to "
                     "a touching piece of another colour where the design stays within α/2 of "
                     "its colour, the rest kept and counted (FGM paper §3.4.3: ~5 mm); 0 = off",
                     "min-segment", [](C& c) -> auto& { return c.slice.fgm.min_segment; }));

  // process.*: fprocess fields of a design
  t.push_back(positive("process.temperature_step", "°C", 100,
                       "quantum of a temperature field: written rounded to it (within half a "
                       "step), a path split where the rounded value changes",
                       "temperature-step",
                       [](C& c) -> auto& { return c.slice.process.temperature_step; }));
  t.push_back(positive("process.speed_step", "mm/s", 1000, "quantum of a speed field (as above)",
                       "speed-step", [](C& c) -> auto& { return c.slice.process.speed_step; }));
  t.push_back(positive("process.flow_step", "", 10, "quantum of a flow (extrusion multiplier) field",
                       "flow-step", [](C& c) -> auto& { return c.slice.process.flow_step; }));
  t.push_back(positive("process.fan_step", "%", 100, "quantum of a fan field",
                       "fan-step", [](C& c) -> auto& { return c.slice.process.fan_step; }));
  t.push_back(positive("process.sample", "mm", 100,
                       "spacing of the field samples along each path (changes between samples "
                       "are found by bisection)",
                       "process-sample", [](C& c) -> auto& { return c.slice.process.sample; }));
  t.push_back(number("process.min_length", "mm", 0, 1000,
                     "pieces of a path shorter than this are merged into a neighbour (their "
                     "deviation from the field is reported, a warning beyond half a step)",
                     "process-min-length", [](C& c) -> auto& { return c.slice.process.min_length; }));

  // pbf.*
  t.push_back(choice_named<TpmsKind>("pbf.cell_type", 5,
                     "TPMS of the sheet", "cell-type", [](C& c) -> auto& { return c.pbf.cell_type; }));
  t.push_back(positive("pbf.cell", "mm", 1000, "TPMS cell size", "cell",
                       [](C& c) -> auto& { return c.pbf.cell; }));
  t.push_back(text("pbf.c", "sheet parameter c (Φ = φ² − c²): a number or an expression of x, y, z, rho, r",
                   "c", [](C& c) -> auto& { return c.pbf.c; }));
  t.push_back(derived(positive("pbf.thickness", "mm", 100,
                               "uniform wall thickness t: c = t·|∇φ|/2 instead of pbf.c", "thickness",
                               [](C& c) -> auto& { return c.pbf.thickness; }),
                      "none: the sheet parameter pbf.c"));
  t.push_back(derived(numbers("pbf.size", "mm", 0, 10000, 3, "box X, Y, Z centred at the origin",
                              "size", [](C& c) -> auto& { return c.pbf.size; }),
                      "4 cells a side"));
  t.push_back(path("pbf.envelope", ".vcad solid the lattice fills instead of the box", "envelope",
                   [](C& c) -> auto& { return c.pbf.envelope; }));
  t.push_back(path("pbf.solids", ".vcad solid parts (bosses), hatched", "solids",
                   [](C& c) -> auto& { return c.pbf.solids; }));
  t.push_back(text("pbf.grade_to", "TYPE:CELL blended in by a sigmoid (graded cell size)",
                   "grade-to", [](C& c) -> auto& { return c.pbf.grade_to; }));
  t.push_back(choice_named<GradeAxis>("pbf.grade_axis", 2, "grading axis: z (axial) or r (radial)",
                     "grade-axis", [](C& c) -> auto& { return c.pbf.grade_axis; }));
  t.push_back(number("pbf.grade_center", "mm", -1e5, 1e5, "sigmoid centre", "grade-center",
                     [](C& c) -> auto& { return c.pbf.grade_center; }));
  t.push_back(positive("pbf.grade_width", "mm", 1e5, "sigmoid width", "grade-width",
                       [](C& c) -> auto& { return c.pbf.grade_width; }));
  t.push_back(text("pbf.hierarchical", "TYPE:CELL:WEIGHT superposed (hierarchical lattice)",
                   "hierarchical", [](C& c) -> auto& { return c.pbf.hierarchical; }));
  t.push_back(choice_named<PbfRoute>("pbf.route", 2,
                     "direct (slice the field) or stl (marching cubes mesh, for comparison)",
                     "route", [](C& c) -> auto& { return c.pbf.route; }));
  t.push_back(choice_named<PbfStrategy>("pbf.strategy", 6,
                     "TPMS sheets: hybrid (contours on thin walls, hatch at joints) or r67 (hatch "
                     "everything); solid parts (a mesh, or a .vcad with a solid strategy): "
                     "rectilinear, meander (hybrid and r67 on a mesh), stripe or island "
                     "(checkerboard), inside the contours",
                     "strategy", [](C& c) -> auto& { return c.pbf.strategy; }));
  t.push_back(derived(positive("pbf.wall_thickness", "mm", 100,
                               "a plane thin wall of this thickness instead of a TPMS (PBF paper "
                               "Fig. 3; box from pbf.size, default 2,2,20)", "wall-thickness",
                               [](C& c) -> auto& { return c.pbf.wall_thickness; }),
                      "none: a TPMS"));
  t.push_back(positive("pbf.wall_inclination", "deg", 90, "the wall's angle from horizontal",
                       "wall-inclination", [](C& c) -> auto& { return c.pbf.wall_inclination; }));
  t.push_back(number("pbf.wall_azimuth", "deg", -360, 360, "the wall's direction from X",
                     "wall-azimuth", [](C& c) -> auto& { return c.pbf.wall_azimuth; }));
  t.push_back(number("pbf.hatch_rotation", "deg", -360, 360, "hatch rotation per layer (paper: 67)",
                     "hatch-rotation", [](C& c) -> auto& { return c.pbf.options.hatch_rotation; }));
  t.push_back(integer("pbf.contours", 0, 20,
                      "solid parts: contour offsets per layer region, the first at the beam "
                      "compensation (0: hatch only)",
                      "contours", [](C& c) -> auto& { return c.pbf.contours; }));
  t.push_back(derived(positive("pbf.contour_distance", "mm", 10,
                               "solid parts: between contours, and from the last one to the hatch",
                               "contour-distance",
                               [](C& c) -> auto& { return c.pbf.contour_distance; }),
                      "scan.hatch_distance"));
  t.push_back(derived(positive("pbf.skin_thickness", "mm", 100,
                               "solid parts: the core, at least this far inside the part's "
                               "surface (in XY and in the layers above and below), is hatched "
                               "with the core parameters (laser.core_*, pbf.core_hatch_*); the "
                               "rest is skin",
                               "skin-thickness", [](C& c) -> auto& { return c.pbf.skin.skin_thickness; }),
                      "none: no core"));
  t.push_back(derived(positive("pbf.upskin_thickness", "mm", 100,
                               "solid parts: the part of a layer with no material somewhere in "
                               "this thickness of layers above it is up-skin (laser.upskin_*)",
                               "upskin-thickness",
                               [](C& c) -> auto& { return c.pbf.skin.upskin_thickness; }),
                      "none: no up-skin"));
  t.push_back(derived(positive("pbf.downskin_thickness", "mm", 100,
                               "solid parts: the part of a layer with no material somewhere in "
                               "this thickness of layers below it is down-skin (laser.downskin_*)",
                               "downskin-thickness",
                               [](C& c) -> auto& { return c.pbf.skin.downskin_thickness; }),
                      "none: no down-skin"));
  // Each kind's own hatch (core, up-skin, down-skin): pbf.<kind>_hatch_distance, _rotation.
  for (const HatchKind kind : {HatchKind::Core, HatchKind::UpSkin, HatchKind::DownSkin}) {
    const std::string name = hatch_kind_name(kind);
    const std::string what = kind == HatchKind::Core     ? "the core"
                             : kind == HatchKind::UpSkin ? "up-skin"
                                                         : "down-skin";
    const auto k = static_cast<std::size_t>(kind);
    t.push_back(derived(positive("pbf." + name + "_hatch_distance", "mm", 5,
                                 "solid parts: hatch distance in " + what, name + "-hatch",
                                 [k](C& c) -> auto& { return c.pbf.kind_hatch_distance[k]; }),
                        "scan.hatch_distance"));
    t.push_back(derived(numbers("pbf." + name + "_hatch_rotation", "deg", -360, 360, 1,
                                "solid parts: hatch rotation per layer in " + what, "",
                                [k](C& c) -> auto& { return c.pbf.kind_rotation[k]; }),
                        "pbf.hatch_rotation"));
  }
  t.push_back(positive("pbf.stripe_width", "mm", 1000, "stripe: width across the hatch lines",
                       "stripe-width", [](C& c) -> auto& { return c.pbf.pattern.stripe_width; }));
  t.push_back(number("pbf.stripe_overlap", "mm", 0, 100, "stripe: neighbouring stripes overlap",
                     "stripe-overlap", [](C& c) -> auto& { return c.pbf.pattern.stripe_overlap; }));
  t.push_back(positive("pbf.island_size", "mm", 1000, "island: side of the square islands",
                       "island-size", [](C& c) -> auto& { return c.pbf.pattern.island_size; }));
  t.push_back(number("pbf.island_overlap", "mm", 0, 100, "island: neighbouring islands overlap",
                     "island-overlap", [](C& c) -> auto& { return c.pbf.pattern.island_overlap; }));
  t.push_back(number("pbf.island_shift", "mm", 0, 1000,
                     "island: the island grid moves this far along both its axes every layer",
                     "island-shift", [](C& c) -> auto& { return c.pbf.pattern.island_shift; }));
  t.push_back(boolean("pbf.binary", "binary CLI geometry (the header stays ASCII, with CLI+ blocks)",
                      "binary", [](C& c) -> auto& { return c.pbf.binary; }));
  t.push_back(positive("pbf.resolution", "mm", 10,
                       "sampling step: the STL route's voxel; direct contours on a grid twice as coarse",
                       "resolution", [](C& c) -> auto& { return c.pbf.options.resolution; }));
  t.push_back(positive("pbf.thin_multiple", "", 100, "thin wall: width <= this × melt pool",
                       "thin-multiple", [](C& c) -> auto& { return c.pbf.options.thin_multiple; }));
  t.push_back(number("pbf.min_inclination", "deg", 0, 90, "shallower walls are hatched",
                     "min-inclination", [](C& c) -> auto& { return c.pbf.options.min_inclination; }));
  t.push_back(choice_enum<HatchPhase>(
      "pbf.hatch_phase",
      {{"wall", HatchPhase::Wall}, {"origin", HatchPhase::Origin}, {"random", HatchPhase::Random}},
      "where hatch lines are fixed each layer: through the design's origin (wall: the Fig. 3 "
      "wall's centre, a solid part's origin), through the machine origin (pbf.plate_position "
      "places the part), or moved by a random fraction of the hatch distance (seeded by "
      "pbf.hatch_seed)",
      "hatch-phase", [](C& c) -> auto& { return c.pbf.options.hatch_phase; }));
  t.push_back(derived(numbers("pbf.plate_position", "mm", -10000, 10000, 2,
                              "where the design's origin sits on the build plate (X, Y from the "
                              "machine origin): the origin hatch phase's grid",
                              "plate-position", [](C& c) -> auto& { return c.pbf.plate_position; }),
                      "the plate's centre"));
  t.push_back(integer("pbf.hatch_seed", 0, 9e15, "random hatch phase: seed of the layers' shifts",
                      "hatch-seed", [](C& c) -> auto& { return c.pbf.options.hatch_seed; }));
  t.push_back(choice_enum<PbfSplit>(
      "pbf.split", {{"width", PbfSplit::Width}, {"inclination", PbfSplit::Inclination}},
      "thin walls against joints: width <= pbf.thin_multiple × D and steeper than "
      "pbf.min_inclination (width), or the paper's c interpolated by the mid-surface's inclination "
      "from 0 at pbf.min_inclination to c 10° steeper, Eq. 6 / Fig. S5 (inclination)",
      "split", [](C& c) -> auto& { return c.pbf.options.split; }));
  t.push_back(number(
      "pbf.laser_overlap", "mm", 0, 1000,
      "neighbouring lasers' stripes overlap: a vector crossing a boundary by at "
      "most half this goes whole to one laser, a longer one is cut there",
      "laser-overlap", [](C& c) -> auto& { return c.pbf.laser_overlap; }));
  t.push_back(choice_enum<LaserAxis>(
      "pbf.laser_split_axis", {{"x", LaserAxis::X}, {"y", LaserAxis::Y}, {"auto", LaserAxis::Auto}},
      "the lasers' stripes follow one another along X (laser 1 leftmost), along Y (laser 1 at the "
      "front), or per layer along the axis that builds it sooner (auto)",
      "laser-split-axis", [](C& c) -> auto& { return c.pbf.laser_split_axis; }));

  // nonplanar.*, surface.*
  t.push_back(derived(positive("nonplanar.bead_width", "mm", 100, "path width = plane spacing",
                               "bead-width", [](C& c) -> auto& { return c.nonplanar.params.width; }),
                      "extrusion.nozzle_diameter"));
  t.push_back(integer("nonplanar.layers", 1, 1e6, "number of layers", "layers",
                      [](C& c) -> auto& { return c.nonplanar.params.layers; }));
  t.push_back(numbers("nonplanar.angles", "deg", -360, 360, 0,
                      "path directions cycled over the layers (0,90 = cross-hatch; 0 = parallel)",
                      "angles", [](C& c) -> auto& { return c.nonplanar.params.angles; }));
  t.push_back(choice_enum<OffsetMode>(
      "nonplanar.offset", {{"vertical", OffsetMode::Vertical}, {"normal", OffsetMode::Normal}},
      "layers stack vertically (paper) or along the surface normal", "offset",
      [](C& c) -> auto& { return c.nonplanar.params.offset; }));
  t.push_back(boolean("nonplanar.surface_spacing",
                      "lines one width apart along the surface (arc length), not in the slicing planes",
                      "surface-spacing", [](C& c) -> auto& { return c.nonplanar.params.spacing_along_surface; }));
  t.push_back(positive("nonplanar.chord_tolerance", "mm", 10,
                       "max distance of a path segment from the surface", "chord-tol",
                       [](C& c) -> auto& { return c.nonplanar.params.chord_tolerance; }));
  t.push_back(derived(positive("nonplanar.max_join", "mm", 1e5,
                               "longest end-to-end connector printed instead of a travel",
                               "max-join", [](C& c) -> auto& { return c.nonplanar.params.max_join; }),
                      "4 × bead width"));
  t.push_back(text("nonplanar.layer_tools",
                   "tools per layer: LAYERS:TOOL groups (3:0,3:1,3:0) or a tool list (0,1)",
                   "layer-tools", [](C& c) -> auto& { return c.nonplanar.layer_tools; }));
  t.push_back(boolean("nonplanar.planar_control",
                      "the planar control (non-planar paper, Fig. 3C/E): the solid the layers fill "
                      "sliced flat, each layer group's band in its tool",
                      "planar-control", [](C& c) -> auto& { return c.nonplanar.planar_control; }));
  t.push_back(text("nonplanar.height_fn", "surface z = f(x, y) instead of a mesh (muparser)",
                   "height-fn", [](C& c) -> auto& { return c.nonplanar.height_fn; }));
  t.push_back(derived(numbers("nonplanar.domain", "mm", -1e5, 1e5, 4,
                              "x0, y0, x1, y1 of the height function", "domain",
                              [](C& c) -> auto& { return c.nonplanar.domain; }),
                      "none (needed with nonplanar.height_fn)"));
  t.push_back(choice_named<SurfaceKind>("surface.kind", 5,
                     "generated test surface (non-planar paper)", "kind",
                     [](C& c) -> auto& { return c.surface.kind; }));
  t.push_back(positive("surface.length", "mm", 1e4, "length along X", "length",
                       [](C& c) -> auto& { return c.surface.corrugation.length; }));
  t.push_back(positive("surface.width", "mm", 1e4, "width along Y", "width",
                       [](C& c) -> auto& { return c.surface.corrugation.width; }));
  t.push_back(number("surface.periods", "", 0, 1000, "corrugation periods", "periods",
                     [](C& c) -> auto& { return c.surface.corrugation.periods; }));
  t.push_back(number("surface.angle", "deg", 0, 89, "corrugation slope", "angle",
                     [](C& c) -> auto& { return c.surface.corrugation.angle_deg; }));
  t.push_back(number("surface.amplitude_scale", "", 0, 10, "corrugation amplitude factor",
                     "amplitude-scale", [](C& c) -> auto& { return c.surface.corrugation.amplitude_scale; }));
  t.push_back(number("surface.fillet", "mm", 0, 100, "fillet diameter at peaks and valleys",
                     "fillet", [](C& c) -> auto& { return c.surface.corrugation.fillet_diameter; }));
  t.push_back(number("surface.flat", "mm", 0, 1000, "flat clamping end length", "flat",
                     [](C& c) -> auto& { return c.surface.corrugation.flat_length; }));
  t.push_back(number("surface.depth", "mm", 0, 1000, "Miura-Ori fold depth", "depth",
                     [](C& c) -> auto& { return c.surface.miura.depth; }));
  t.push_back(positive("surface.height", "mm", 1000, "M curve height", "height",
                       [](C& c) -> auto& { return c.surface.m_curve.height; }));
  t.push_back(positive("surface.radius", "mm", 1e5, "sphere-cap radius", "radius",
                       [](C& c) -> auto& { return c.surface.radius; }));
  t.push_back(positive("surface.diameter", "mm", 1e5, "sphere-cap footprint diameter", "diameter",
                       [](C& c) -> auto& { return c.surface.diameter; }));
  t.push_back(positive("surface.resolution", "mm", 100, "grid spacing of generated meshes",
                       "resolution", [](C& c) -> auto& { return c.surface.resolution; }));

  // output.*, run.*
  t.push_back(number("plate.clearance", "mm", 0, 1000,
                       "build plates ([[part]] tables): the least gap between parts' footprints",
                       "", [](C& c) -> auto& { return c.plate.clearance; }));
  t.push_back(choice_named<PlateSequence>("plate.sequence", 2,
                     "FDM plates: layers (layer i of every part, then layer i + 1) or parts (each "
                     "part whole before the next, where machine.extruder_clearance_radius and "
                     "_height allow)",
                     "", [](C& c) -> auto& { return c.plate.sequence; }));
  t.push_back(integer("output.preview_layers", 0, 100000, "PNG previews spread over the layers",
                      "preview-layers", [](C& c) -> auto& { return c.output.preview_layers; }));
  t.push_back(integer("output.image_size", 16, 8000, "preview image size", "image-size",
                      [](C& c) -> auto& { return c.output.image_size; }));
  t.push_back(boolean("output.gcode", "plan: also write G-code for the machine", "",
                      [](C& c) -> auto& { return c.output.gcode; }));
  t.push_back(boolean("output.png", "jobs: write previews", "",
                      [](C& c) -> auto& { return c.output.png; }));
  t.push_back(integer("output.frames", 0, 10000, "aero: step pictures of the first N trails",
                      "frames", [](C& c) -> auto& { return c.output.frames; }));
  t.push_back(integer("run.threads", 0, 1024, "worker threads (0 = all cores)", "threads",
                      [](C& c) -> auto& { return c.threads; }));
  t.push_back(derived(positive(
                          "run.max_memory", "MB", 1e9,
                          "refuse a run whose estimate (made from its settings before it "
                          "starts) needs more memory than this",
                          "max-memory", [](C& c) -> auto& { return c.budget.max_memory_mb; }),
                      "half the memory available when the run starts"));
  t.push_back(positive("run.max_time", "s", 1e9,
                       "refuse a run whose estimated time is longer than this", "max-time",
                       [](C& c) -> auto& { return c.budget.max_time; }));
  t.push_back(boolean("run.force", "run even when the estimate is beyond run.max_memory or run.max_time",
                      "force", [](C& c) -> auto& { return c.budget.force; }));
  t.push_back(boolean("run.progress",
                      "command line: progress on stderr (stage, %, ETA; --progress, "
                      "--no-progress): not given, on a terminal only; true, also into a pipe or "
                      "log, one line per update with the estimates made before the run; false, "
                      "never (Python: the progress= callback)",
                      "", [](C& c) -> auto& { return c.progress; }));
  t.push_back(boolean(
      "run.follow_symlinks",
      "write an output whose path is a symbolic link to the file it points to "
      "(the link kept); without it such an output is refused",
      "follow-symlinks", [](C& c) -> auto& { return c.follow_symlinks; }));

  // read.*, check.*, analyze.*, render.*, view.*: the reader routes (RouteSpec::reads).
  t.push_back(text("read.valve_on", "pneumatic files: the command that opens the valve (empty: "
                   "the machine profile's, else the file's header)", "valve-on",
                   [](C& c) -> auto& { return c.read.gcode.valve_on; }));
  t.push_back(text("read.valve_off", "pneumatic files: the command that closes the valve", "valve-off",
                   [](C& c) -> auto& { return c.read.gcode.valve_off; }));
  t.push_back(boolean("read.commanded_mixtures",
                      "graded G-code with a mixing look-ahead: read the mixtures as commanded (the "
                      "file's lines), not as deposited (the look-ahead undone, the default)",
                      "commanded-mixtures", [](C& c) -> auto& { return c.read.gcode.commanded_mixtures; }));
  t.push_back(boolean("read.strict", "stop at the first unreadable line (default: warn and skip)",
                      "strict", [](C& c) -> auto& { return c.read.gcode.stop_on_error; }));
  t.push_back(number("check.snap", "mm", 0, 100,
                     "segment ends within this of a node are at it (at this default, plus the "
                     "machine profile's node overlap)",
                     "snap", [](C& c) -> auto& { return c.read.snap; }));
  t.push_back(positive("analyze.bead_width", "mm", 100,
                       "bead width: deposits within width/2 cover a strut", "bead-width",
                       [](C& c) -> auto& { return c.read.analysis.width; }));
  t.push_back(number("analyze.layer_height", "mm", -100, 100, "nozzle z = design z + this",
                     "layer-height", [](C& c) -> auto& { return c.read.analysis.layer_height; }));
  t.push_back(number("analyze.acceleration", "mm/s²", 0, 1e6,
                     "for the print-time estimate when the file sets none (its M204 or our "
                     "header's speed.acceleration win; 0 = feed rates only)",
                     "acceleration", [](C& c) -> auto& { return c.read.analysis.acceleration; }));
  t.push_back(boolean("analyze.align",
                      "move the print's XY centre onto the design's (for parts placed on the bed; "
                      "done anyway, with a note, when the print lies mostly outside the design)",
                      "align", [](C& c) -> auto& { return c.read.analysis.align_centers; }));
  t.push_back(boolean("analyze.layers",
                      "also print a line per layer: extrusion starts (with a design, beside the "
                      "fewest paths its struts allow), retractions, travel moves and length",
                      "layers", [](C& c) -> auto& { return c.read.per_layer; }));
  t.push_back(positive("analyze.filament_diameter", "mm", 100,
                       "build plates: filament diameter for each part's volume",
                       "filament-diameter", [](C& c) -> auto& { return c.read.filament_diameter; }));
  t.push_back(choice_named<RenderColour>("render.colour", 7,
                     "what colour means: feature, order, mixture (as deposited), commanded (the "
                     "mixture as commanded), tool (laser) or set (laser parameter set: contour k, "
                     "core, up-/down-skin hatch); auto: tool for a laser file of several lasers, "
                     "else feature", "colour", [](C& c) -> auto& { return c.read.colour; }));
  t.push_back(derived(integer("render.layer", 0, 1e9, "layer index (0-based): one PNG, written to -o",
                              "layer", [](C& c) -> auto& { return c.read.layer; }),
                      "every layer, each OUT.layerNNN.png"));
  t.push_back(integer("render.image_size", 16, 8000, "image size in pixels", "image-size",
                      [](C& c) -> auto& { return c.read.render.size_px; }));
  t.push_back(derived(positive("render.bead_width", "mm", 100, "line width", "bead-width",
                               [](C& c) -> auto& { return c.read.render.bead_width; }),
                      "from the toolpath"));
  t.push_back(boolean("render.travel", "draw travel moves (dashed grey)", "travel",
                      [](C& c) -> auto& { return c.read.render.travel; }));
  t.push_back(text("view.title", "page title (empty: the file names)", "title",
                   [](C& c) -> auto& { return c.read.title; }));
  apply_when(t);
  return t;
}
// clang-format on

}  // namespace

const std::vector<Setting>& all_settings() {
  static const std::vector<Setting> table = make_table();
  return table;
}

const std::vector<std::pair<std::string, std::string>>& setting_sections() {
  static const std::vector<std::pair<std::string, std::string>> s = {
      {"machine", "the printer: name, G-code flavour, bed"},
      {"placement", "where the part goes on the bed"},
      {"extrusion", "nozzle, filament, layer height, Eq. 4 extrusion"},
      {"speed", "feed rates and acceleration"},
      {"temperature", "nozzle, bed, fan"},
      {"retraction", "retraction and Z hop"},
      {"flow", "pre- and post-flow"},
      {"pneumatic", "valve and pressure commands"},
      {"embedded", "printing in a support bath"},
      {"gradient", "how a mixture is made: mixing, tools, temperature"},
      {"purge", "Strategy 1 purge towers"},
      {"gcode", "start/end templates"},
      {"laser", "laser powder-bed machine: spot, powers, speeds, limits, build area"},
      {"scan", "laser scan parameters: layer, hatch, SL, LHD"},
      {"timing", "laser scanner timing for the scan-time model"},
      {"lasers", "lasers that differ: power, speed, spot and timing per laser"},
      {"lattice2d", "2D atlas patterns"},
      {"lattice3d", "3D unit cells and foams"},
      {"lattice", "reading lattice files"},
      {"layers", "GIPPO parts of many layers"},
      {"onto", "planned layers laid on a surface"},
      {"plan", "path planning"},
      {"gippo", "the GIPPO planner"},
      {"aero", "the AERO planner (3D, embedded)"},
      {"nozzle", "the nozzle model for collisions"},
      {"slice", "planar slicing"},
      {"fgm", "graded (FGM) slicing"},
      {"process", "process fields of a design (fprocess): quanta of temperature, speed, flow, fan"},
      {"pbf", "laser powder-bed TPMS lattices"},
      {"nonplanar", "non-planar layers on a surface"},
      {"surface", "generated test surfaces"},
      {"plate", "build plates of many parts ([[part]] tables)"},
      {"output", "previews and extra outputs"},
      {"run", "execution"},
      {"read", "reading prints back (check, analyze, compare, view, render)"},
      {"check", "trellis check: a print replayed against the nozzle model"},
      {"analyze", "trellis analyze and compare: a print measured against its design"},
      {"render", "trellis render: layer PNGs of a print"},
      {"view", "trellis view: the 3D viewer page"},
  };
  return s;
}

}  // namespace trellis
