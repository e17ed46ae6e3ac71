// The route commands (lattice2d, lattice3d, plan, gcode, slice, pbf, nonplanar, surface): their
// flags come from the settings schema; each builds a Job and hands it to the library.
#include <iostream>
#include <map>

#include "commands.hpp"
#include "progress_display.hpp"
#include "trellis/core/error.hpp"
#include "trellis/job/job.hpp"

namespace trellis::cli {

namespace {

// A command of a route (plan has one per planner): its flags and help. What the route itself is
// (its input, sections, streaming) comes from the library's route table (job/job.hpp RouteSpec).
struct CommandSpec {
  const char* name;
  const char* route;
  const char* description;
  std::vector<std::string> flag_sections;  // settings with a flag here become options
  bool input_required;                     // the route's input (RouteSpec::input) as a positional
  const char* output_doc;                  // -o
  int machine;                             // --machine: 0 none, 1 optional, 2 required
  bool toolpath;                           // --toolpath
  bool report;                             // --report
  std::string footer;
  // A setting given as a positional or by the command's name: plan's planners are subcommands
  // of `plan` (plan.planner), surface takes its kind (surface.kind) as an optional positional.
  const char* named_by = nullptr;
  const char* positional = nullptr;  // its help
  const char* machine_doc = "machine profile (TOML)";
};

struct RouteOpts {
  std::string input, extra, machine, output, report, toolpath, gcode, preview;
  std::vector<std::string> sets;
  SettingFlags flags;
  int progress = -1;  // --progress 1, --no-progress 0 (run.progress)
};

std::string help_of(const Setting& s) {
  std::string h = s.doc;
  if (!s.unit.empty() && s.unit != "path") h += " (" + s.unit + ")";
  h += "; " + s.key + ", default " + (s.derived.empty() ? s.default_text() : s.derived);
  if (s.kind == SettingKind::Choice || s.kind == SettingKind::Numbers) h += "; " + s.range_text();
  return h;
}

std::string command_line(int argc, char** argv) {
  std::string out;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (i == 0) a = "trellis";
    const bool quote = a.find_first_of(" \t\"'") != std::string::npos || a.empty();
    out += (i ? " " : "") + (quote ? "\"" + a + "\"" : a);
  }
  return out;
}

}  // namespace

namespace {
std::vector<std::string> command_words;
bool words_set = false;
}  // namespace

void set_command_words(int argc, char** argv) {
  command_words.assign(argv + (argc > 0 ? 1 : 0), argv + argc);
  words_set = true;
}

void SettingFlags::add(CLI::App* cmd, const std::vector<std::string>& sections,
                       const std::string& reader) {
  if (words_set &&
      std::find(command_words.begin(), command_words.end(), cmd->get_name()) == command_words.end())
    return;
  for (const auto& s : all_settings()) {
    if (s.flag.empty()) continue;
    if (!reader.empty() && !route_uses(s, reader)) continue;
    if (std::find(sections.begin(), sections.end(), s.section()) == sections.end()) continue;
    const std::string group = "Settings [" + s.section() + "]";
    if (s.kind == SettingKind::Bool) {
      cmd->add_flag_callback(
             "--" + s.flag, [this, key = s.key] { bools[key] = 1; }, help_of(s))
          ->group(group);
      cmd->add_flag_callback(
             "--no-" + s.flag, [this, key = s.key] { bools[key] = 0; }, "turn " + s.key + " off")
          ->group(group);
      continue;
    }
    auto* opt = cmd->add_option("--" + s.flag, values[s.key], help_of(s))->group(group);
    if (s.kind == SettingKind::Numbers)
      opt->type_name("LIST");
    else if (s.kind == SettingKind::Choice)
      opt->type_name("NAME");
    else if (s.kind == SettingKind::Text)
      opt->type_name(s.unit == "path" ? "FILE" : "TEXT");
    else
      opt->type_name(s.kind == SettingKind::Integer ? "INT" : "NUMBER");
    if (s.unit == "path") opt->check(path_value());
    options.emplace_back(s.key, opt);
  }
}

void SettingFlags::apply(Settings& st) const {
  for (const auto& [key, opt] : options)
    if (opt->count() > 0) st.set_text(key, values.at(key), {"--" + find_setting(key)->flag});
  for (const auto& [key, on] : bools)
    st.set(key, on != 0, {"--" + std::string(on ? "" : "no-") + find_setting(key)->flag});
}

namespace {

void apply_sets(Settings& st, const std::vector<std::string>& sets) {
  for (const auto& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos)
      throw SettingError("expected section.key=value, got '" + s + "'", {"", 0, "--set"});
    st.set_text(s.substr(0, eq), s.substr(eq + 1), {"--set"});
  }
}

}  // namespace

Settings command_settings(const std::string& machine, const std::vector<std::string>& sets) {
  Settings st;
  if (!machine.empty()) st.load_toml_file(machine);
  apply_sets(st, sets);
  return st;
}

void apply_command_line(Settings& st, const SettingFlags& flags, int progress,
                        const std::vector<std::string>& sets) {
  flags.apply(st);
  if (progress >= 0)
    st.set("run.progress", progress == 1, {progress ? "--progress" : "--no-progress"});
  apply_sets(st, sets);
}

void print_result(const JobResult& r, const Diagnostics& diag) {
  print_warnings(diag);
  std::cout << r.summary << "\n";
  if (!r.files.empty()) {
    std::cout << "wrote";
    for (std::size_t i = 0; i < r.files.size(); ++i) std::cout << (i ? ", " : " ") << r.files[i];
    std::cout << "\n";
  }
  if (r.exit_code) set_exit_code(r.exit_code);
}

void add_routes(CLI::App& app, int argc, char** argv) {
  const std::vector<std::string> m = machine_sections();
  auto with = [&](std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
  };
  std::string patterns;
  for (const auto& n : pattern_names()) patterns += (patterns.empty() ? "" : ", ") + n;
  std::string cells;
  for (const auto& n : unit_cell_names()) cells += (cells.empty() ? "" : ", ") + n;
  const std::string plan_footer =
      "Lattice formats: .json, NAME_vertices.csv/NAME_edges.csv (AERO), segment .csv, .obj.\n"
      "Planar levels (edges at one z) and materials are planned separately. With --machine and\n"
      "--gcode FILE the plan is also written as G-code. Example:\n"
      "  trellis plan gippo penrose.json -o penrose.toolpath.json --report penrose.report.json";
  auto* plan = app.add_subcommand("plan", "Plan print paths over a lattice: gippo, euler or aero");
  plan->require_subcommand(1);
  const std::vector<CommandSpec> specs = {
      {"lattice2d",
       "lattice2d",
       "Generate a 2D lattice from the atlas (lattice JSON)",
       {"lattice2d", "output", "run"},
       false,
       "lattice JSON to write",
       false,
       false,
       false,
       "Patterns: " + patterns +
           ".\nThe cell size means: honeycomb = hexagon side; penrose = rhombus side; snub-square "
           "= "
           "edge;\narrowhead, reentrant-honeycomb = horizontal period; square, triangle, lines = "
           "strand distance.\nThe pattern is generated over at least twice the region, rotated "
           "about "
           "the region centre,\nand cropped with a node where the crop cuts a strut.\nExample:\n"
           "  trellis lattice2d --pattern penrose --cell 1.2 --size 10,10 -o penrose.json "
           "--preview penrose"},
      {"lattice3d",
       "lattice3d",
       "Generate a 3D strut lattice: unit cells or a Voronoi foam (lattice JSON)",
       {"lattice3d", "output", "run"},
       false,
       "lattice JSON to write",
       false,
       false,
       false,
       "Unit cells: " + cells +
           ".\n--kind foam makes a stochastic Voronoi foam in a box (--box W,D,H) or inside a "
           "closed\n"
           "mesh (--mesh FILE), reproducible for --seed. Materials: none; xy-plane (struts in the "
           "XY\n"
           "plane 0, others 1); component (one per connected part); vertical (steep struts "
           "1).\nExample:\n"
           "  trellis lattice3d --cell-type octet --cell 7 --count 3,3,3 -o octet.json"},
      {"gippo", "plan", "GIPPO: the paper's randomized greedy path growth, best of N iterations",
       with({"lattice", "plan", "gippo", "output", "run"}, m), true, "toolpath JSON to write", true,
       false, true,
       "Each iteration grows paths from a random incomplete node, taking the longest (--mode max)\n"
       "or shortest (--mode min) unused edge at either end; the best score (Eq. 1) is kept.\n"
       "Reproducible for a --seed whatever the thread count.\n" +
           plan_footer,
       "plan.planner"},
      {"euler", "plan",
       "Euler: exactly the lower bound max(1, odd nodes / 2) of paths (Hierholzer)",
       with({"lattice", "plan", "output", "run"}, m), true, "toolpath JSON to write", true, false,
       true, plan_footer, "plan.planner"},
      {"aero", "plan", "AERO: collision-free Eulerian trails for 3D lattices printed in a bath",
       with({"lattice", "plan", "aero", "nozzle", "output", "run"}, m), true,
       "toolpath JSON to write", true, false, true,
       "The nozzle is a vertical cylinder (--nozzle-radius); struts within --cone of vertical "
       "print\n"
       "bottom-up; the plan is replayed by the independent collision checker and reported.\n" +
           plan_footer,
       "plan.planner"},
      {"gcode", "gcode",
       "Write G-code (or pneumatic / embedded .nc) from a toolpath and a machine profile",
       with({"run"}, m), true, "G-code file to write", 2, false, false,
       "Profiles are TOML files (profiles/); `trellis settings machine` lists every setting.\n"
       "Settings merge: defaults < profile < flags and --set."},
      {"slice", "slice",
       "Slice a design (.vcad) or a mesh (.stl, .obj, .3mf) into walls, skins and infill",
       with({"slice", "fgm", "process", "output", "run"}, m), true, "G-code file to write", 2, true,
       true,
       "A .vcad design is contoured straight from its implicit field at every layer (no mesh); a\n"
       "mesh is cut by planes (--route mesh, its default) or turned into a distance field first.\n"
       "The layer height is the profile's extrusion.layer_height unless --layer-height says\n"
       "otherwise; the bead width is the nozzle's unless --bead-width. Example:\n"
       "  trellis slice examples/designs/csg_bracket.vcad --machine "
       "profiles/ender3_s1_pro_tpu.toml\n"
       "      -o bracket.gcode --report bracket.json --preview bracket_preview"},
      {"pbf",
       "pbf",
       "Laser powder-bed toolpaths for a TPMS sheet lattice (from its field) or a solid part "
       "(.cli)",
       {"laser", "lasers", "scan", "timing", "pbf", "output", "run"},
       false,
       "CLI build file to write",
       true,
       true,
       true,
       "The sheet is Φ = φ² − c² around a TPMS mid-surface φ (--cell-type, --cell; c from --c or\n"
       "--thickness for uniform walls), inside a box (--size) or the solid of DESIGN.vcad. A\n"
       "DESIGN.vcad that is itself one TPMS sheet in its root box (gyroid(5, 0.3), maybe "
       "intersected\n"
       "with solids) is planned as it is: its φ, c and box, the lattice flags unused. Per\n"
       "layer: thin, steep walls get one contour track on φ = 0 cut into scan vectors (--sl, "
       "--lhd);\n"
       "joints are hatched at 67° more every layer. --strategy r67 hatches everything (the\n"
       "baseline); --route stl meshes the field first, for comparison. Scan settings come from "
       "the\n"
       "laser profile (--machine) unless flags say otherwise. A solid part (a mesh: STL, OBJ,\n"
       "3MF; or a .vcad with --strategy rectilinear|meander|stripe|island) is sliced and each "
       "layer\n"
       "scanned with --contours offsets, the first at the beam compensation, then hatched inside\n"
       "the last one by the strategy (island: --island-size, --island-overlap, --island-shift;\n"
       "stripe: --stripe-width, --stripe-overlap). Examples:\n"
       "  trellis pbf examples/designs/concave_cylinder.obj --strategy island --island-size 5 -o "
       "part.cli\n"
       "  trellis pbf --cell-type schwarz_d --cell 2.5 --size 10,10,10 --machine "
       "profiles/pbf_316l_25um.toml\n"
       "      -o lattice.cli --report lattice.json --preview previews",
       nullptr,
       nullptr,
       "laser profile (TOML); default: built-in values"},
      {"nonplanar", "nonplanar",
       "Slice a surface into continuous non-planar layers (embedded printing)",
       with({"nonplanar", "output", "run"}, m), false, "G-code to write", 2, true, true,
       "The surface is an open mesh (STL, OBJ, 3MF), --height-fn z(x,y) over --domain, or a\n"
       "generated test surface (--set surface.kind=corrugation). It must be a height field.\n"
       "Each layer is the surface cut by vertical planes one bead width apart (the nozzle's "
       "unless\n"
       "--bead-width), joined into one serpentine, lifted by the layer height (the profile's "
       "unless\n"
       "--layer-height). --angles 0,90 cross-hatches, --angles 0 keeps one direction.\n"
       "--layer-tools 3:0,3:1,3:0 prints 3 layers with tool 0, 3 with tool 1, 3 with tool "
       "0.\nExample:\n"
       "  trellis surface corrugation -o corrugation.stl\n"
       "  trellis nonplanar corrugation.stl --machine profiles/fresh_nonplanar_2syringe.toml -o "
       "corrugation.gcode"},
      {"surface",
       "surface",
       "Generate the non-planar paper's test surfaces (STL, OBJ or 3MF)",
       {"surface", "output", "run"},
       false,
       "mesh to write: .stl, .obj or .3mf (angle-test: .json, G-code or .3mf)",
       1,
       false,
       false,
       "Kinds (--kind): corrugation (--periods, --angle, --amplitude-scale, --fillet, --flat),\n"
       "miura (--depth), m-curve (--height), sphere-cap (--radius, --diameter), and angle-test,\n"
       "the print-angle test path (0, ±22.5, ±45, ±67.5, 90, −80°) written as toolpath JSON, or "
       "as\n"
       "G-code with --machine.",
       "surface.kind",
       "corrugation, miura, m-curve or sphere-cap (or --kind)"},
  };
  for (const auto& spec : specs) {
    auto o = std::make_shared<RouteOpts>();
    const std::string route = spec.route;
    const RouteSpec& data = route_spec(route);
    auto* cmd = (spec.named_by && !spec.positional ? plan : &app)
                    ->add_subcommand(spec.name, spec.description);
    cmd->footer(spec.footer);
    if (spec.named_by && !spec.positional) o->extra = spec.name;
    if (spec.positional) cmd->add_option("kind", o->extra, spec.positional);
    if (!data.input.empty()) {
      auto* in = cmd->add_option(data.input, o->input, "input " + data.input)->check(path_value());
      if (spec.input_required) in->required();
    }
    cmd->add_option("-o,--output", o->output, spec.output_doc)->required()->check(path_value());
    if (spec.machine) {
      cmd->add_option("--machine", o->machine, spec.machine_doc)->check(path_value());
    }
    if (data.gcode_beside_toolpath)
      cmd->add_option("--gcode", o->gcode, "also write G-code (needs --machine)")
          ->check(path_value());
    if (spec.report)
      cmd->add_option("--report", o->report, "JSON report to write")->check(path_value());
    // slice (planar, graded, process fields; docs/plates.md) and pbf write their output alone
    // layer by layer.
    const bool streams = data.streams;
    auto whole = [streams](const char* other) {
      return streams ? std::string(" (holds the whole toolpath in memory; without it and ") +
                           other + " the output streams layer by layer)"
                     : std::string();
    };
    if (spec.toolpath)
      cmd->add_option("--toolpath", o->toolpath,
                      "also write the toolpath JSON" + whole("--preview"))
          ->check(path_value());
    cmd->add_option("--preview", o->preview,
                    "folder for PNG previews (layer_0000.png, ...)" + whole("--toolpath"))
        ->check(path_value());
    cmd->add_option("--set", o->sets,
                    "any setting: section.key=value (repeatable; `trellis settings`)");
    o->flags.add(cmd, spec.flag_sections);
    add_progress_flag(cmd, o->progress);
    const bool machine_required = spec.machine == 2;
    const char* named_by = spec.named_by;
    const std::string named_as = spec.positional ? "kind argument" : "planner argument";
    cmd->callback([o, route, &data, named_by, named_as, machine_required, argc, argv] {
      if (machine_required && o->machine.empty())
        throw SettingError("--machine PROFILE.toml is required (see profiles/)",
                           {"", 0, "--machine"});
      if (!o->gcode.empty() && o->machine.empty())
        throw SettingError("--gcode needs --machine PROFILE.toml", {"", 0, "--gcode"});
      Job job;
      job.route = route;
      job.name = std::filesystem::path(o->output).stem().string();
      job.input = o->input;
      job.machine = o->machine;
      job.command = command_line(argc, argv);
      job.settings = command_settings(o->machine, {});
      if (named_by && !o->extra.empty()) job.settings.set(named_by, o->extra, {named_as});
      apply_command_line(job.settings, o->flags, o->progress, o->sets);
      const auto sections = route_sections(route);
      for (const auto& [key, e] : job.settings.entries()) {
        if (e.origin.source != "--set") continue;
        const std::string sec = key.substr(0, key.find('.'));
        if (std::find(sections.begin(), sections.end(), sec) == sections.end())
          throw SettingError("`trellis " + route + "` does not read [" + sec + "] settings",
                             {"", 0, "--set " + key});
      }
      if (data.gcode_beside_toolpath) {
        job.toolpath = o->output;
        job.gcode = o->gcode;
      } else {
        job.output = o->output;
        job.toolpath = o->toolpath;
      }
      job.report = o->report;
      job.preview = o->preview;
      job.keep_toolpath = false;  // only the files are used here
      Diagnostics diag;
      ProgressDisplay display(progress_mode(job.settings), "trellis " + route);
      JobResult r = run_job(job, display.context(diag));
      display.finish();
      print_result(r, diag);
    });
  }
}

}  // namespace trellis::cli
