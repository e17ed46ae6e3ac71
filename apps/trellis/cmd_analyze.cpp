#include <filesystem>
#include <iostream>
#include <map>

#include "commands.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

namespace {

struct AnalyzeOpts {
  AnalysisParams params;
  GcodeReadOptions read;
  std::string design, report, png, machine;
  // For the volume of each part of a plate (mm): the machine profile's default.
  double filament_diameter = MachineProfile{}.filament_diameter;
  bool per_layer = false;
  bool follow = false;
  std::vector<std::string> files;
};

void add_common(CLI::App* cmd, AnalyzeOpts& o) {
  cmd->add_option("--bead-width", o.params.width,
                  "bead width: deposits within width/2 cover a strut (mm)")
      ->check(number_value(0, 100, true))
      ->capture_default_str();
  cmd->add_option("--layer-height", o.params.layer_height, "nozzle z = design z + this (mm)")
      ->check(number_value(-100, 100))
      ->capture_default_str();
  cmd->add_option(
         "--acceleration", o.params.acceleration,
         "mm/s² for the print-time estimate when the file sets none (its M204 or our header's "
         "speed.acceleration win; 0 = feed rates only)")
      ->check(number_value(0, 1e6));
  cmd->add_flag("--align", o.params.align_centers,
                "move the print's XY centre onto the design's (for parts placed on the bed; done "
                "anyway, with a note, when the print lies mostly outside the design)");
  cmd->add_option("--valve-on", o.read.valve_on,
                  "pneumatic files: the command that opens the valve");
  cmd->add_option("--valve-off", o.read.valve_off,
                  "pneumatic files: the command that closes the valve");
  cmd->add_flag("--commanded-mixtures", o.read.commanded_mixtures,
                "graded G-code with a mixing look-ahead: measure the mixtures as commanded (the "
                "file's lines), not as deposited (the look-ahead undone, the default)");
  cmd->add_flag("--strict", o.read.stop_on_error,
                "stop at the first unreadable line (default: warn and skip)");
  cmd->add_option("--report", o.report, "JSON report to write (per-layer counts included)")
      ->check(path_value());
  cmd->add_flag("--layers", o.per_layer,
                "also print a line per layer: extrusion starts (with --design, beside the "
                "fewest paths its struts allow), retractions, travel moves and length");
  cmd->add_option("--preview,--png", o.png,
                  "folder for PNGs per file and layer (FILE_layer_0000.png, FILE_2_... for a "
                  "second file of that name); with --design the design in grey, doubles red, "
                  "missing struts blue")
      ->check(path_value());
  add_follow_symlinks(cmd, o.follow);
}

// The files of analyze and compare, checked before anything is read (core/run_files.hpp).
void check_files(const AnalyzeOpts& o) {
  RunFiles files(o.follow);
  for (const auto& f : o.files) files.input("the G-code", f);
  files.input("the design", o.design);
  files.input("the machine profile (--machine)", o.machine);
  files.output("the report (--report)", o.report);
  files.output_folder("the preview folder (--preview)", o.png);
  files.check();
}

// One print measured: G-code of any slicer, or a toolpath JSON as planned (no filament or
// retractions: the machine's G-code adds them). A file that is no print (a report, a lattice, a
// mesh, a design) is refused naming it, never read as G-code with nothing in it.
Analysis analyze_file(const std::string& f, const Graph* design, const AnalysisParams& params,
                      const GcodeReadOptions& read, Diagnostics& diag) {
  std::string ext = std::filesystem::path(f).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".json") {
    const Toolpath tp = read_toolpath(f);
    Analysis a = analyze(tp, toolpath_counts(tp), design, params);
    a.name = f;
    return a;
  }
  if (ext == ".3mf") {
    // A 3MF toolpath (a laser one went to the laser analysis); a mesh 3MF is refused by the reader.
    const Toolpath tp = read_toolpath_3mf_file(f, &diag);
    Analysis a = analyze(tp, toolpath_counts(tp), design, params);
    a.name = f;
    return a;
  }
  for (const char* other : {".stl", ".obj", ".csv", ".vcad", ".toml", ".png", ".html"})
    if (ext == other)
      throw ParseError(
          f + ": a '" + ext +
          "' file is not a print: analyze reads G-code (.gcode/.g/.gco/.nc/.bgcode), "
          "a laser .cli, a 3MF toolpath or a toolpath JSON (a lattice goes to --design)");
  return analyze_gcode_file(f, design, params, read, diag);
}

std::vector<Analysis> run(const AnalyzeOpts& o) {
  Diagnostics diag;
  Graph design;
  if (!o.design.empty()) design = read_lattice(o.design, {}, diag);
  std::vector<Analysis> out;
  AnalysisParams params = o.params;
  params.keep_printed = !o.png.empty();
  std::map<std::string, int> stems;  // files of one name (a/x.gcode, b/x.gcode): x, x_2, ...
  for (const auto& f : o.files) {
    out.push_back(analyze_file(f, o.design.empty() ? nullptr : &design, params, o.read, diag));
    const Analysis& a = out.back();
    if (a.auto_aligned)
      diag.warn("analyze_aligned", f + ": the print lies outside the design, moved by (" +
                                       num(a.shift.x, 2) + ", " + num(a.shift.y, 2) +
                                       ") mm to align their centres; pass --align to always "
                                       "align");
    if (o.png.empty()) continue;
    const Toolpath& tp = a.printed;
    if (tp.layers.empty())
      throw GeometryError("nothing to draw for --preview: the file has no extrusion", {f});
    create_output_directories(o.png);
    std::string stem = std::filesystem::path(f).stem().string();
    if (const int n = ++stems[stem]; n > 1) stem += "_" + std::to_string(n);
    auto name = [&](std::size_t i) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "_layer_%04zu.png", i);
      return (std::filesystem::path(o.png) / (stem + buf)).string();
    };
    if (o.design.empty()) {
      RenderOptions ro;
      ro.colour_by_role = true;
      ro.bead_width = o.params.width;
      for (std::size_t i = 0; i < tp.layers.size(); ++i) render_layer_png(tp, i, name(i), ro);
      std::cout << "wrote " << tp.layers.size() << " layer picture(s) to " << o.png << "\n";
      continue;
    }
    std::vector<Segment2> dsegs;
    for (const auto& e : design.edges)
      dsegs.push_back({design.nodes[e.a].xy(), design.nodes[e.b].xy()});
    for (std::size_t i = 0; i < a.layers.size() && i < tp.layers.size(); ++i) {
      std::vector<Segment2> blue;
      for (EdgeId e : a.layers[i].missing)
        blue.push_back(
            {design.nodes[design.edges[e].a].xy(), design.nodes[design.edges[e].b].xy()});
      render_overlay_png(dsegs, tp.layers[i], a.layers[i].doubles, blue, o.params.width, name(i));
    }
    std::cout << "wrote " << std::min(a.layers.size(), tp.layers.size()) << " layer picture(s) to "
              << o.png << "\n";
  }
  print_warnings(diag);
  return out;
}

}  // namespace

// A line per layer: starts (and the lower bound of the design's struts there), retractions,
// travel.
void print_layers(const Analysis& a) {
  std::cout << "layer        z   starts" << (a.has_design ? "  (bound)" : "")
            << "  retractions  travels  travel mm\n";
  for (std::size_t i = 0; i < a.counts.per_layer.size(); ++i) {
    const auto& l = a.counts.per_layer[i];
    char buf[160];
    std::snprintf(buf, sizeof buf, "%5zu %8.3f %8zu", i, l.z, l.starts);
    std::cout << buf;
    if (a.has_design) {
      std::snprintf(buf, sizeof buf, "  (%5zu)", i < a.layers.size() ? a.layers[i].lower_bound : 0);
      std::cout << buf;
    }
    std::snprintf(buf, sizeof buf, " %12zu %8zu %10.1f\n", l.retractions, l.travel_moves,
                  l.travel_length);
    std::cout << buf;
  }
}

void add_analyze(CLI::App& app) {
  auto o = std::make_shared<AnalyzeOpts>();
  auto* cmd = app.add_subcommand(
      "analyze", "Measure a G-code file (any slicer), optionally against the design lattice");
  cmd->footer(
      "Reads Marlin, RepRapFirmware and Klipper G-code (G0-G3, G90/91, M82/83, G92, G20/21;\n"
      "tools, temperatures and mixing in each one's commands; Cura and PrusaSlicer comments)\n"
      "and PrusaSlicer's binary G-code (.bgcode); a toolpath JSON is measured as planned and a\n"
      "laser .cli by its vectors. Layers come from layer comments, else from\n"
      "Z changes. With --design: extrusion ratio (printed / nominal\n"
      "length), double-deposited length, off-design length, missing struts, and the GIPPO score\n"
      "corrected by EdgesReal/EdgesNominal.");
  cmd->add_option("gcode", o->files, "G-code file")->required()->expected(1)->check(path_value());
  cmd->add_option("--design", o->design, "design lattice (any lattice format); .vcad for a .cli")
      ->check(path_value());
  cmd->add_option("--machine", o->machine, ".cli files: laser profile (melt pool, scan timing)")
      ->check(path_value());
  cmd->add_option("--filament-diameter", o->filament_diameter,
                  "build plates: filament diameter for each part's volume (mm)")
      ->check(number_value(0, 100, true))
      ->capture_default_str();
  add_common(cmd, *o);
  cmd->callback([o] {
    check_files(*o);
    if (is_laser_build_file(o->files.front()))
      return analyze_laser_file(o->files.front(), o->design, o->machine, o->report);
    const auto runs = run(*o);
    const Analysis& a = runs.front();
    if (!o->report.empty()) write_file_atomic(o->report, analysis_json(a));
    if (o->per_layer) print_layers(a);
    std::cout << a.name << ": " << a.counts.layers << " layer(s), " << a.paths << " paths, "
              << a.counts.extrusion_starts << " extrusion starts, " << num(a.extruded_length, 1)
              << " mm extruded, " << a.counts.travel_moves << " travel moves ("
              << num(a.counts.travel_length, 1) << " mm), " << a.counts.retractions
              << " retractions, score " << num(a.score, 4) << "\n";
    std::cout << "  print time " << num(a.counts.print_time_s / 60, 1)
              << " min, of which heater waits " << num(a.counts.heating_s / 60, 1) << " min\n";
    // Build plates: each labelled part (M486 / Klipper EXCLUDE_OBJECT).
    for (const auto& p : a.counts.parts)
      std::cout << "  part " << p.label << ": " << num(p.extruded_length, 1) << " mm extruded, "
                << num(p.filament, 2) << " mm filament ("
                << num(p.filament * 3.14159265358979 * o->filament_diameter * o->filament_diameter /
                           4,
                       1)
                << " mm³ at " << num(o->filament_diameter, 2) << " mm), "
                << num(p.print_time_s / 60, 1) << " min\n";
    if (a.has_design)
      std::cout << "  against the design: ratio " << num(a.extrusion_ratio, 3) << ", double "
                << num(a.double_length, 2) << " mm, off-design " << num(a.off_design_length, 2)
                << " mm, missing " << a.missing_edges << " of " << a.design_edges
                << " struts, corrected score " << num(a.score_corrected, 4) << "\n";
  });
}

void add_compare(CLI::App& app) {
  auto o = std::make_shared<AnalyzeOpts>();
  auto* cmd =
      app.add_subcommand("compare", "Compare G-code files against one design, side by side");
  cmd->add_option("design", o->design, "design lattice")->required()->check(path_value());
  cmd->add_option("gcode", o->files, "G-code files")
      ->required()
      ->expected(1, 1000)
      ->check(path_value());
  add_common(cmd, *o);
  cmd->callback([o] {
    check_files(*o);
    const auto runs = run(*o);
    if (o->per_layer)
      for (const auto& a : runs) {
        std::cout << a.name << ":\n";
        print_layers(a);
      }
    std::cout << comparison_table(runs);
    if (!o->report.empty()) {
      std::string all = "[\n";
      for (std::size_t i = 0; i < runs.size(); ++i)
        all += (i ? ",\n" : "") + analysis_json(runs[i]);
      write_file_atomic(o->report, all + "]\n");
    }
  });
}

}  // namespace trellis::cli
