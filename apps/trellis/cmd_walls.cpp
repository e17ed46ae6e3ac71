#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/lattice/io.hpp"

namespace trellis::cli {

void add_walls(CLI::App& app) {
  struct Opts {
    std::string input, output;
    double width = 0.2, height = 0.148;
    bool follow = false;
    BudgetFlags budget;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "walls", "Export a lattice as solid walls (binary STL, OBJ or 3MF) for other slicers");
  cmd->footer(
      "Each strut becomes a box width x height from its z upward and each node a 16-sided\n"
      "prism, as overlapping shells (slicers take their union). This is how the GIPPO paper\n"
      "fed its lattices to a conventional slicer (\"wall structure\", 0% infill).");
  cmd->add_option("lattice", o->input, "lattice file")->required()->check(path_value());
  cmd->add_option("-o,--output", o->output, "mesh to write: .stl (binary), .obj or .3mf")
      ->required()
      ->check(path_value());
  add_follow_symlinks(cmd, o->follow);
  cmd->add_option("--bead-width", o->width, "wall width = bead width (mm)")
      ->check(number_value(0, 100, true))
      ->capture_default_str();
  cmd->add_option("--height", o->height, "wall height (mm)")
      ->check(number_value(0, 100, true))
      ->capture_default_str();
  add_budget_flags(cmd, o->budget);
  cmd->callback([o] {
    RunFiles files(o->follow);
    files.input("the lattice", o->input);
    files.output("the mesh (-o)", o->output);
    files.check();
    // Named for what is written, after the file checks (a link, a folder, an input said first);
    // refused before any work, nothing written.
    if (!is_mesh_output(o->output) && !is_stream_output(o->output))
      throw SettingError(
          "'" + o->output +
              "': `trellis walls` writes the walls as .stl (binary STL), .obj or .3mf: name it so",
          {"", 0, "--output"});
    Diagnostics diag;
    const Graph g = read_lattice(o->input, {}, diag);
    check_budget(lattice_walls_estimate(g), o->budget.budget());
    const TriangleMesh mesh = lattice_walls(g, o->width, o->height);
    write_mesh(o->output, mesh, "trellis walls", "--output");
    print_warnings(diag);
    std::cout << "walls: " << g.edges.size() << " struts, " << mesh.triangles.size()
              << " triangles -> " << o->output << "\n";
  });
}

}  // namespace trellis::cli
