#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/render/render.hpp"
#include "trellis/slice/pipeline.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

void add_slice(CLI::App& app) {
  struct Opts {
    std::string input, machine, output, report, toolpath, preview, route = "auto";
    std::vector<std::string> sets;
    double layer_height = 0.2, infill = 0.2, infill_angle = 45, resolution = 0.1,
           mesh_voxel = 0.25, bead_width = 0;
    int walls = 2, top = 4, bottom = 4, strategy = 0, colors = 8;
    bool no_center = false, concentric = false, fixed_angle = false;
    double lookahead = -1, zipper = 0, material_resolution = 1.0;
    std::size_t preview_layers = 4;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "slice", "Slice a design (.vcad) or a mesh (.stl, .obj, .3mf) into walls, skins and infill");
  cmd->footer(
      "Routes: a .vcad design is contoured straight from its implicit field at every layer\n"
      "(marching squares at --resolution, crossings refined on the field; no mesh). A mesh is cut\n"
      "by planes (--route mesh, its default) or turned into a distance field first (--route field,\n"
      "voxel --mesh-voxel). Designs centred at the origin are moved to the bed centre unless\n"
      "--no-center. Example:\n"
      "  trellis slice examples/designs/fgm_column2_plate.vcad --machine profiles/ender3_s1_pro_tpu.toml\n"
      "      -o plate.gcode --report plate.json --preview previews/");
  cmd->add_option("design", o->input, "design .vcad, or mesh .stl/.obj/.3mf")->required();
  cmd->add_option("--machine", o->machine, "machine profile (TOML)")->required();
  cmd->add_option("-o,--output", o->output, "G-code file to write")->required();
  cmd->add_option("--report", o->report, "JSON report to write");
  cmd->add_option("--toolpath", o->toolpath, "also write the toolpath JSON");
  cmd->add_option("--preview", o->preview, "directory for layer PNGs");
  cmd->add_option("--preview-layers", o->preview_layers, "how many layers to render (spread over the part)")
      ->capture_default_str();
  cmd->add_option("--route", o->route, "auto, field or mesh")->capture_default_str();
  cmd->add_option("--layer-height", o->layer_height, "layer height (mm)")->capture_default_str();
  cmd->add_option("--walls", o->walls, "number of walls")->capture_default_str();
  cmd->add_option("--infill", o->infill, "sparse infill density 0..1")->capture_default_str();
  cmd->add_option("--infill-angle", o->infill_angle, "infill angle (deg), +90 every other layer")
      ->capture_default_str();
  cmd->add_option("--top", o->top, "solid top layers")->capture_default_str();
  cmd->add_option("--bottom", o->bottom, "solid bottom layers")->capture_default_str();
  cmd->add_option("--bead-width", o->bead_width, "bead width (mm); default the nozzle diameter");
  cmd->add_option("--resolution", o->resolution, "XY grid step of field contours (mm)")
      ->capture_default_str();
  cmd->add_option("--mesh-voxel", o->mesh_voxel, "voxel of mesh distance fields (mm)")
      ->capture_default_str();
  cmd->add_option("--strategy", o->strategy,
                  "graded designs (two or three materials): 1 = walls/skins/infill cut by colour faces, purge "
                  "towers from the profile's [purge]; 2 = colour faces filled densely; both in "
                  "palette order with the profile's [gradient] commands; 0 = one material")
      ->check(CLI::IsMember({0, 1, 2}))
      ->capture_default_str();
  cmd->add_option("--colors", o->colors, "graded designs: colours in the palette (two materials: N bands of 100%/N; three: "
                  "d² triangles of the mixture triangle, e.g. 9)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_flag("--concentric", o->concentric, "Strategy 2: concentric fill instead of rectilinear");
  cmd->add_flag("--fixed-angle", o->fixed_angle,
                "Strategy 2: rectilinear lines at --infill-angle (+90° a layer) instead of along the "
                "local iso-lines (perpendicular to the gradient, per 4 mm square)");
  cmd->add_option("--material-resolution", o->material_resolution,
                  "graded designs: XY grid of the material iso-contours (mm; crossings are refined "
                  "on the field; finer finds smaller features of the gradient)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--zipper", o->zipper,
                  "Strategy 1: overlap band β (% of the gradient) where pieces alternate between "
                  "the two neighbouring colours")
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--lookahead", o->lookahead,
                  "issue mixture changes this many mm of path early (dead volume; default: the "
                  "profile's gradient.lookahead)");
  cmd->add_flag("--no-center", o->no_center, "keep design XY coordinates (no bed centring)");
  cmd->add_option("--set", o->sets, "override a machine setting: section.key=value (repeatable)");
  cmd->callback([o] {
    MachineProfile profile = load_profile(o->machine);
    profile.center = !o->no_center;
    for (const auto& s : o->sets) apply_override(profile, s);
    if (o->lookahead >= 0) profile.lookahead = o->lookahead;
    SliceJob job;
    job.input = o->input;
    job.route = slice_route_from_string(o->route);
    job.field.resolution = o->resolution;
    job.mesh_voxel = o->mesh_voxel;
    job.planar.layer_height = o->layer_height;
    job.planar.walls = o->walls;
    job.planar.infill_density = o->infill;
    job.planar.infill_angle = o->infill_angle;
    job.planar.top_layers = o->top;
    job.planar.bottom_layers = o->bottom;
    job.planar.bead_width = o->bead_width > 0 ? o->bead_width : profile.nozzle_diameter;
    job.strategy = o->strategy;
    job.fgm.palette.colors = o->colors;
    job.fgm.concentric = o->concentric;
    job.fgm.fixed_angle = o->fixed_angle;
    job.fgm.angle_deg = o->infill_angle;
    job.fgm.zipper = o->zipper / 100;
    job.fgm.material_resolution = o->material_resolution;
    job.purge.melt_volume = profile.melt_volume;
    job.purge.threshold = profile.purge_threshold;
    job.purge.x = profile.purge_x;
    job.purge.y = profile.purge_y;
    job.purge.side = profile.purge_side;
    profile.layer_height = o->layer_height;
    const SliceResult r = run_slice(job, {progress_line});
    const GcodeStats g = write_gcode_file(o->output, r.toolpath, profile);
    if (!o->toolpath.empty()) write_toolpath(o->toolpath, r.toolpath);
    if (!o->report.empty()) write_file_atomic(o->report, slice_report_json(job, r, &g));
    RenderOptions ro;
    ro.colour_by_mixture = job.strategy != 0;  // graded: coloured by the palette
    ro.starts = job.strategy == 0;
    const std::vector<std::string> pngs =
        render_previews(r.toolpath, o->preview, o->preview_layers, ro);
    if (job.strategy != 0)
      std::cout << "strategy " << job.strategy << ": " << o->colors << " colours, " << r.fgm.faces << " faces, "
                << r.fgm.paths << " paths, " << g.gradient_changes << " " << profile.gradient_mode
                << " changes (look-ahead " << num(profile.lookahead, 0) << " mm), " << r.fgm.purges
                << " purges (" << num(r.fgm.purge_volume, 0) << " mm3), gradient error mean "
                << num(r.fgm.error_mean, 4) << " max " << num(r.fgm.error_max, 4) << " (bound "
                << num(r.fgm.error_bound, 4) << "), shortest "
                << num(r.fgm.shortest_path, 2) << " mm; " << to_string(r.route) << " route, "
                << r.outlines.size() << " layers, ~" << num(g.print_time_s / 60, 1) << " min\n";
    else
    std::cout << to_string(r.route) << " route: " << r.outlines.size() << " layers, "
              << r.planar.paths << " paths (" << r.planar.walls << " wall loops, "
              << r.planar.skin_lines << " skin paths, " << r.planar.infill_lines
              << " infill lines), " << num(r.planar.extruded_length, 1) << " mm extruded, ~"
              << num(g.print_time_s / 60, 1) << " min; outlines " << num(r.outline_seconds, 2)
              << " s, walls+infill " << num(r.plan_seconds, 2) << " s\n";
    std::cout << "wrote " << o->output;
    if (!o->report.empty()) std::cout << ", " << o->report;
    if (!o->toolpath.empty()) std::cout << ", " << o->toolpath;
    for (const auto& p : pngs) std::cout << ", " << p;
    std::cout << "\n";
  });
}

}  // namespace trellis::cli
