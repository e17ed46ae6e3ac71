#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

void add_check(CLI::App& app) {
  struct Opts {
    std::string lattice, print, machine, report, png;
    CheckOptions check;
    double merge_tolerance = 1e-6;
    bool keep_graph = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "check", "Replay a print against the nozzle model: collisions, struts missing or repeated");
  cmd->footer(
      "The print is a toolpath JSON or G-code (.gcode/.nc; with --machine its valve commands and\n"
      "tool offsets are used to read it). Every extruded segment is matched to a design strut by\n"
      "its end nodes and tested against everything printed before it: the nozzle is a vertical\n"
      "cylinder of --nozzle-radius from the tip up; material above the tip by more than\n"
      "--tip-clearance within the radius is hit, except within --node-clearance of a node the two\n"
      "struts share. Steep struts (within --cone of vertical) must be printed bottom-up.\n"
      "Exit status: 0 if clean, 1 if anything was found, 2 for bad input.");
  cmd->add_option("lattice", o->lattice, "design lattice")->required();
  cmd->add_option("print", o->print, "toolpath JSON or G-code")->required();
  cmd->add_option("--machine", o->machine, "machine profile the G-code was written for");
  cmd->add_option("--report", o->report, "report JSON with every collision");
  cmd->add_option("--png", o->png, "isometric picture with the collisions ringed in red");
  add_nozzle_options(cmd, o->check.nozzle, "Nozzle model");
  cmd->add_flag("--keep-graph", o->keep_graph,
                "the lattice exactly as given: no node merging, no T-junction splitting");
  cmd->add_option("--snap", o->check.snap,
                  "segment ends within this of a node are at it (mm; default 0.05, or the "
                  "profile's node overlap + 0.05)");
  cmd->callback([o] {
    Diagnostics diag;
    const Graph g = read_lattice(
        o->lattice, o->keep_graph ? keep_graph_options() : CleanOptions{o->merge_tolerance, true},
        diag);
    CheckOptions check = o->check;
    Toolpath tp;
    auto ends_with = [](const std::string& s, const std::string& tail) {
      return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
    };
    const bool gcode = ends_with(o->print, ".gcode") || ends_with(o->print, ".nc") ||
                       ends_with(o->print, ".g");
    if (gcode) {
      GcodeReadOptions read;
      MachineProfile profile;
      bool have_profile = !o->machine.empty();
      if (have_profile) {
        profile = load_profile(o->machine);
        if (profile.parsed_flavor() != Flavor::Marlin) {
          read.valve_on = profile.valve_on;
          read.valve_off = profile.valve_off;
        }
        if (check.snap == 0.05) check.snap = profile.node_overlap + 0.05;
      }
      const std::string text = read_file(o->print);
      tp = read_gcode(text, read, diag, o->print);
      // Back to design coordinates: undo the placement Trellis wrote into the header and the
      // tool offsets of the profile.
      double dx = 0, dy = 0;
      const auto at = text.find("; placement offset = ");
      if (at != std::string::npos &&
          std::sscanf(text.c_str() + at, "; placement offset = %lf, %lf", &dx, &dy) != 2)
        dx = dy = 0;
      if (have_profile || dx != 0 || dy != 0) {
        for (auto& l : tp.layers)
          for (auto& p : l.paths) {
            const Vec2 t = have_profile ? profile.tool_offset(p.tool) : Vec2{};
            for (auto& q : p.points) {
              q.x -= t.x + dx;
              q.y -= t.y + dy;
            }
          }
      }
    } else {
      tp = read_toolpath(o->print);
    }
    const CollisionCheck c = check_collisions(g, tp, check);
    if (!o->report.empty()) write_file_atomic(o->report, collision_check_json(c, check));
    if (!o->png.empty()) {
      View3dOptions v;
      for (const auto& h : c.hits) v.marks.push_back(h.point);
      v.title = std::to_string(c.collisions) + " collisions";
      render_3d_png(tp, o->png, v);
    }
    print_warnings(diag);
    std::cout << "check: " << c.paths << " paths, " << c.segments << " segments, "
              << c.printed_once << "/" << c.struts << " struts printed once, " << c.missing.size()
              << " missing, " << c.repeated.size() << " repeated, " << c.off_design_segments
              << " off the design, " << c.top_down.size() << " steep struts top-down, "
              << c.collisions << " collisions\n";
    for (std::size_t i = 0; i < std::min<std::size_t>(c.hits.size(), 10); ++i) {
      const auto& h = c.hits[i];
      std::cout << "  collision: path " << h.path << " segment " << h.segment << " (strut "
                << h.strut << ") hits strut " << h.hit_strut << " at (" << num(h.point.x, 3)
                << ", " << num(h.point.y, 3) << ", " << num(h.point.z, 3) << "), tip at ("
                << num(h.tip.x, 3) << ", " << num(h.tip.y, 3) << ", " << num(h.tip.z, 3) << ")\n";
    }
    if (!c.ok()) set_exit_code(1);
  });
}

}  // namespace trellis::cli
