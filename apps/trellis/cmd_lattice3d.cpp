#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/cells3d.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/aero.hpp"

namespace trellis::cli {

void add_lattice3d(CLI::App& app) {
  struct Opts {
    CellLatticeParams cells;
    FoamParams foam;
    std::string cell = "octet", output, png, materials = "none";
    std::vector<int> count{1, 1, 1};
    std::vector<double> box;
    bool foam_mode = false;
    double radius = 0.25;
    ConformalParams conformal;
  };
  auto o = std::make_shared<Opts>();
  std::string names;
  for (const auto& n : unit_cell_names()) names += (names.empty() ? "" : ", ") + n;
  auto* cmd = app.add_subcommand("lattice3d", "Generate a 3D strut lattice (lattice JSON)");
  cmd->footer(
      "Unit cells: " + names +
      ".\n  cubic: cube edges; bcc: centre to corners; fcc: face centres to corners; octet: fcc\n"
      "  + octahedron (14 nodes, 36 struts); diamond: tetrahedral bonds; kelvin: truncated\n"
      "  octahedra (bcc packing); rhombic-dodecahedron: on the fcc sites.\n"
      "Cells are tessellated with shared nodes merged. --foam makes a stochastic Voronoi foam in\n"
      "a box (--box W,D,H) or inside a closed mesh (--mesh FILE), reproducible for --seed.\n"
      "Materials: none; xy-plane (struts in the XY plane 0, others 1, as the paper's rigid /\n"
      "flexible octet); component (one per connected part); vertical (steep struts 1).");
  cmd->add_option("--cell", o->cell, "unit cell")->capture_default_str();
  cmd->add_option("--size", o->cells.size, "cell side (mm)")->capture_default_str();
  cmd->add_option("--count", o->count, "cells along X Y Z")->expected(3)->capture_default_str();
  cmd->add_flag("--foam", o->foam_mode, "a Voronoi foam instead of unit cells");
  cmd->add_option("--box", o->box, "foam box W,D,H (mm)")->delimiter(',')->expected(3);
  cmd->add_option("--mesh", o->foam.mesh, "foam inside this closed mesh (STL, OBJ, 3MF)");
  cmd->add_option("--density", o->foam.density, "foam seeds per mm³")->capture_default_str();
  cmd->add_option("--seed", o->foam.seed, "foam random seed")->capture_default_str();
  cmd->add_option("--conformal", o->conformal.mesh,
                  "the --cell lattice clipped to this closed mesh (STL, OBJ, 3MF)");
  cmd->add_option("--skin", o->conformal.skin,
                  "with --conformal: a stochastic (Voronoi) skin this thick (mm); 0 = none")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--skin-density", o->conformal.skin_density, "skin foam seeds per mm³")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--materials", o->materials, "per-strut material rule")
      ->check(CLI::IsMember({"none", "xy-plane", "component", "vertical"}))
      ->capture_default_str();
  cmd->add_option("-o,--output", o->output, "lattice to write: JSON, or a 3MF beam lattice (.3mf)")
      ->required();
  cmd->add_option("--radius", o->radius, "strut radius written to a 3MF beam lattice (mm)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--png", o->png, "isometric preview PNG");
  cmd->callback([o] {
    Diagnostics diag;
    Graph g;
    if (!o->conformal.mesh.empty()) {
      o->conformal.cell = unit_cell_from_string(o->cell);
      o->conformal.size = o->cells.size;
      o->conformal.seed = o->foam.seed;
      g = conformal_lattice(o->conformal, diag);
    } else if (o->foam_mode) {
      if (!o->box.empty()) {
        o->foam.width = o->box[0];
        o->foam.depth = o->box[1];
        o->foam.height = o->box[2];
      }
      g = voronoi_foam(o->foam, diag);
    } else {
      o->cells.cell = unit_cell_from_string(o->cell);
      o->cells.nx = o->count[0];
      o->cells.ny = o->count[1];
      o->cells.nz = o->count[2];
      g = cell_lattice(o->cells);
    }
    assign_materials(g, material_rule_from_string(o->materials));
    write_lattice(o->output, g, o->radius);
    if (!o->png.empty()) {
      // The struts as one path each, in a single layer, for the 3D view.
      Toolpath tp;
      tp.layers.emplace_back();
      for (const auto& e : g.edges) {
        Path p;
        p.points = {g.nodes[e.a], g.nodes[e.b]};
        p.tool = e.material;
        tp.layers[0].paths.push_back(std::move(p));
      }
      View3dOptions v;
      v.travel = false;
      v.title = std::to_string(g.edges.size()) + " struts";
      render_3d_png(tp, o->png, v);
    }
    print_warnings(diag);
    int materials = 0;
    for (const auto& e : g.edges) materials = std::max(materials, e.material + 1);
    const BBox3 b = g.bbox();
    std::cout << (o->foam_mode ? std::string("foam") : o->cell) << ": " << g.nodes.size()
              << " nodes, " << g.edges.size() << " struts, " << materials << " material(s), "
              << num(b.max.x - b.min.x, 2) << " x " << num(b.max.y - b.min.y, 2) << " x "
              << num(b.max.z - b.min.z, 2) << " mm -> " << o->output << "\n";
  });
}

}  // namespace trellis::cli
