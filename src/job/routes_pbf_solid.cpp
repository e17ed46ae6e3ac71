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

ScanStrategy strategy_of(const std::string& s) {
  if (s == "rectilinear") return ScanStrategy::Rectilinear;
  if (s == "stripe") return ScanStrategy::Stripe;
  if (s == "island") return ScanStrategy::Island;
  return ScanStrategy::Meander;  // meander, and hybrid / r67 on a mesh (no sheet to trace)
}

double peak_memory_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
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

bool is_mesh_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".stl" || ext == ".obj" || ext == ".3mf";
}

bool pbf_solid_job(const Job& job, const Config& c) {
  const std::string& s = c.pbf.strategy;
  const bool solid_strategy = s != "hybrid" && s != "r67";
  if (solid_strategy && (job.input.empty() || !job.parts.empty() || job.shards))
    throw SettingError(fmt::format("the {} strategy scans a solid part: give one mesh (STL, OBJ, "
                                   "3MF) or .vcad solid as the input (build plates and shards "
                                   "of solid parts are not planned yet); TPMS lattices take "
                                   "hybrid or r67",
                                   s),
                       {"", 0, "pbf.strategy"});
  if (job.input.empty()) return false;
  // A 3MF level-set design is a field like a .vcad (field/implicit_3mf.hpp), not a mesh.
  return solid_strategy || (is_mesh_path(job.input) && !is_implicit_3mf(job.input));
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
  o.resolution = c.pbf.options.resolution;
  o.timing = scan_timing(prof);
  return o;
}

JobResult pbf_solid(const Job& job, const Config& c, Diagnostics& diag, const Progress& progress) {
  if (!job.parts.empty() || job.shards)
    throw SettingError(
        "build plates and shards of solid parts (meshes, solid strategies) are not "
        "planned yet: run `trellis pbf` on each part",
        {job.input, 0, "job.parts"});
  const LaserProfile& prof = c.laser;
  const PbfSolidOptions o = pbf_solid_options(c);
  TriangleMesh mesh;
  Field field;
  PbfSolid part;
  if (is_mesh_path(job.input) && !is_implicit_3mf(job.input)) {
    mesh = read_mesh(job.input);
    require_closed(mesh, job.input);
    part.mesh = &mesh;
  } else {
    field = read_field_design(job.input).field;
    if (field.has_process())
      throw SettingError(
          "the design sets process fields (fprocess), which only the FDM slice "
          "route writes; remove the fprocess node for laser powder-bed fusion",
          {job.input, 0, "fprocess"});
    part.field = &field;
  }
  const bool stream =
      !job.keep_toolpath && !job.output.empty() && job.toolpath.empty() && job.preview.empty();
  const bool split = splits_layers(c);
  const LaserSetup setup = lasers_of(c);
  LaserTimes times;
  const auto layer_of = [&](std::size_t i, const PbfLayer& L) {
    Layer layer = pbf_layer_toolpath(L, i, o.layer, prof.contour_power, prof.contour_speed,
                                     prof.hatch_power, prof.hatch_speed);
    if (split) times.add(split_among_lasers(layer, setup, i));
    return layer;
  };
  JobResult out;
  Toolpath tp;
  PbfResult r;
  if (stream) {
    CliStreamWriter writer(job.output, prof, CliWriteOptions{c.pbf.binary, true}, "trellis pbf",
                           embedded_job(job, job.output));
    r = plan_pbf_solid(part, o, progress,
                       [&](std::size_t i, const PbfLayer& L) { writer.add(layer_of(i, L)); });
    writer.finish();
    out.files.push_back(job.output);
  } else {
    r = plan_pbf_solid(part, o, progress);
    tp.source = "trellis pbf";
    for (std::size_t i = 0; i < r.layers.size(); ++i) tp.layers.push_back(layer_of(i, r.layers[i]));
    out.toolpath = std::make_shared<Toolpath>(tp);
    if (!job.output.empty()) {
      tp.job = embedded_job(job, job.output);
      write_cli_file(job.output, tp, prof, CliWriteOptions{c.pbf.binary, true});
      out.files.push_back(job.output);
    }
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
    j["strategy"] = c.pbf.strategy;
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
      c.pbf.strategy, r.layers.size(), r.contour_vectors, fixed(r.contour_length, 1),
      r.hatch_vectors, fixed(r.hatch_length, 1), fixed(r.scan_time, 1), fixed(r.seconds, 2),
      fixed(rss, 0));
  out.summary += laser_summary(times);
  return out;
}

}  // namespace trellis::routes
