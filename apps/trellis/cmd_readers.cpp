// The reader commands (check, analyze, compare, view, render): what each reads is its row of the
// library's route table (job/job.hpp RouteSpec::reads); here are their help texts, positionals and
// file options. Their setting flags come from the schema; each builds a Job and hands it to
// run_job.
#include <algorithm>
#include <iostream>

#include "commands.hpp"
#include "progress_display.hpp"
#include "trellis/job/job.hpp"

namespace trellis::cli {

namespace {

const char* const kSetDoc =
    "any setting it reads: section.key=value (repeatable; `trellis settings`)";

// A positional: the design, or the prints (`max` > 1: any number of them).
struct Positional {
  const char* name;
  const char* doc;
  bool design;
  int max = 1;
};

struct ReaderCommand {
  const char* name;
  const char* description;
  std::string footer;
  std::vector<Positional> positionals;
  const char* output_doc = nullptr;   // -o (required)
  const char* machine_doc = nullptr;  // --machine
  const char* design_doc = nullptr;   // --design
  const char* report_doc = nullptr;   // --report
  const char* preview_doc = nullptr;  // --preview
  const char* set_doc = kSetDoc;
  bool progress = false;  // --progress / --no-progress (run.progress)
  const char* preview_names = "--preview";
};

const char* const kAnalyzePreview =
    "folder for PNGs per file and layer (FILE_layer_0000.png, FILE_2_... for a second file of that "
    "name); with --design the design in grey, doubles red, missing struts blue";

const std::vector<ReaderCommand>& reader_commands() {
  static const std::vector<ReaderCommand> commands = {
      {"check",
       "Replay a print against the nozzle model: collisions, struts missing or repeated",
       "The print is a toolpath JSON or G-code (.gcode/.nc). G-code is read with the valve "
       "commands\n"
       "and tool offsets of --machine, or of the machine recorded in the file by Trellis. Every\n"
       "extruded segment is matched to a design strut by its end nodes (a strut laid on a\n"
       "surface as a polyline: its segments from node to node; a design of stacked planar\n"
       "layers: printed layer k in the plane of layer k) and tested against everything printed\n"
       "before it: the nozzle is a vertical cylinder of --nozzle-radius from the\n"
       "tip up; material above the tip by more than --tip-clearance within the radius is hit,\n"
       "except within --node-clearance of a node the two struts share. Steep struts (within "
       "--cone\n"
       "of vertical) must be printed bottom-up.\n"
       "Exit status: 0 if clean, 1 if anything was found, 2 for bad input.",
       {{"lattice", "design lattice", true},
        {"print", "toolpath JSON, G-code or 3MF toolpath", false}},
       nullptr,
       "machine profile the G-code was written for",
       nullptr,
       "report JSON with every collision",
       "folder for an isometric picture with the collisions ringed",
       "any [nozzle] or [lattice] setting: section.key=value"},
      {"analyze",
       "Measure a G-code file (any slicer), optionally against the design lattice",
       "Reads Marlin, RepRapFirmware and Klipper G-code (G0-G3, G90/91, M82/83, G92, G20/21;\n"
       "tools, temperatures and mixing in each one's commands; Cura and PrusaSlicer comments)\n"
       "and PrusaSlicer's binary G-code (.bgcode); a toolpath JSON is measured as planned and a\n"
       "laser .cli by its vectors. Layers come from layer comments, else from\n"
       "Z changes. With --design: extrusion ratio (printed / nominal\n"
       "length), double-deposited length, off-design length, missing struts, and the GIPPO score\n"
       "corrected by EdgesReal/EdgesNominal.",
       {{"gcode", "G-code file", false}},
       nullptr,
       ".cli files: laser profile (melt pool, scan timing)",
       "design lattice (any lattice format); .vcad for a .cli",
       "JSON report to write (per-layer counts included)",
       kAnalyzePreview,
       kSetDoc,
       false,
       "--preview,--png"},
      {"compare",
       "Compare G-code files against one design, side by side",
       "",
       {{"design", "design lattice", true}, {"gcode", "G-code files", false, 1000}},
       nullptr,
       nullptr,
       nullptr,
       "JSON report to write (per-layer counts included)",
       kAnalyzePreview,
       kSetDoc,
       false,
       "--preview,--png"},
      {"view",
       "Write an interactive 3D viewer (one self-contained HTML file) for toolpaths",
       "Reads G-code of any slicer (.gcode/.g/.gco), pneumatic or bath .nc, laser .cli, toolpath\n"
       "JSON, 3MF toolpaths and lattices (JSON/CSV/OBJ/3MF). Open the HTML in a browser (no "
       "server, no network):\n"
       "orbit with the left mouse button, pan with the right, zoom with the wheel; colour by\n"
       "feature type, tool, mixture, temperature, speed, width, print order or laser power.\n"
       "With --design (a lattice) the prints are shown in design coordinates over the design,\n"
       "coloured by deviation from it, and replayed against the nozzle model as `trellis check`\n"
       "does: colour by collisions rings every collision and marks the struts involved. A\n"
       "`trellis check` report is a viewer input too. --machine draws the profile's build volume\n"
       "around G-code (machine coordinates).",
       {{"files", "files to show", false, 1000}},
       "HTML file to write",
       "machine profile (.nc valve commands, build volume, nozzle of the check)",
       "design lattice: overlay, deviation from it and the collision check",
       nullptr,
       nullptr,
       "any [nozzle] or [lattice] setting of the check: section.key=value"},
      {"render",
       "Render toolpath layers to PNG",
       "Reads a toolpath JSON, G-code of any slicer (.gcode/.g/.nc), a laser .cli or a 3MF\n"
       "toolpath. Paths are coloured by feature type (or print order, or mixture) in the viewer's\n"
       "colours, travel is dashed grey, path starts are white discs in a dark ring (seen on any\n"
       "colour; laser hatch vectors have none) and ends small dark dots. A G-code file's mixture\n"
       "is drawn as deposited (its header's mixing look-ahead undone); --colour commanded draws\n"
       "the mixture where the commands were issued; --colour tool draws each tool (each laser of\n"
       "a laser file) in its colour, the default for a build file of several lasers. Each PNG has\n"
       "a title (file, layer, Z, what colour means), a legend or colour bar and a scale bar in "
       "mm.\n"
       "Without --layer every layer is written as OUT.layerNNN.png (OUT without .png).",
       {{"toolpath", "toolpath JSON, G-code (.gcode/.g/.nc), laser .cli or 3MF toolpath", false}},
       "PNG file (with --layer) or prefix",
       ".nc files: machine profile (valve commands)",
       nullptr,
       nullptr,
       nullptr,
       kSetDoc,
       true},
  };
  return commands;
}

struct ReaderOpts {
  Job job;
  std::vector<std::string> design;  // the design positional (0 or 1)
  std::vector<std::string> sets;
  SettingFlags flags;
  int progress = -1;
};

}  // namespace

void add_reader(CLI::App& app, const std::string& name) {
  const auto& commands = reader_commands();
  const auto it = std::find_if(commands.begin(), commands.end(),
                               [&](const ReaderCommand& c) { return c.name == name; });
  const ReaderCommand& spec = *it;
  const RouteSpec& reader = route_spec(name, {"", 0, "command"});
  auto o = std::make_shared<ReaderOpts>();
  o->job.route = name;
  auto* cmd = app.add_subcommand(spec.name, spec.description);
  if (!spec.footer.empty()) cmd->footer(spec.footer);
  for (const auto& p : spec.positionals) {
    auto* opt = p.design ? cmd->add_option(p.name, o->job.design, p.doc)
                         : cmd->add_option(p.name, o->job.inputs, p.doc)->expected(1, p.max);
    opt->required()->check(path_value());
  }
  if (spec.output_doc)
    cmd->add_option("-o,--output", o->job.output, spec.output_doc)->required()->check(path_value());
  if (spec.design_doc)
    cmd->add_option("--design", o->job.design, spec.design_doc)->check(path_value());
  if (spec.machine_doc)
    cmd->add_option("--machine", o->job.machine, spec.machine_doc)->check(path_value());
  if (spec.report_doc)
    cmd->add_option("--report", o->job.report, spec.report_doc)->check(path_value());
  if (spec.preview_doc)
    cmd->add_option(spec.preview_names, o->job.preview, spec.preview_doc)->check(path_value());
  cmd->add_option("--set", o->sets, spec.set_doc);
  o->flags.add(cmd, reader.sections, reader.name);
  if (spec.progress) add_progress_flag(cmd, o->progress);
  cmd->callback([o, &spec] {
    Job job = o->job;
    apply_command_line(job.settings, o->flags, o->progress, o->sets);
    Diagnostics diag;
    ProgressDisplay display(spec.progress ? progress_mode(o->progress) : ProgressMode::Off,
                            "trellis " + job.route);
    const JobResult r = run_job(job, display.context(diag));
    display.finish();
    print_warnings(diag);
    std::cout << r.summary;
    if (r.exit_code) set_exit_code(r.exit_code);
  });
}

}  // namespace trellis::cli
