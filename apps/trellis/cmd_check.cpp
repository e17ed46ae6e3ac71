#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/print_check.hpp"

namespace trellis::cli {

void add_check(CLI::App& app) {
  struct Opts {
    std::string lattice, print, machine, report, preview;
    std::vector<std::string> sets;
    double snap = kNodeSnap;
    SettingFlags flags;
    bool follow = false;
    bool commanded = false;
    BudgetFlags budget;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "check", "Replay a print against the nozzle model: collisions, struts missing or repeated");
  cmd->footer(
      "The print is a toolpath JSON or G-code (.gcode/.nc). G-code is read with the valve "
      "commands\n"
      "and tool offsets of --machine, or of the machine recorded in the file by Trellis. Every\n"
      "extruded segment is matched to a design strut by its end nodes (a strut laid on a\n"
      "surface as a polyline: its segments from node to node; a design of stacked planar\n"
      "layers: printed layer k in the plane of layer k) and tested against everything printed\n"
      "before it: the nozzle is a vertical cylinder of --nozzle-radius from the\n"
      "tip up; material above the tip by more than --tip-clearance within the radius is hit,\n"
      "except within --node-clearance of a node the two struts share. Steep struts (within --cone\n"
      "of vertical) must be printed bottom-up.\n"
      "Exit status: 0 if clean, 1 if anything was found, 2 for bad input.");
  cmd->add_option("lattice", o->lattice, "design lattice")->required()->check(path_value());
  cmd->add_option("print", o->print, "toolpath JSON, G-code or 3MF toolpath")
      ->required()
      ->check(path_value());
  cmd->add_option("--machine", o->machine, "machine profile the G-code was written for")
      ->check(path_value());
  cmd->add_flag("--commanded-mixtures", o->commanded,
                "graded G-code with a mixing look-ahead: read the mixtures as commanded, not as "
                "deposited (the default)");
  cmd->add_option("--report", o->report, "report JSON with every collision")->check(path_value());
  cmd->add_option("--preview", o->preview,
                  "folder for an isometric picture with the collisions ringed")
      ->check(path_value());
  add_follow_symlinks(cmd, o->follow);
  cmd->add_option("--set", o->sets, "any [nozzle] or [lattice] setting: section.key=value");
  o->flags.add(cmd, {"nozzle", "lattice"});
  cmd->add_option("--snap", o->snap,
                  fmt::format("segment ends within this of a node are at it (mm; default {0}, or "
                              "the profile's node overlap + {0})",
                              kNodeSnap));
  add_budget_flags(cmd, o->budget);
  cmd->callback([o] {
    RunFiles files(o->follow);
    files.input("the lattice", o->lattice);
    files.input("the print", o->print);
    files.input("the machine profile (--machine)", o->machine);
    files.output("the report (--report)", o->report);
    files.output_folder("the preview folder (--preview)", o->preview);
    files.check();
    Settings st = command_settings(o->machine, o->sets);
    o->flags.apply(st);
    PrintCheck run(st, !o->machine.empty(), o->snap, o->budget.budget());
    Diagnostics diag;
    run.read_design(o->lattice, diag);
    Toolpath tp;  // held whole for the preview only: the check streams a G-code
    CollisionCheck c;
    if (o->preview.empty()) {
      c = run.check_file(o->print, diag, o->commanded);
    } else {
      tp = run.read(o->print, diag, o->commanded);
      c = run.check(tp);
    }
    const CheckOptions& check = run.options();
    if (!o->report.empty()) write_file_atomic(o->report, collision_check_json(c, check));
    if (!o->preview.empty()) {
      create_output_directories(o->preview);
      View3dOptions v;
      for (const auto& h : c.hits) v.marks.push_back(h.point);
      v.title = std::to_string(c.collisions) + " collisions";
      render_3d_png(tp, (std::filesystem::path(o->preview) / "3d.png").string(), v);
    }
    print_warnings(diag);
    std::cout << "check: " << c.paths << " paths, " << c.segments << " segments, " << c.printed_once
              << "/" << c.struts << " struts printed once, " << c.missing.size() << " missing, "
              << c.repeated.size() << " repeated, " << c.off_design_segments << " off the design, "
              << c.top_down.size() << " steep struts top-down, " << c.collisions << " collisions\n";
    for (std::size_t i = 0; i < std::min<std::size_t>(c.hits.size(), 10); ++i) {
      const auto& h = c.hits[i];
      std::cout << "  collision: path " << h.path << " segment " << h.segment << " (strut "
                << h.strut << ") hits strut " << h.hit_strut << " at (" << num(h.point.x, 3) << ", "
                << num(h.point.y, 3) << ", " << num(h.point.z, 3) << "), tip at ("
                << num(h.tip.x, 3) << ", " << num(h.tip.y, 3) << ", " << num(h.tip.z, 3) << ")\n";
    }
    if (!c.ok()) set_exit_code(1);
  });
}

}  // namespace trellis::cli
