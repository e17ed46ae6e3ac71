#include <fmt/format.h>
#include <sys/resource.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/render/render.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

namespace {

TpmsKind tpms_kind(const std::string& name) {
  if (name == "gyroid") return TpmsKind::Gyroid;
  if (name == "schwarz_p" || name == "p") return TpmsKind::SchwarzP;
  if (name == "schwarz_d" || name == "diamond" || name == "d") return TpmsKind::SchwarzD;
  if (name == "neovius") return TpmsKind::Neovius;
  if (name == "iwp") return TpmsKind::Iwp;
  throw SettingError("unknown cell type '" + name +
                     "' (expected gyroid, schwarz_p, schwarz_d, neovius or iwp)");
}

// "TYPE:CELL" or "TYPE:CELL:WEIGHT".
Field tpms_spec(const std::string& spec, double* weight) {
  const auto a = spec.find(':');
  if (a == std::string::npos) throw SettingError("expected TYPE:CELL, got '" + spec + "'");
  const auto b = spec.find(':', a + 1);
  const std::string type = spec.substr(0, a);
  double cell = 0;
  try {
    cell = std::stod(spec.substr(a + 1, b == std::string::npos ? std::string::npos : b - a - 1));
    if (weight && b != std::string::npos) *weight = std::stod(spec.substr(b + 1));
  } catch (const std::exception&) {
    throw SettingError("bad number in '" + spec + "'");
  }
  if (!(cell > 0)) throw SettingError("cell size must be > 0 in '" + spec + "'");
  return tpms(tpms_kind(type), {cell, cell, cell});
}

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

// Per-layer columns of the report (z, FR_a of the path and of R67, lengths, area, scan times).
nlohmann::ordered_json pbf_layer_series(const PbfResult& r) {
  nlohmann::ordered_json s;
  for (const char* k : {"z_mm", "fr_a", "fr_a_r67", "contour_mm", "hatch_mm", "r67_hatch_mm",
                        "area_mm2", "scan_time_s", "scan_time_r67_s"})
    s[k] = nlohmann::json::array();
  for (const auto& L : r.layers) {
    s["z_mm"].push_back(L.z);
    s["fr_a"].push_back(L.fr);
    s["fr_a_r67"].push_back(L.fr_r67);
    s["contour_mm"].push_back(L.contour_length);
    s["hatch_mm"].push_back(L.hatch_length);
    s["r67_hatch_mm"].push_back(L.r67_length);
    s["area_mm2"].push_back(L.area);
    s["scan_time_s"].push_back(L.scan_time);
    s["scan_time_r67_s"].push_back(L.scan_time_r67);
  }
  return s;
}

// FR_a over layers (paper Fig. 3(b)): this path and the R67 baseline; returns the PNG's path.
std::string render_fr_plot(const PbfResult& r, bool r67, const std::string& dir) {
  std::vector<double> x;
  PlotSeries fh{r67 ? "R67" : "hybrid", {}, 0.85, 0.1, 0.1}, fb{"R67 baseline", {}, 0.1, 0.3, 0.8};
  for (std::size_t i = 0; i < r.layers.size(); ++i) {
    x.push_back(static_cast<double>(i + 1));
    const bool any = r.layers[i].area > 0;
    fh.values.push_back(any ? r.layers[i].fr : NAN);
    fb.values.push_back(any ? r.layers[i].fr_r67 : NAN);
  }
  const std::string path = dir + "/fr_a.png";
  render_series_png(x, {fh, fb}, "filling ratio FR_a = D·ΣL/A per layer", "layer", path);
  return path;
}

}  // namespace

void add_pbf(CLI::App& app) {
  struct Opts {
    std::string envelope, solids, output, report, toolpath, preview, machine, route = "direct";
    std::string cell_type = "gyroid", c = "0.15", c_expr, grade_to, grade_axis = "z",
                hierarchical;
    double cell = 2.5, thickness = 0, grade_center = 0, grade_width = 1, resolution = 0.025;
    double layer = 0, sl = 0, lhd = -1, hatch = 0, beam = -1, thin_multiple = 1.5,
           min_inclination = 20;
    double wall_thickness = 0, wall_inclination = 90, wall_azimuth = 0, memory_budget_mb = 0,
           hatch_rotation = 67;
    std::vector<double> size;
    bool r67 = false, binary = false;
    std::size_t preview_layers = 3;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "pbf", "Laser powder-bed toolpaths for a TPMS sheet lattice, straight from its field (.cli)");
  cmd->footer(
      "The sheet is Φ = φ² − c² around a TPMS mid-surface φ (--cell-type, --cell; c from --c,\n"
      "--c-expr or --thickness for uniform walls), inside a box (--size) or the solid of\n"
      "ENVELOPE.vcad, plus optional solid parts (--solids, hatched). Per layer: thin, steep walls\n"
      "get one contour track on φ = 0 cut into scan vectors (SL long, LHD gaps, start shifted per\n"
      "layer); joints and shallow parts are hatched at 67° more every layer, ends found on the\n"
      "field and pulled in by the beam compensation. --r67 hatches everything (the baseline).\n"
      "--route stl meshes the field (marching cubes) and slices the mesh, for comparison.\n"
      "Example:\n"
      "  trellis pbf --cell-type schwarz_d --cell 2.5 --size 10,10,10 --machine profiles/pbf_316l_25um.toml\n"
      "      -o lattice.cli --report lattice.json --preview previews/");
  cmd->add_option("envelope", o->envelope, "optional .vcad solid the lattice fills");
  cmd->add_option("-o,--output", o->output, "CLI file to write")->required();
  cmd->add_option("--report", o->report, "JSON report");
  cmd->add_option("--toolpath", o->toolpath, "also write the toolpath JSON");
  cmd->add_option("--preview", o->preview, "directory for layer PNGs (contours red, hatch blue)");
  cmd->add_option("--preview-layers", o->preview_layers, "layers to render")->capture_default_str();
  cmd->add_option("--machine", o->machine, "laser profile (TOML); default: built-in values");
  cmd->add_option("--cell-type", o->cell_type, "gyroid, schwarz_p, schwarz_d, neovius, iwp")
      ->capture_default_str();
  cmd->add_option("--cell", o->cell, "cell size (mm)")->capture_default_str();
  cmd->add_option("--c", o->c, "sheet parameter c (Φ = φ² − c²)")->capture_default_str();
  cmd->add_option("--c-expr", o->c_expr, "c as an expression of x, y, z, rho, r… (graded thickness)");
  cmd->add_option("--thickness", o->thickness, "uniform wall thickness t (mm): c = t·|∇φ|/2");
  cmd->add_option("--size", o->size, "box X,Y,Z (mm) centred at the origin; default 4 cells")
      ->delimiter(',')
      ->expected(3);
  cmd->add_option("--solids", o->solids, ".vcad of solid parts (bosses), hatched");
  cmd->add_option("--grade-to", o->grade_to, "TYPE:CELL blended in by a sigmoid (graded cell size)");
  cmd->add_option("--grade-axis", o->grade_axis, "z (axial) or r (radial)")->capture_default_str();
  cmd->add_option("--grade-center", o->grade_center, "sigmoid centre (mm)")->capture_default_str();
  cmd->add_option("--grade-width", o->grade_width, "sigmoid width (mm)")->capture_default_str();
  cmd->add_option("--hierarchical", o->hierarchical, "TYPE:CELL:WEIGHT superposed (hierarchical)");
  cmd->add_option("--layer", o->layer, "layer thickness (mm); default from the profile");
  cmd->add_option("--sl", o->sl, "contour segment length SL (mm)");
  cmd->add_option("--lhd", o->lhd, "contour segment gap LHD (mm)");
  cmd->add_option("--hatch", o->hatch, "hatch distance (mm)");
  cmd->add_option("--beam-comp", o->beam, "beam compensation (mm)");
  cmd->add_option("--resolution", o->resolution, "sampling step (mm): the STL route's voxel; the direct contours use a grid twice as coarse, crossings refined on the field")
      ->capture_default_str();
  cmd->add_option("--thin-multiple", o->thin_multiple, "thin wall: width <= this × melt pool")
      ->capture_default_str();
  cmd->add_option("--min-inclination", o->min_inclination, "shallower walls are hatched (deg)")
      ->capture_default_str();
  cmd->add_option("--route", o->route, "direct or stl")->capture_default_str();
  cmd->add_flag("--r67", o->r67, "plain 67°-rotating hatch of the whole sheet (the baseline)");
  cmd->add_option("--wall-thickness", o->wall_thickness,
                  "a plane thin wall of this thickness (mm) instead of a TPMS (paper Fig. 3); box "
                  "from --size, default 2,2,20");
  cmd->add_option("--wall-inclination", o->wall_inclination, "wall angle from horizontal (deg)")
      ->capture_default_str();
  cmd->add_option("--wall-azimuth", o->wall_azimuth, "wall direction from the X axis (deg)")
      ->capture_default_str();
  cmd->add_option("--hatch-rotation", o->hatch_rotation, "hatch rotation per layer (deg)")
      ->capture_default_str();
  cmd->add_flag("--binary", o->binary,
                "binary CLI geometry (header stays ASCII, with CLI+ blocks)");
  cmd->add_option("--memory-budget", o->memory_budget_mb,
                  "refuse a job estimated above this (MB); default: the memory available");
  cmd->callback([o] {
    const LaserProfile prof = o->machine.empty() ? LaserProfile{} : load_laser_profile(o->machine);
    if (o->route != "direct" && o->route != "stl")
      throw SettingError("unknown route '" + o->route + "' (expected direct or stl)");
    PbfDesign d;
    if (o->wall_thickness > 0) {
      const Vec3 s =
          o->size.size() == 3 ? Vec3{o->size[0], o->size[1], o->size[2]} : Vec3{2, 2, 20};
      d = plane_wall(o->wall_thickness, o->wall_inclination, o->wall_azimuth, s);
    } else {
      d.phi = tpms(tpms_kind(o->cell_type), {o->cell, o->cell, o->cell});
      if (!o->grade_to.empty()) {
        const Field other = tpms_spec(o->grade_to, nullptr);
        const std::string s = o->grade_axis == "z" ? "z" : o->grade_axis == "r" ? "rho" : "";
        if (s.empty()) throw SettingError("grade axis must be z or r");
        if (!(o->grade_width > 0)) throw SettingError("grade width must be > 0");
        d.phi =
            blend(d.phi, other,
                  {fmt::format("1/(1+exp(-({}-({}))/({})))", s, o->grade_center, o->grade_width)});
      }
      if (!o->hierarchical.empty()) {
        double w = 0.3;
        const Field fine = tpms_spec(o->hierarchical, &w);
        d.phi = blend(d.phi, fine, {fmt::format("{}", w)});
      }
      d.c = {o->c_expr.empty() ? o->c : o->c_expr};
      d.thickness = o->thickness;
      if (!o->envelope.empty()) {
        d.envelope = read_vcad(o->envelope).field;
      } else {
        const double side = 4 * o->cell;
        const Vec3 s =
            o->size.size() == 3 ? Vec3{o->size[0], o->size[1], o->size[2]} : Vec3{side, side, side};
        d.envelope = rectprism(s);
      }
      if (!o->solids.empty()) d.solids = read_vcad(o->solids).field;
    }
    PbfOptions po;
    po.layer = o->layer > 0 ? o->layer : prof.layer;
    po.segment_length = o->sl > 0 ? o->sl : prof.segment_length;
    po.segment_gap = o->lhd >= 0 ? o->lhd : prof.segment_gap;
    po.hatch_distance = o->hatch > 0 ? o->hatch : prof.hatch_distance;
    po.beam_compensation = o->beam >= 0 ? o->beam : prof.beam_compensation;
    po.melt_pool = prof.melt_pool_width;
    po.resolution = o->resolution;
    po.thin_multiple = o->thin_multiple;
    po.min_inclination = o->min_inclination;
    po.hybrid = !o->r67;
    po.stl_route = o->route == "stl";
    po.hatch_rotation = o->hatch_rotation;
    po.timing = scan_timing(prof);
    po.memory_budget = o->memory_budget_mb * 1e6;
    const PbfResult r = plan_pbf(d, po, [](double f) { progress_line("layers", f); });
    const Toolpath tp =
        pbf_toolpath(r, prof.contour_power, prof.contour_speed, prof.hatch_power, prof.hatch_speed);
    write_cli_file(o->output, tp, prof, CliWriteOptions{o->binary, true});
    if (!o->toolpath.empty()) write_toolpath(o->toolpath, tp);
    const PbfStats h = fr_stats(r.layers, false), b = fr_stats(r.layers, true);
    const double rss = peak_rss_mb();
    print_warnings(r.diagnostics);
    if (!o->report.empty()) {
      nlohmann::ordered_json j;
      j["format"] = "trellis.pbf_report";
      j["version"] = 1;
      j["route"] = o->route;
      j["strategy"] = o->r67 ? "r67" : "hybrid";
      j["settings"] = {{"cell_type", o->cell_type},  {"cell_mm", o->cell},
                       {"c", d.c.text},              {"thickness_mm", o->thickness},
                       {"layer_mm", po.layer},       {"segment_length_mm", po.segment_length},
                       {"segment_gap_mm", po.segment_gap}, {"hatch_distance_mm", po.hatch_distance},
                       {"beam_compensation_mm", po.beam_compensation},
                       {"melt_pool_mm", po.melt_pool}, {"resolution_mm", po.resolution},
                       {"thin_multiple", po.thin_multiple},
                       {"min_inclination_deg", po.min_inclination}};
      j["layers"] = r.layers.size();
      j["contour_vectors"] = r.contour_vectors;
      j["hatch_vectors"] = r.hatch_vectors;
      j["contour_length_mm"] = r.contour_length;
      j["hatch_length_mm"] = r.hatch_length;
      j["scan_length_mm"] = r.contour_length + r.hatch_length;
      j["fr_a"] = {{"mean", h.mean}, {"min", h.min}, {"max", h.max}, {"cv", h.cv}};
      j["fr_a_r67_baseline"] = {{"mean", b.mean}, {"min", b.min}, {"max", b.max}, {"cv", b.cv}};
      const PbfStats t = thickness_stats(r.layers);
      j["wall_thickness_mm"] = {{"mean", t.mean}, {"min", t.min}, {"max", t.max},
                                {"spread", t.cv}};
      if (po.stl_route)
        j["mesh"] = {{"triangles", r.mesh_triangles}, {"mesh_bytes", r.mesh_bytes},
                     {"grid_bytes", r.grid_bytes}};
      j["scan_time_s"] = {{"hybrid", r.scan_time},
                          {"r67_baseline", r.scan_time_r67},
                          {"saving", r.scan_time_r67 > 0 ? 1 - r.scan_time / r.scan_time_r67 : 0}};
      j["per_layer"] = pbf_layer_series(r);  // paper Fig. 3(b)
      j["warnings"] = nlohmann::json::array();
      for (const auto& m : r.diagnostics.messages())
        j["warnings"].push_back({{"kind", m.kind}, {"message", m.text}});
      j["memory_estimate_mb"] = r.memory_estimate / 1e6;
      j["time_s"] = r.seconds;
      j["peak_memory_mb"] = rss;
      write_file_atomic(o->report, j.dump(2) + "\n");
    }
    RenderOptions ro;
    ro.colour_by_role = true;
    ro.travel = false;
    ro.starts = false;
    ro.bead_width = prof.melt_pool_width;
    ro.margin_mm = 0.2;
    std::vector<std::string> pngs = render_previews(tp, o->preview, o->preview_layers, ro);
    if (!o->preview.empty()) pngs.push_back(render_fr_plot(r, o->r67, o->preview));
    std::cout << (o->r67 ? "r67" : "hybrid") << " (" << o->route << " route): " << r.layers.size()
              << " layers, " << r.contour_vectors << " contour vectors ("
              << num(r.contour_length, 1) << " mm), " << r.hatch_vectors << " hatch vectors ("
              << num(r.hatch_length, 1) << " mm); FR_a mean " << num(h.mean, 3) << " cv "
              << num(h.cv, 3) << " (R67 baseline " << num(b.mean, 3) << " cv " << num(b.cv, 3)
              << "); scan time " << num(r.scan_time, 1) << " s (R67 " << num(r.scan_time_r67, 1)
              << " s); " << num(r.seconds, 2) << " s, peak " << num(rss, 0) << " MB\n";
    std::cout << "wrote " << o->output;
    if (!o->report.empty()) std::cout << ", " << o->report;
    if (!o->toolpath.empty()) std::cout << ", " << o->toolpath;
    for (const auto& p : pngs) std::cout << ", " << p;
    std::cout << "\n";
  });
}

}  // namespace trellis::cli
