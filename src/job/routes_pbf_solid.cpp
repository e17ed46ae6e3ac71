// The pbf route for solid parts (slice/pbf_mesh.hpp): a mesh, or a .vcad with a solid scan
// strategy, sliced and scanned with contours and the strategy's hatch, written to CLI layer by
// layer when the build file is the only output.
#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "routes.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/implicit_3mf.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/slice/pbf_mesh.hpp"

namespace fs = std::filesystem;

namespace trellis::routes {

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext;
}

ScanStrategy strategy_of(PbfStrategy s) {
  switch (s) {
    case PbfStrategy::Rectilinear:
      return ScanStrategy::Rectilinear;
    case PbfStrategy::Stripe:
      return ScanStrategy::Stripe;
    case PbfStrategy::Island:
      return ScanStrategy::Island;
    default:
      return ScanStrategy::Meander;  // meander, and hybrid / r67 on a mesh (no sheet to trace)
  }
}

double peak_memory_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

// The laser parameter sets of a solid part: the profile's contour and hatch, each contour
// offset's (laser.contour_powers/speeds), the core's, up-skin's and down-skin's.
PbfExposures pbf_exposures(const Config& c) {
  const LaserProfile& prof = c.laser;
  PbfExposures e;
  e.contour = {prof.contour_power, prof.contour_speed};
  e.hatch = {prof.hatch_power, prof.hatch_speed};
  const std::size_t n = std::max(prof.contour_powers.size(), prof.contour_speeds.size());
  const auto pick = [](const std::vector<double>& v, std::size_t i, double fallback) {
    return v.empty() ? fallback : v[std::min(i, v.size() - 1)];
  };
  for (std::size_t i = 0; i < n; ++i)
    e.contours.push_back({pick(prof.contour_powers, i, prof.contour_power),
                          pick(prof.contour_speeds, i, prof.contour_speed)});
  e.core = {prof.core_power, prof.core_speed};
  e.upskin = {prof.upskin_power, prof.upskin_speed};
  e.downskin = {prof.downskin_power, prof.downskin_speed};
  return e;
}

PbfSolidOptions pbf_solid_options(const Config& c) {
  const LaserProfile& prof = c.laser;
  PbfSolidOptions o;
  o.layer = prof.layer;
  o.beam_compensation = prof.beam_compensation;
  o.contours = c.pbf.contours;
  o.contour_distance = c.pbf.contour_distance;
  o.pattern = c.pbf.pattern;
  o.pattern.strategy = strategy_of(c.pbf.strategy);
  o.pattern.hatch_distance = prof.hatch_distance;
  o.pattern.angle = c.pbf.options.hatch_angle;
  o.pattern.rotation = c.pbf.options.hatch_rotation;
  o.hatch_phase = c.pbf.options.hatch_phase;
  o.machine_origin = pbf_machine_origin(c);
  o.hatch_seed = c.pbf.options.hatch_seed;
  o.skin = c.pbf.skin;
  for (std::size_t k = 0; k < kHatchKinds; ++k) {
    o.kind_hatch[k].distance = c.pbf.kind_hatch_distance[k];
    if (c.pbf.kind_rotation[k].size() == 1) o.kind_hatch[k].rotation = c.pbf.kind_rotation[k][0];
  }
  o.exposures = pbf_exposures(c);
  o.resolution = c.pbf.options.resolution;
  o.timing = scan_timing(prof);
  return o;
}

nlohmann::ordered_json layer_series(const PbfResult& r) {
  nlohmann::ordered_json s;
  for (const char* k : {"z_mm", "area_mm2", "contour_mm", "hatch_mm", "scan_time_s"})
    s[k] = nlohmann::json::array();
  for (const PbfLayer& L : r.layers) {
    s["z_mm"].push_back(L.z);
    s["area_mm2"].push_back(L.area);
    s["contour_mm"].push_back(L.contour_length);
    s["hatch_mm"].push_back(L.hatch_length);
    s["scan_time_s"].push_back(L.scan_time);
  }
  return s;
}

}  // namespace

Vec2 pbf_machine_origin(const Config& c) {
  return c.pbf.plate_position.size() == 2
             ? Vec2{-c.pbf.plate_position[0], -c.pbf.plate_position[1]}
             : Vec2{-0.5 * c.laser.build_x, -0.5 * c.laser.build_y};  // centred on the plate
}

bool is_mesh_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".stl" || ext == ".obj" || ext == ".3mf";
}

bool pbf_solid_job(const Job& job, const Config& c) {
  const bool solid = solid_strategy(c.pbf.strategy);
  if (solid && (job.input.empty() || !job.parts.empty() || job.shards))
    throw SettingError(fmt::format("the {} strategy scans a solid part: give one mesh (STL, OBJ, "
                                   "3MF) or .vcad solid as the input (build plates and shards "
                                   "of solid parts are not planned yet); TPMS lattices take "
                                   "hybrid or r67",
                                   to_string(c.pbf.strategy)),
                       {"", 0, "pbf.strategy"});
  if (job.input.empty()) return false;
  // A 3MF level-set design is a field like a .vcad (field/implicit_3mf.hpp), not a mesh.
  return solid || (is_mesh_path(job.input) && !is_implicit_3mf(job.input));
}

namespace {

// Skin, core, up-skin and down-skin: each kind's area and hatch length over the layers, its
// parameter set and thickness.
nlohmann::ordered_json region_report(const PbfResult& r, const PbfSolidOptions& o) {
  nlohmann::ordered_json j;
  j["skin_thickness_mm"] = o.skin.skin_thickness;
  j["upskin_thickness_mm"] = o.skin.upskin_thickness;
  j["downskin_thickness_mm"] = o.skin.downskin_thickness;
  for (std::size_t k = 0; k < kHatchKinds; ++k) {
    double a = 0, h = 0;
    for (const PbfLayer& L : r.layers) a += L.kind_area[k], h += L.kind_hatch_length[k];
    const auto kind = static_cast<HatchKind>(k);
    const LaserSet s = o.exposures.of(kind);
    const ScanPattern p = o.pattern_of(kind);
    j[hatch_kind_name(kind)] = {{"area_mm2", a},
                                {"hatch_mm", h},
                                {"power_w", s.power},
                                {"speed_mm_s", s.speed},
                                {"hatch_distance_mm", p.hatch_distance},
                                {"hatch_rotation_deg", p.rotation}};
  }
  return j;
}

}  // namespace

JobResult pbf_solid(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  if (!job.parts.empty() || job.shards)
    throw SettingError(
        "build plates and shards of solid parts (meshes, solid strategies) are not "
        "planned yet: run `trellis pbf` on each part",
        {job.input, 0, "job.parts"});
  const LaserProfile& prof = c.laser;
  for (const auto& [key, v] : {std::pair{"laser.contour_powers", &prof.contour_powers},
                               std::pair{"laser.contour_speeds", &prof.contour_speeds}}) {
    if (!v->empty() && v->size() != static_cast<std::size_t>(c.pbf.contours))
      throw SettingError(fmt::format("{} values for {} contours (pbf.contours): give one per "
                                     "contour, outermost first",
                                     v->size(), c.pbf.contours),
                         {"", 0, key});
    for (double x : *v)
      if (!(x > 0)) throw SettingError("every contour's power and speed must be > 0", {"", 0, key});
  }
  const PbfSolidOptions o = pbf_solid_options(c);
  const std::vector<ParameterSet> named = named_parameter_sets(o.exposures, o.skin);
  const std::vector<CliParameterSet> sets = cli_parameter_sets(named);
  TriangleMesh mesh;
  Field field;
  PbfSolid part;
  if (is_mesh_path(job.input) && !is_implicit_3mf(job.input)) {
    mesh = read_mesh(job.input);
    require_closed(mesh, job.input);
    part.mesh = &mesh;
  } else {
    VcadDesign design = read_field_design(job.input);
    warn_min_feature(job.input, design.min_feature_size,
                     "laser's melt pool (laser.melt_pool_width)", c.laser.melt_pool_width,
                     o.resolution, "pbf.resolution", context);
    field = std::move(design.field);
    if (field.has_process())
      throw SettingError(
          "the design sets process fields (fprocess), which only the FDM slice "
          "route writes; remove the fprocess node for laser powder-bed fusion",
          {job.input, 0, "fprocess"});
    part.field = &field;
  }
  const bool stream = !job.keep_toolpath && !job.output.empty() && job.toolpath.empty() &&
                      job.preview.empty() && !is_3mf_output(job.output);
  const bool split = splits_layers(c);
  const LaserSetup setup = lasers_of(c);
  LaserTimes times;
  const auto layer_of = [&](std::size_t i, const PbfLayer& L) {
    Layer layer = pbf_solid_layer_toolpath(L, i, o.layer, o.exposures);
    if (split) times.add(split_among_lasers(layer, setup, i));
    return layer;
  };
  JobResult out;
  Toolpath tp;
  PbfResult r;
  if (stream) {
    CliStreamWriter writer(job.output, prof, CliWriteOptions{c.pbf.binary, true, sets},
                           "trellis pbf", embedded_job(job, job.output));
    r = plan_pbf_solid(
        part, o, [&](std::size_t i, const PbfLayer& L) { writer.add(layer_of(i, L)); }, context);
    writer.finish();
    out.files.push_back(job.output);
  } else {
    r = plan_pbf_solid(part, o, {}, context);
    tp.source = "trellis pbf";
    tp.parameter_sets = named;
    tp.lasers = declared_lasers(&prof, tp);  // the lasers that differ, in the toolpath JSON too
    for (std::size_t i = 0; i < r.layers.size(); ++i) tp.layers.push_back(layer_of(i, r.layers[i]));
    out.toolpath = std::make_shared<Toolpath>(tp);
    // A 3MF's build item: the mesh as read, a .vcad solid meshed at pbf.resolution.
    if (is_3mf_output(job.output))
      out.geometry.mesh = part.mesh ? std::make_shared<const TriangleMesh>(mesh)
                                    : field_mesh_3mf(field, o.resolution, context.budget);
    if (!job.output.empty()) write_laser_build(job.output, tp, job, c, out, sets);
    if (!job.toolpath.empty()) {
      write_toolpath_with_job(job.toolpath, tp, job);
      out.files.push_back(job.toolpath);
    }
  }
  if (r.hatch_vectors == 0 && r.contour_vectors == 0)
    diag.warn("pbf_empty", fmt::format("{}: no layer has a region to scan (the part is thinner "
                                       "than a layer, or narrower than twice the beam "
                                       "compensation)",
                                       job.input));
  const double rss = peak_memory_mb();
  if (!job.report.empty()) {
    nlohmann::ordered_json j;
    j["format"] = "trellis.pbf_report";
    j["version"] = 1;
    j["route"] = "solid";
    j["strategy"] = to_string(c.pbf.strategy);
    j["settings"] = {{"part", fs::path(job.input).filename().string()},
                     {"layer_mm", o.layer},
                     {"hatch_distance_mm", o.pattern.hatch_distance},
                     {"beam_compensation_mm", o.beam_compensation},
                     {"contours", o.contours},
                     {"hatch_rotation_deg", o.pattern.rotation}};
    j["layers"] = r.layers.size();
    j["contour_vectors"] = r.contour_vectors;
    j["hatch_vectors"] = r.hatch_vectors;
    j["contour_length_mm"] = r.contour_length;
    j["hatch_length_mm"] = r.hatch_length;
    j["scan_time_s"] = r.scan_time;
    if (o.skin.any()) j["regions"] = region_report(r, o);
    j["per_layer"] = layer_series(r);
    add_laser_report(j, times, c);
    j["warnings"] = nlohmann::json::array();
    for (const auto& m : diag.messages())
      j["warnings"].push_back({{"kind", m.kind}, {"message", m.text}});
    j["time_s"] = r.seconds;
    j["peak_memory_mb"] = rss;
    write_file_atomic(job.report, with_job(j.dump(2) + "\n", job, job.report));
    out.files.push_back(job.report);
  }
  laser_previews(tp, job, c, out);
  out.summary = fmt::format(
      "{} (solid part): {} layers, {} contour vectors ({} mm), {} hatch vectors ({} mm); scan "
      "time {} s; {} s, peak {} MB",
      to_string(c.pbf.strategy), r.layers.size(), r.contour_vectors, fixed(r.contour_length, 1),
      r.hatch_vectors, fixed(r.hatch_length, 1), fixed(r.scan_time, 1), fixed(r.seconds, 2),
      fixed(rss, 0));
  if (o.skin.any()) {
    std::string kinds;
    for (std::size_t k = 0; k < kHatchKinds; ++k) {
      double a = 0;
      for (const PbfLayer& L : r.layers) a += L.kind_area[k];
      kinds += fmt::format("{}{} {}", k ? ", " : "", hatch_kind_name(static_cast<HatchKind>(k)),
                           fixed(a, 1));
    }
    out.summary += "; region areas summed over layers (mm²): " + kinds;
  }
  out.summary += laser_summary(times);
  return out;
}

}  // namespace trellis::routes
