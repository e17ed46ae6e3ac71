#include "trellis/job/job.hpp"

#include "trellis/geom/mesh_io.hpp"

#include <toml++/toml.h>

#include <filesystem>
#include <set>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/report.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis {

namespace fs = std::filesystem;

namespace {

// Strict access to one TOML table: every key read is checked off; leftovers are errors.
class Section {
 public:
  Section(const toml::table* t, std::string name, std::string origin)
      : t_(t), name_(std::move(name)), origin_(std::move(origin)) {}

  template <class T>
  void get(const char* key, T& out) {
    const toml::node* n = take(key);
    if (!n) return;
    const Where where = where_of(key, n);
    if constexpr (std::is_same_v<T, bool>) {
      if (!n->is_boolean()) throw SettingError("expected true or false", where);
      out = *n->value<bool>();
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!n->is_string()) throw SettingError("expected a string", where);
      out = *n->value<std::string>();
    } else if constexpr (std::is_integral_v<T>) {
      if (!n->is_integer()) throw SettingError("expected an integer", where);
      const auto v = *n->value<std::int64_t>();
      if (v < 0) throw SettingError("must be >= 0", where);
      out = static_cast<T>(v);
    } else {
      if (!n->is_number()) throw SettingError("expected a number", where);
      out = *n->value<double>();
      if (!std::isfinite(out)) throw SettingError("must be finite", where);
    }
  }

  void get_point(const char* key, Vec2& out) {
    const toml::node* n = take(key);
    if (!n) return;
    const Where where = where_of(key, n);
    const auto* arr = n->as_array();
    if (!arr || arr->size() != 2 || !(*arr)[0].is_number() || !(*arr)[1].is_number())
      throw SettingError("expected [x, y]", where);
    out = {*(*arr)[0].value<double>(), *(*arr)[1].value<double>()};
  }

  // A file path, relative to the job file's folder unless absolute.
  void get_path(const char* key, std::string& out, const fs::path& base) {
    get(key, out);
    if (!out.empty() && !fs::path(out).is_absolute()) out = (base / out).lexically_normal().string();
  }

  void get_numbers(const char* key, std::vector<double>& out, std::size_t count) {
    const toml::node* n = take(key);
    if (!n) return;
    const Where where = where_of(key, n);
    const auto* arr = n->as_array();
    const std::string want = "expected " + std::to_string(count) + " numbers";
    if (!arr || arr->size() != count) throw SettingError(want, where);
    out.clear();
    for (const auto& v : *arr) {
      if (!v.is_number()) throw SettingError(want, where);
      out.push_back(*v.value<double>());
    }
  }

  Where where(const char* key) const { return where_of(key, t_ ? t_->get(key) : nullptr); }

  void finish() const {
    if (!t_) return;
    for (const auto& [k, n] : *t_)
      if (!seen_.count(std::string(k.str())))
        throw SettingError("unknown key", where_of(std::string(k.str()), &n));
  }

 private:
  // Marks `key` as known and returns its node, or nullptr if absent.
  const toml::node* take(const char* key) {
    if (!t_) return nullptr;
    seen_.insert(key);
    return t_->get(key);
  }

  Where where_of(const std::string& key, const toml::node* n) const {
    return {origin_, n ? static_cast<long>(n->source().begin.line) : 0, name_ + "." + key};
  }

  const toml::table* t_;
  std::string name_, origin_;
  std::set<std::string> seen_;
};

template <class Fn>
auto rethrow_at(const Where& where, Fn fn) {
  try {
    return fn();
  } catch (const SettingError& e) {
    throw SettingError(e.message(), where);
  }
}

}  // namespace

Job load_job(const std::string& path) {
  const std::string text = read_file(path);
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw SettingError(std::string(e.description()),
                       {path, static_cast<long>(e.source().begin.line)});
  }
  const fs::path base = fs::path(path).parent_path();
  for (const auto& [k, n] : root) {
    static const std::set<std::string> known = {"job",    "lattice", "layers",  "plan",
                                                "output", "solid",   "surface", "machine_overrides"};
    if (!known.count(std::string(k.str())) || !n.is_table())
      throw SettingError(
          "unknown section (expected [job], [lattice], [layers], [plan], [solid], [surface], "
          "[output], [machine_overrides])",
          {path, static_cast<long>(n.source().begin.line), std::string(k.str())});
  }
  Job job;
  Section s_job(root["job"].as_table(), "job", path);
  s_job.get("name", job.name);
  s_job.get("output_dir", job.output_dir);
  s_job.get_path("machine", job.machine, base);
  s_job.finish();

  Section s_lat(root["lattice"].as_table(), "lattice", path);
  AtlasParams& a = job.atlas;
  s_lat.get_path("file", job.lattice_file, base);
  std::string pattern = to_string(a.pattern), region = "rectangle";
  s_lat.get("pattern", pattern);
  a.pattern = rethrow_at(s_lat.where("pattern"), [&] { return pattern_from_string(pattern); });
  s_lat.get("cell_size", a.cell_size);
  s_lat.get("strand_distance", a.strand_distance);
  s_lat.get("rotation_deg", a.rotation_deg);
  s_lat.get("voronoi_density", a.voronoi_density);
  s_lat.get("seed", a.seed);
  s_lat.get("region", region);
  if (region != "rectangle" && region != "circle")
    throw SettingError("expected \"rectangle\" or \"circle\"", s_lat.where("region"));
  a.region.shape = region == "circle" ? RegionShape::Circle : RegionShape::Rectangle;
  s_lat.get("width", a.region.width);
  s_lat.get("height", a.region.height);
  s_lat.get("diameter", a.region.diameter);
  s_lat.get("contour", a.contour);
  s_lat.get("handles", a.handles);
  s_lat.get("handle_length", a.handle_length);
  s_lat.get("handle_width", a.handle_width);
  a.region.center = {std::nan(""), 0};
  s_lat.get_point("center", a.region.center);
  s_lat.get("handle_spacing", a.handle_spacing);
  s_lat.get("reentrant_angle_deg", a.reentrant_angle_deg);
  s_lat.get("arrowhead_outer_deg", a.arrowhead_outer_deg);
  s_lat.get("arrowhead_inner_deg", a.arrowhead_inner_deg);
  s_lat.finish();

  Section s_solid(root["solid"].as_table(), "solid", path);
  s_solid.get_path("file", job.solid_file, base);
  s_solid.finish();

  Section s_surf(root["surface"].as_table(), "surface", path);
  auto& sf = job.surface;
  s_surf.get("kind", sf.kind);
  if (root["surface"].as_table() && sf.kind != "sphere-cap" && sf.kind != "mesh" &&
      sf.kind != "function")
    throw SettingError("expected \"sphere-cap\", \"mesh\" or \"function\"", s_surf.where("kind"));
  s_surf.get("radius", sf.radius);
  s_surf.get("diameter", sf.diameter);
  s_surf.get_path("file", sf.file, base);
  s_surf.get("height_fn", sf.height_fn);
  s_surf.get_numbers("domain", sf.domain, 4);
  std::string offset = "normal";
  s_surf.get("offset", offset);
  sf.project.offset = rethrow_at(s_surf.where("offset"), [&] { return offset_mode_from_string(offset); });
  s_surf.get("chord_tolerance", sf.project.chord_tolerance);
  s_surf.finish();
  if (!sf.kind.empty()) {
    if (sf.kind == "mesh" && sf.file.empty())
      throw SettingError("a mesh surface needs file = \"surface.stl\"", s_surf.where("file"));
    if (sf.kind == "function" && (sf.height_fn.empty() || sf.domain.size() != 4))
      throw SettingError("a function surface needs height_fn and domain", s_surf.where("kind"));
  }

  // Without a center, a lattice on a surface is centred on it (when the surface is built, in
  // run_job / job_lattice); otherwise its lower-left corner goes to the origin.
  if (std::isnan(a.region.center.x) && sf.kind.empty()) a.region.center = corner_at_origin(a);

  Section s_layers(root["layers"].as_table(), "layers", path);
  if (!job.solid_file.empty() && !(root["layers"].as_table() && root["layers"]["count"]))
    job.layer_count = 0;  // from the solid's height
  s_layers.get("count", job.layer_count);
  s_layers.get("rotation_deg", job.layer_rotation_deg);
  s_layers.get("layer_height", job.plan.layer_height);
  s_layers.finish();
  if ((job.layer_count < 1 && job.solid_file.empty()) || job.layer_count > 100000)
    throw SettingError("must be 1..100000", s_layers.where("count"));

  Section s_plan(root["plan"].as_table(), "plan", path);
  std::string planner = "gippo", mode = "max", order = to_string(job.plan.order);
  s_plan.get("planner", planner);
  job.plan.planner =
      rethrow_at(s_plan.where("planner"), [&] { return planner_from_string(planner); });
  s_plan.get("mode", mode);
  if (mode != "max" && mode != "min")
    throw SettingError("expected \"max\" or \"min\"", s_plan.where("mode"));
  job.plan.gippo.mode = mode == "max" ? GippoMode::Max : GippoMode::Min;
  s_plan.get("iterations", job.plan.gippo.iterations);
  s_plan.get("seed", job.plan.gippo.seed);
  s_plan.get("threads", job.plan.gippo.threads);
  s_plan.get("long_path_nodes", job.plan.long_path_nodes);
  s_plan.get("order", order);
  job.plan.order = rethrow_at(s_plan.where("order"), [&] { return path_order_from_string(order); });
  s_plan.finish();

  Section s_out(root["output"].as_table(), "output", path);
  s_out.get("gcode", job.gcode);
  s_out.get("png", job.png);
  s_out.get("png_size", job.png_size);
  s_out.finish();

  if (const auto* ov = root["machine_overrides"].as_table())
    for (const auto& [k, n] : *ov) {
      std::string value;
      if (n.is_string())
        value = *n.value<std::string>();
      else if (n.is_boolean())
        value = *n.value<bool>() ? "true" : "false";
      else if (n.is_integer())
        value = std::to_string(*n.value<std::int64_t>());
      else if (n.is_floating_point())
        value = std::to_string(*n.value<double>());
      else
        throw SettingError("expected a value",
                           {path, static_cast<long>(n.source().begin.line), std::string(k.str())});
      job.overrides.push_back(std::string(k.str()) + "=" + value);
    }
  if (job.gcode && job.machine.empty())
    throw SettingError("[job] machine = \"profile.toml\" is needed to write G-code",
                       {path, 0, "job.machine"});
  return job;
}

HeightField job_surface(const Job& job) {
  const auto& sf = job.surface;
  if (sf.kind == "sphere-cap") return sphere_cap(sf.radius, sf.diameter);
  if (sf.kind == "mesh") return HeightField::from_mesh(read_mesh(sf.file), sf.file);
  if (sf.kind == "function" && sf.domain.size() == 4)
    return HeightField::from_expression(
        sf.height_fn, {{sf.domain[0], sf.domain[1]}, {sf.domain[2], sf.domain[3]}},
        "z = " + sf.height_fn);
  throw SettingError("the job has no surface", {"", 0, "surface.kind"});
}

namespace {

Vec2 domain_centre(const HeightField& s) {
  const BBox2 b = s.domain();
  return {(b.min.x + b.max.x) / 2, (b.min.y + b.max.y) / 2};
}

}  // namespace

Graph job_lattice(const Job& job) {
  if (std::isnan(job.atlas.region.center.x)) {  // centred on the job's surface
    Job centred = job;
    centred.atlas.region.center = domain_centre(job_surface(job));
    return job_lattice(centred);
  }
  Graph all;
  // A solid: every layer cropped to its cross-section at mid-layer height.
  TriangleMesh solid;
  BBox3 box;
  int count = job.layer_count;
  const double h = job.plan.layer_height;
  if (!job.solid_file.empty()) {
    solid = read_mesh(job.solid_file);
    require_closed(solid, job.solid_file);
    box = bounds(solid);
    if (count <= 0) count = static_cast<int>(std::floor((box.max.z - box.min.z) / h + 1e-9));
    if (count < 1)
      throw GeometryError("solid '" + job.solid_file + "' is thinner than one layer");
  }
  for (int i = 0; i < count; ++i) {
    AtlasParams a = job.atlas;
    a.rotation_deg += i * job.layer_rotation_deg;
    a.z = a.z + i * h;
    if (!job.solid_file.empty()) {
      a.crop = slice_mesh(solid, box.min.z + (i + 0.5) * h);
      if (a.crop.empty()) continue;
      // Generate over the solid's footprint.
      a.region.shape = RegionShape::Circle;
      a.region.center = {(box.min.x + box.max.x) / 2, (box.min.y + box.max.y) / 2};
      a.region.diameter = std::hypot(box.max.x - box.min.x, box.max.y - box.min.y) + 2 * a.cell_size;
    }
    const Graph layer = make_lattice2d(a);
    const auto offset = static_cast<NodeId>(all.nodes.size());
    all.nodes.insert(all.nodes.end(), layer.nodes.begin(), layer.nodes.end());
    for (Edge e : layer.edges) {
      e.a += offset;
      e.b += offset;
      all.edges.push_back(e);
    }
  }
  return all;
}

JobOutputs run_job(const Job& job, Diagnostics& diag, const Progress& progress) {
  MachineProfile profile;
  if (!job.machine.empty()) profile = load_profile(job.machine);
  for (const auto& o : job.overrides) apply_override(profile, o);

  // The surface is built once: it centres the lattice and receives the planned layers.
  HeightField surface;
  Job centred = job;
  if (!job.surface.kind.empty()) {
    surface = job_surface(job);
    if (std::isnan(job.atlas.region.center.x)) centred.atlas.region.center = domain_centre(surface);
  }
  Graph lattice;
  std::string input;
  if (!job.lattice_file.empty()) {
    lattice = read_lattice(job.lattice_file, {}, diag);
    input = job.lattice_file;
  } else {
    progress("lattice", 0);
    lattice = job_lattice(centred);
    input = "atlas:" + to_string(job.atlas.pattern);
  }
  JobOutputs out;
  const fs::path dir(job.output_dir);
  out.lattice = (dir / (job.name + ".lattice.json")).string();
  write_lattice(out.lattice, lattice);

  PlanParams plan = job.plan;
  out.result = plan_lattice(lattice, plan, diag, progress);
  if (!job.surface.kind.empty()) {
    progress("surface", 0);
    out.result.toolpath = project_onto_surface(out.result.toolpath, surface, job.surface.project);
    out.result.travel = travel_stats(out.result.toolpath);
  }
  out.result.toolpath.source =
      std::string("trellis run ") + job.name + " (" + to_string(plan.planner) + ")";
  out.toolpath = (dir / (job.name + ".toolpath.json")).string();
  write_toolpath(out.toolpath, out.result.toolpath);

  if (job.gcode) {
    const std::string ext = !profile.file_extension.empty()                ? profile.file_extension
                            : profile.parsed_flavor() == Flavor::Pneumatic ? ".nc"
                                                                           : ".gcode";
    out.gcode = (dir / (job.name + ext)).string();
    out.gcode_stats = write_gcode_file(out.gcode, out.result.toolpath, profile);
  }
  if (job.png) {
    RenderOptions ro;
    ro.size_px = job.png_size;
    ro.bead_width = profile.nozzle_diameter;
    for (std::size_t i = 0; i < out.result.toolpath.layers.size(); ++i) {
      char name[64];
      std::snprintf(name, sizeof name, ".layer%03zu.png", i);
      out.pngs.push_back((dir / (job.name + name)).string());
      render_layer_png(out.result.toolpath, i, out.pngs.back(), ro);
    }
    if (!job.surface.kind.empty() || !job.solid_file.empty()) {
      out.pngs.push_back((dir / (job.name + ".3d.png")).string());
      View3dOptions v;
      v.size_px = job.png_size;
      v.title = job.name;
      render_3d_png(out.result.toolpath, out.pngs.back(), v);
    }
    if (!out.result.layers.empty() && !out.result.layers.front().scores.empty()) {
      out.pngs.push_back((dir / (job.name + ".scores.png")).string());
      const auto& l = out.result.layers.front();
      render_scores_png(l.scores, l.best_iteration,
                        job.name + ": GIPPO score per iteration (layer 0)", out.pngs.back());
    }
  }
  const ReportContext ctx{input, lattice.nodes.size(), lattice.edges.size()};
  out.report = (dir / (job.name + ".report.json")).string();
  write_file_atomic(out.report, plan_report_json(out.result, plan, diag, ctx));
  return out;
}

}  // namespace trellis
