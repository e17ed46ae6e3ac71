#include <filesystem>
#include <iostream>
#include <optional>

#include "commands.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/print_check.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/view/view.hpp"

namespace trellis::cli {

void machine_valves(const std::string& machine, ViewLoadOptions& load) {
  if (machine.empty()) return;
  const MachineProfile p = command_settings(machine, {}).config().machine;
  if (p.marlin_family()) return;
  if (load.valve_on.empty()) load.valve_on = p.valve_on;
  if (load.valve_off.empty()) load.valve_off = p.valve_off;
}

void add_view(CLI::App& app) {
  struct Opts {
    std::vector<std::string> files;
    std::string output, title, design;
    std::vector<std::string> sets;
    std::string machine;
    ViewLoadOptions load;
    bool follow = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "view", "Write an interactive 3D viewer (one self-contained HTML file) for toolpaths");
  cmd->footer(
      "Reads G-code of any slicer (.gcode/.g/.gco), pneumatic or bath .nc, laser .cli, toolpath\n"
      "JSON, 3MF toolpaths and lattices (JSON/CSV/OBJ/3MF). Open the HTML in a browser (no server, "
      "no network):\n"
      "orbit with the left mouse button, pan with the right, zoom with the wheel; colour by\n"
      "feature type, tool, mixture, temperature, speed, width, print order or laser power.\n"
      "With --design (a lattice) the prints are shown in design coordinates over the design,\n"
      "coloured by deviation from it, and replayed against the nozzle model as `trellis check`\n"
      "does: colour by collisions rings every collision and marks the struts involved. A\n"
      "`trellis check` report is a viewer input too. --machine draws the profile's build volume\n"
      "around G-code (machine coordinates).");
  cmd->add_option("files", o->files, "files to show")
      ->required()
      ->expected(1, 1000)
      ->check(path_value());
  cmd->add_option("-o,--output", o->output, "HTML file to write")->required()->check(path_value());
  add_follow_symlinks(cmd, o->follow);
  cmd->add_option("--title", o->title, "page title (default: the file names)");
  cmd->add_option("--machine", o->machine,
                  "machine profile (.nc valve commands, build volume, nozzle of the check)")
      ->check(path_value());
  cmd->add_option("--design", o->design,
                  "design lattice: overlay, deviation from it and the collision check")
      ->check(path_value());
  cmd->add_option("--set", o->sets,
                  "any [nozzle] or [lattice] setting of the check: section.key=value");
  cmd->add_option("--valve-on", o->load.valve_on,
                  "pneumatic files: the command that opens the valve");
  cmd->add_option("--valve-off", o->load.valve_off,
                  "pneumatic files: the command that closes the valve");
  cmd->callback([o] {
    RunFiles files(o->follow);
    for (const auto& f : o->files) files.input("the file to show", f);
    files.input("the machine profile (--machine)", o->machine);
    files.input("the design (--design)", o->design);
    files.output("the HTML (-o)", o->output);
    files.check();
    Diagnostics diag;
    std::vector<ViewScene> scenes;
    std::string title = o->title;
    const bool machine = !o->machine.empty();
    const Settings st = command_settings(o->machine, o->sets);
    const Config cfg = st.config();
    machine_valves(o->machine, o->load);
    std::optional<PrintCheck> checker;
    if (!o->design.empty()) {
      checker.emplace(st, machine);
      checker->read_design(o->design, diag);
    }
    for (const auto& f : o->files) {
      ViewScene s = load_view_scene(f, o->load, diag);
      const bool print =
          s.kind == "gcode" || s.kind == "nc" || s.kind == "bgcode" || s.kind == "toolpath";
      if (!o->design.empty() && s.kind != "lattice") {
        if (print) {
          // As `trellis check` reads it: back in design coordinates, then replayed.
          s.toolpath = checker->read(f, diag);
          set_design(s, checker->design());
          set_collisions(s, checker->check(s.toolpath));
        } else {
          set_design(s, checker->design());
        }
      } else if (!o->design.empty()) {
        diag.warn("view", f + " is a lattice: --design is not compared with it");
      }
      if (machine && print && s.kind != "toolpath") {
        if (o->design.empty())
          set_build_volume(s, cfg.machine, cfg.machine.name);
        else
          diag.warn("view", f + ": no build volume drawn: with --design the print is shown in "
                                "design coordinates, not on the machine's bed");
      }
      scenes.push_back(std::move(s));
      if (o->title.empty()) title += (title.empty() ? "" : ", ") + scenes.back().name;
    }
    write_file_atomic(o->output, viewer_html(scenes, title));
    print_warnings(diag);
    for (const auto& s : scenes) {
      // Paths as `trellis analyze` and the page count them: runs of extrusion between travels
      // (a laser build file: its vectors).
      std::size_t segments = 0;
      const std::size_t paths = s.kind == "cli" ? s.toolpath.path_count() : run_count(s.toolpath);
      for (const auto& l : s.toolpath.layers)
        for (const auto& p : l.paths) segments += p.segments();
      std::cout << s.name << " (" << s.kind << "): ";
      if (s.kind == "lattice") {
        std::cout << s.design.size() << " struts\n";
        continue;
      }
      if (s.kind == "check")
        std::cout << s.collisions << " collisions, " << s.hits.size() << " ringed";
      else
        std::cout << s.toolpath.layers.size() << " layer(s), " << paths << " paths, " << segments
                  << " segments";
      if (s.checked && s.kind != "check") std::cout << ", " << s.collisions << " collisions";
      if (!s.deviation.empty()) {
        float worst = 0;
        for (float d : s.deviation) worst = std::max(worst, d);
        std::cout << ", deviation from the design up to " << num(worst, 3) << " mm";
      }
      if (!s.bed.shape.empty()) std::cout << ", build volume of " << s.bed.machine;
      std::cout << "\n";
    }
    std::cout << "wrote " << o->output << "\n";
  });
}

}  // namespace trellis::cli
