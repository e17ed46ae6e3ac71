#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/slice/nonplanar.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

namespace {

// "3:0,3:1,3:0" (layers:tool groups) or "0,1" (a tool per layer, cycled).
std::vector<int> parse_layer_tools(const std::string& text) {
  std::vector<int> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const auto colon = item.find(':');
    try {
      std::size_t used = 0;
      if (colon == std::string::npos) {
        const int tool = std::stoi(item, &used);
        if (used != item.size() || tool < 0) throw std::invalid_argument(item);
        out.push_back(tool);
      } else {
        const int count = std::stoi(item.substr(0, colon), &used);
        if (used != colon || count < 1) throw std::invalid_argument(item);
        const std::string t = item.substr(colon + 1);
        const int tool = std::stoi(t, &used);
        if (used != t.size() || tool < 0) throw std::invalid_argument(item);
        out.insert(out.end(), static_cast<std::size_t>(count), tool);
      }
    } catch (const std::logic_error&) {
      throw SettingError("bad layer tools entry '" + item +
                             "' (expected LAYERS:TOOL groups like 3:0,3:1,3:0 or tools like 0,1)",
                         {"", 0, "--layer-tools"});
    }
    start = comma + 1;
  }
  return out;
}

}  // namespace

void add_nonplanar(CLI::App& app) {
  struct Opts {
    std::string surface, height_fn, machine, output, report, toolpath, png;
    std::vector<double> domain, angles;
    std::string pattern = "crosshatch", offset = "vertical", layer_tools;
    double angle = 0;
    NonplanarParams prm;
    std::vector<std::string> sets;
    bool no_center = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "nonplanar", "Slice a surface into continuous non-planar layers (embedded printing)");
  cmd->footer(
      "The surface is an open mesh (STL, OBJ, 3MF) or --height-fn z(x,y) over --domain; it must\n"
      "be a height field (no point above another), otherwise the error names where it is not.\n"
      "Each layer is the surface cut by vertical planes --width apart, the cuts joined end to end\n"
      "(nearest neighbour) into one serpentine without travel where the footprint allows, and\n"
      "lifted --layer-height per layer: vertically (--offset vertical, the paper) or along the\n"
      "surface normal for an even thickness (--offset normal). Directions: --pattern crosshatch\n"
      "(--angle, then +90 deg every other layer), parallel (--angle on every layer), or --angles\n"
      "A,B,... cycled over the layers. --layer-tools 3:0,3:1,3:0 prints 3 layers with tool 0,\n"
      "3 with tool 1, 3 with tool 0 (the embedded writer lifts out of the bath to swap).\n"
      "Example:\n"
      "  trellis surface corrugation -o corrugation.stl\n"
      "  trellis nonplanar corrugation.stl --machine profiles/fresh_nonplanar_2syringe.toml\n"
      "      -o corrugation.gcode --report corrugation.json --png corrugation.png");
  cmd->add_option("surface", o->surface, "surface mesh (STL, OBJ, 3MF)");
  cmd->add_option("--height-fn", o->height_fn, "surface z = f(x, y) (muparser; NaN = no surface)");
  cmd->add_option("--domain", o->domain, "X0,Y0,X1,Y1 of --height-fn (mm)")
      ->delimiter(',')
      ->expected(4);
  cmd->add_option("--machine", o->machine, "machine profile (TOML)")->required();
  cmd->add_option("-o,--output", o->output, "G-code to write")->required();
  cmd->add_option("--report", o->report, "JSON report to write");
  cmd->add_option("--toolpath", o->toolpath, "toolpath JSON to write");
  cmd->add_option("--png", o->png, "oblique 3D preview PNG");
  cmd->add_option("--width", o->prm.width, "path width = plane spacing (mm)")->capture_default_str();
  cmd->add_option("--layer-height", o->prm.layer_height, "layer height (mm)")->capture_default_str();
  cmd->add_option("--layers", o->prm.layers, "number of layers")->capture_default_str();
  cmd->add_option("--pattern", o->pattern, "layer directions")
      ->check(CLI::IsMember({"crosshatch", "parallel"}))
      ->capture_default_str();
  cmd->add_option("--angle", o->angle, "path direction of the first layer (deg from +X)")
      ->capture_default_str();
  cmd->add_option("--angles", o->angles, "directions cycled over the layers (deg)")
      ->delimiter(',');
  cmd->add_option("--offset", o->offset, "how layers stack")
      ->check(CLI::IsMember({"vertical", "normal"}))
      ->capture_default_str();
  cmd->add_option("--chord-tol", o->prm.chord_tolerance,
                  "max distance of a path segment from the surface (mm)")
      ->capture_default_str();
  cmd->add_option("--max-join", o->prm.max_join,
                  "longest end-to-end connector printed instead of a travel (mm; 0 = 4 x width)")
      ->capture_default_str();
  auto* tools = cmd->add_option("--layer-tools", o->layer_tools,
                                "tools per layer: LAYERS:TOOL groups (3:0,3:1,3:0) or TOOL list");
  cmd->add_flag("--surface-spacing", o->prm.spacing_along_surface,
                "lines one width apart along the surface (arc length), not in the slicing planes");
  cmd->add_option("--speed", o->prm.speed, "print speed (mm/s; 0 = profile)")->capture_default_str();
  cmd->add_flag("--no-center", o->no_center, "keep surface XY coordinates (no bed centring)");
  cmd->add_option("--set", o->sets, "override a machine setting: section.key=value (repeatable)");
  auto* layers_opt = cmd->get_option("--layers");
  cmd->callback([o, tools, layers_opt] {
    if (o->surface.empty() == o->height_fn.empty())
      throw SettingError("give a surface mesh or --height-fn (one of them)");
    MachineProfile profile = load_profile(o->machine);
    if (o->no_center) profile.center = false;
    for (const auto& s : o->sets) apply_override(profile, s);
    HeightField surface;
    if (!o->surface.empty()) {
      surface = HeightField::from_mesh(read_mesh(o->surface), o->surface);
    } else {
      if (o->domain.size() != 4)
        throw SettingError("--height-fn needs --domain X0,Y0,X1,Y1", {"", 0, "--domain"});
      surface = HeightField::from_expression(
          o->height_fn, {{o->domain[0], o->domain[1]}, {o->domain[2], o->domain[3]}},
          "z = " + o->height_fn);
    }
    NonplanarParams prm = o->prm;
    prm.offset = offset_mode_from_string(o->offset);
    if (!o->angles.empty()) prm.angles = o->angles;
    else if (o->pattern == "parallel") prm.angles = {o->angle};
    else prm.angles = {o->angle, o->angle + 90};
    if (tools->count() > 0) {
      prm.layer_tools = parse_layer_tools(o->layer_tools);
      // Groups name every layer: their sum is the layer count unless --layers says otherwise.
      if (o->layer_tools.find(':') != std::string::npos && layers_opt->count() == 0)
        prm.layers = static_cast<int>(prm.layer_tools.size());
    }
    profile.layer_height = prm.layer_height;
    NonplanarResult r = slice_nonplanar(surface, prm);
    const SurfaceDeviation dev = surface_deviation(r.toolpath, surface, prm);
    const GcodeStats g = write_gcode_file(o->output, r.toolpath, profile);
    if (!o->toolpath.empty()) write_toolpath(o->toolpath, r.toolpath);
    if (!o->report.empty())
      write_file_atomic(o->report, nonplanar_report_json(r, prm, surface, dev, &g));
    if (!o->png.empty()) {
      View3dOptions v;
      v.title = surface.name();
      render_3d_png(r.toolpath, o->png, v);
    }
    std::size_t paths = 0, travel = 0;
    double length = 0;
    for (const auto& l : r.layers) paths += l.paths, travel += l.travel_moves, length += l.length;
    std::cout << r.layers.size() << " layers, " << paths << " paths, " << travel
              << " travel moves within layers, " << g.tool_changes << " tool changes, "
              << num(length, 1) << " mm of path, steepest descent " << num(r.max_descent_deg, 1)
              << " deg, max deviation from the surface " << num(dev.max_point, 4)
              << " mm (chords " << num(dev.max_chord, 4) << " mm), ~"
              << num(g.print_time_s / 60, 1) << " min\nwrote " << o->output;
    if (!o->report.empty()) std::cout << ", " << o->report;
    if (!o->toolpath.empty()) std::cout << ", " << o->toolpath;
    if (!o->png.empty()) std::cout << ", " << o->png;
    std::cout << "\n";
  });
}

void add_surface(CLI::App& app) {
  struct Opts {
    std::string kind, output, png, machine;
    CorrugationParams corr;
    MiuraParams miura;
    MCurveParams m;
    AngleTestParams angles;
    double radius = 10, diameter = 12, resolution = 0.1;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("surface", "Generate the non-planar paper's test surfaces");
  cmd->footer(
      "Kinds:\n"
      "  corrugation  44 x 16 mm, --periods (0, 2.5, 5, 10) of a wave at --angle (45 deg) times\n"
      "               --amplitude-scale (1, 0.5, 0.25, 0), --fillet diameter (0, 0.5, 1, 2 mm),\n"
      "               flat clamping ends of --flat mm\n"
      "  miura        Miura-Ori folds of --depth (0, 2, 4, 6 mm), same size\n"
      "  m-curve      the \"M\" profile of the two-material print (--length, --width, --height)\n"
      "  sphere-cap   a cap of a sphere of --radius over a disc of --diameter\n"
      "  angle-test   the print-angle test path (one line per angle, up then down), written as\n"
      "               toolpath JSON, or G-code with --machine\n"
      "Surfaces are written as STL (extruded profiles exactly, others on a --resolution grid).");
  cmd->add_option("kind", o->kind, "surface kind")
      ->required()
      ->check(CLI::IsMember({"corrugation", "miura", "m-curve", "sphere-cap", "angle-test"}));
  cmd->add_option("-o,--output", o->output, "STL (or angle-test JSON / G-code) to write")
      ->required();
  cmd->add_option("--png", o->png, "oblique 3D preview PNG of the surface's first layer");
  cmd->add_option("--length", o->corr.length, "length along X (mm)")->capture_default_str();
  cmd->add_option("--width", o->corr.width, "width along Y (mm)")->capture_default_str();
  cmd->add_option("--periods", o->corr.periods, "corrugation periods")->capture_default_str();
  cmd->add_option("--angle", o->corr.angle_deg, "corrugation slope (deg)")->capture_default_str();
  cmd->add_option("--amplitude-scale", o->corr.amplitude_scale, "corrugation amplitude factor")
      ->capture_default_str();
  cmd->add_option("--fillet", o->corr.fillet_diameter, "fillet diameter at corners (mm)")
      ->capture_default_str();
  cmd->add_option("--flat", o->corr.flat_length, "flat end length (mm)")->capture_default_str();
  cmd->add_option("--depth", o->miura.depth, "Miura-Ori fold depth (mm)")->capture_default_str();
  cmd->add_option("--height", o->m.height, "M curve height (mm)")->capture_default_str();
  cmd->add_option("--radius", o->radius, "sphere radius (mm)")->capture_default_str();
  cmd->add_option("--diameter", o->diameter, "sphere cap footprint diameter (mm)")
      ->capture_default_str();
  cmd->add_option("--angles", o->angles.angles, "angle test angles (deg)")->delimiter(',');
  cmd->add_option("--resolution", o->resolution, "grid spacing of generated meshes (mm)")
      ->capture_default_str();
  cmd->add_option("--machine", o->machine, "angle test: write G-code for this profile");
  auto* length_opt = cmd->get_option("--length");
  auto* width_opt = cmd->get_option("--width");
  cmd->callback([o, length_opt, width_opt] {
    if (o->kind == "angle-test") {
      if (length_opt->count()) o->angles.length = o->corr.length;
      const Toolpath tp = angle_test(o->angles);
      if (!o->machine.empty()) {
        MachineProfile profile = load_profile(o->machine);
        write_gcode_file(o->output, tp, profile);
      } else {
        write_toolpath(o->output, tp);
      }
      if (!o->png.empty()) render_3d_png(tp, o->png, {});
      std::cout << "angle test: " << tp.layers[0].paths.size() << " lines; wrote " << o->output
                << "\n";
      return;
    }
    HeightField s;
    if (o->kind == "corrugation") {
      s = corrugation(o->corr);
    } else if (o->kind == "miura") {
      o->miura.length = o->corr.length, o->miura.width = o->corr.width;
      s = miura(o->miura);
    } else if (o->kind == "m-curve") {
      if (length_opt->count()) o->m.length = o->corr.length;
      if (width_opt->count()) o->m.width = o->corr.width;
      o->m.fillet_diameter = o->corr.fillet_diameter;
      s = m_curve(o->m);
    } else {
      s = sphere_cap(o->radius, o->diameter);
    }
    const TriangleMesh mesh = surface_mesh(s, o->resolution);
    write_file_atomic(o->output, mesh_to_stl(mesh, s.name()));
    if (!o->png.empty()) {
      NonplanarParams prm;
      prm.layers = 1;
      View3dOptions v;
      v.title = s.name();
      render_3d_png(slice_nonplanar(s, prm).toolpath, o->png, v);
    }
    std::cout << s.name() << ": " << mesh.triangles.size() << " triangles; wrote " << o->output
              << (o->png.empty() ? "" : ", " + o->png) << "\n";
  });
}

}  // namespace trellis::cli
