#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/view/view.hpp"

namespace trellis::cli {

void add_view(CLI::App& app) {
  struct Opts {
    std::vector<std::string> files;
    std::string output, title;
    ViewLoadOptions load;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "view", "Write an interactive 3D viewer (one self-contained HTML file) for toolpaths");
  cmd->footer(
      "Reads G-code of any slicer (.gcode/.g/.gco), pneumatic or bath .nc, laser .cli, toolpath\n"
      "JSON and lattices (JSON/CSV/OBJ/3MF). Open the HTML in a browser (no server, no network):\n"
      "orbit with the left mouse button, pan with the right, zoom with the wheel; colour by\n"
      "feature type, tool, mixture, temperature, speed, width, print order or laser power.");
  cmd->add_option("files", o->files, "files to show")->required()->expected(1, 1000);
  cmd->add_option("-o,--output", o->output, "HTML file to write")->required();
  cmd->add_option("--title", o->title, "page title (default: the file names)");
  cmd->add_option("--machine", o->load.machine, "machine profile (.nc valve commands)");
  cmd->add_option("--valve-on", o->load.valve_on,
                  "pneumatic files: the command that opens the valve");
  cmd->add_option("--valve-off", o->load.valve_off,
                  "pneumatic files: the command that closes the valve");
  cmd->callback([o] {
    Diagnostics diag;
    std::vector<ViewScene> scenes;
    std::string title = o->title;
    for (const auto& f : o->files) {
      scenes.push_back(load_view_scene(f, o->load, diag));
      if (o->title.empty()) title += (title.empty() ? "" : ", ") + scenes.back().name;
    }
    write_file_atomic(o->output, viewer_html(scenes, title));
    print_warnings(diag);
    for (const auto& s : scenes) {
      std::size_t segments = 0, paths = 0;
      for (const auto& l : s.toolpath.layers)
        for (const auto& p : l.paths) segments += p.segments(), ++paths;
      std::cout << s.name << " (" << s.kind << "): ";
      if (s.kind == "lattice")
        std::cout << s.design.size() << " struts\n";
      else
        std::cout << s.toolpath.layers.size() << " layer(s), " << paths << " paths, " << segments
                  << " segments\n";
    }
    std::cout << "wrote " << o->output << "\n";
  });
}

}  // namespace trellis::cli
