#include <iostream>

#include "commands.hpp"
#include "trellis/analysis/pores.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/plan.hpp"
#include "trellis/render/render.hpp"

namespace trellis::cli {

void add_lattice2d(CLI::App& app) {
  struct Opts {
    AtlasParams a;
    std::string pattern = "honeycomb", output, png;
    std::vector<double> center;
    double diameter = 0;
    double line_width = 0.4;
  };
  auto o = std::make_shared<Opts>();
  std::string names;
  for (const auto& n : pattern_names()) names += (names.empty() ? "" : ", ") + n;
  auto* cmd =
      app.add_subcommand("lattice2d", "Generate a 2D lattice from the atlas (lattice JSON)");
  cmd->footer(
      "Patterns: " + names +
      ".\nThe cell size means: honeycomb = hexagon side; penrose = rhombus side; snub-square = "
      "edge;\narrowhead, reentrant-honeycomb = horizontal period; square, triangle, lines = "
      "strand distance.\nThe pattern is generated over at least twice the region, rotated "
      "about the region centre,\nand cropped with a node where the crop cuts a strut.");
  cmd->add_option("--pattern", o->pattern, "pattern name")->capture_default_str();
  cmd->add_option("--cell", o->a.cell_size, "cell size (mm)")->capture_default_str();
  cmd->add_option("--strand", o->a.strand_distance,
                  "strand distance for square/triangle/lines (mm; 0 = cell)");
  cmd->add_option("--rotation", o->a.rotation_deg, "pattern rotation (degrees)")
      ->capture_default_str();
  cmd->add_option("--density", o->a.voronoi_density, "Voronoi seeds per mm²")
      ->capture_default_str();
  cmd->add_option("--seed", o->a.seed, "Voronoi random seed")->capture_default_str();
  cmd->add_option("--width", o->a.region.width, "rectangle width (mm)")->capture_default_str();
  cmd->add_option("--height", o->a.region.height, "rectangle height (mm)")->capture_default_str();
  cmd->add_option("--diameter", o->diameter, "crop to a circle of this diameter instead (mm)");
  cmd->add_option("--center", o->center, "region centre x,y (mm); default: lower-left corner at 0,0")
      ->delimiter(',')
      ->expected(2);
  cmd->add_option("--z", o->a.z, "height of the lattice plane (mm)")->capture_default_str();
  cmd->add_flag("--contour", o->a.contour, "add the region outline as struts");
  cmd->add_flag("--handles", o->a.handles, "add tensile-test handles at both x ends");
  cmd->add_option("--handle-length", o->a.handle_length, "handle length along x (mm)")
      ->capture_default_str();
  cmd->add_option("--handle-width", o->a.handle_width, "handle width along y (mm)")
      ->capture_default_str();
  cmd->add_option("-o,--output", o->output, "lattice JSON to write")->required();
  cmd->add_option("--line-width", o->line_width,
                  "printed line width for the pore area it reports (mm)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--png", o->png, "also write a PNG preview of the struts");
  cmd->callback([o] {
    AtlasParams a = o->a;
    a.pattern = pattern_from_string(o->pattern);
    if (o->diameter > 0) {
      a.region.shape = RegionShape::Circle;
      a.region.diameter = o->diameter;
    }
    a.region.center = o->center.size() == 2 ? Vec2{o->center[0], o->center[1]} : corner_at_origin(a);
    const Graph g = make_lattice2d(a);
    write_lattice(o->output, g);
    const PoreArea pores = pore_area(g, o->line_width);
    std::cout << "lattice: " << to_string(a.pattern) << ", " << g.nodes.size() << " nodes, "
              << g.edges.size() << " edges, " << num(g.total_length(), 1)
              << " mm of struts, lower bound " << lower_bound_paths(g) << " paths, pore area "
              << num(pores.percent(), 1) << "% (" << pores.count << " pores at "
              << num(o->line_width, 2) << " mm lines) -> " << o->output << "\n";
    if (!o->png.empty()) {
      // One path per strut, drawn without order colours: a picture of the design itself.
      Toolpath tp;
      tp.layers.push_back({a.z, {}});
      for (const auto& e : g.edges) {
        Path p;
        p.points = {g.nodes[e.a], g.nodes[e.b]};
        tp.layers[0].paths.push_back(p);
      }
      RenderOptions ro;
      ro.travel = false;
      ro.starts = false;
      render_layer_png(tp, 0, o->png, ro);
      std::cout << "preview: " << o->png << "\n";
    }
  });
}

}  // namespace trellis::cli
