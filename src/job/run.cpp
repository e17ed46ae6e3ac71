#include <fmt/format.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "routes.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/implicit_3mf.hpp"
#include "trellis/field/meshing.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/job/plate.hpp"
#include "trellis/machine/bgcode.hpp"
#include "trellis/machine/bgcode_writer.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/toolpath/json.hpp"
#include "trellis/version.hpp"

namespace trellis {

namespace fs = std::filesystem;

namespace routes {

std::string embedded_job(const Job& job, const std::string& path) {
  const std::string dir = fs::path(path).parent_path().string();
  return job_toml(job, dir.empty() ? "." : dir);
}

std::string with_job(const std::string& json, const Job& job, const std::string& path, bool command,
                     const Diagnostics* diag) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(json);
  if (diag && !j.contains("warnings")) {
    j["warnings"] = nlohmann::ordered_json::array();
    for (const auto& m : diag->messages())
      j["warnings"].push_back({{"kind", m.kind}, {"message", m.text}});
  }
  j["job"] = embedded_job(job, path);
  // The literal command line goes into reports only (like their timings), so that a file made
  // from the CLI, from Python or by rerun is the same file.
  if (command && !job.command.empty()) j["command"] = job.command;
  j["generator"] = std::string("Trellis ") + TRELLIS_VERSION;
  return j.dump(2) + "\n";
}

std::string with_field(const std::string& json, const std::string& field,
                       const std::string& value_json) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(json);
  j[field] = nlohmann::ordered_json::parse(value_json);
  return j.dump(2) + "\n";
}

bool is_3mf_output(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext == ".3mf";
}

namespace {

// A 3MF's design mesh is its build item, not what is printed (the toolpath is): a field is
// meshed at the route's resolution, but with at most this many voxels along its longest side.
// At pbf.resolution (0.025 mm) a 10 x 10 x 5 mm gyroid lattice took 20 s, 2.2 GB and 109 MB of
// package against 1.5 s, 0.2 GB and 3.7 MB for its toolpath alone; at 128 (0.078 mm, about the
// melt pool) the mesh stays near the toolpath's cost.
constexpr double kGeometryCells = 128;

// The struts as beams of their radius, else `radius`; struts shorter than the extension's
// minimum beam length are left out, and said.
BeamLattice3mf lattice_beams(const Graph& g, double radius, Diagnostics* diag) {
  BeamLattice3mf l;
  l.vertices = g.nodes;
  std::size_t dropped = 0;
  for (const Edge& e : g.edges) {
    if (!(g.edge_length(static_cast<EdgeId>(&e - g.edges.data())) >= 1e-4)) {
      ++dropped;
      continue;
    }
    const double r = e.radius > 0 ? e.radius : radius;
    l.beams.push_back({e.a, e.b, r, r, e.material});
  }
  if (dropped && diag)
    diag->warn("3mf_short_struts", fmt::format("{} strut(s) shorter than 0.0001 mm are not beams "
                                               "of the 3MF's lattice (Beam Lattice §2.1 minlength)",
                                               dropped));
  return l;
}

// Half the first bead width of the toolpath, else half the nozzle.
double bead_radius(const Toolpath& tp, double nozzle) {
  for (const Layer& l : tp.layers)
    for (const Path& p : l.paths)
      if (p.width > 0) return p.width / 2;
  return nozzle / 2;
}

}  // namespace

std::shared_ptr<const TriangleMesh> field_mesh_3mf(const Field& field, double voxel,
                                                   const Budget& budget) {
  const BBox3 box = field.extent();
  const Vec3 size = box.max - box.min;
  if (!is_finite(size))
    throw GeometryError(
        "the design has no finite extent to mesh as the 3MF's build item (give it a root box)");
  voxel = std::max(voxel, std::max({size.x, size.y, size.z}) / kGeometryCells);
  check_budget(field_mesh_estimate(box, voxel), budget);
  return std::make_shared<const TriangleMesh>(field_to_mesh(field, box, voxel));
}

std::shared_ptr<const TriangleMesh> design_mesh_3mf(const std::string& input, double voxel,
                                                    const Budget& budget) {
  if (is_mesh_path(input) && !is_implicit_3mf(input))
    return std::make_shared<const TriangleMesh>(read_mesh(input));
  VcadOptions vo;
  vo.mesh_voxel = voxel;
  return field_mesh_3mf(read_field_design(input, vo).field, voxel, budget);
}

std::size_t write_3mf_out(const std::string& path, Toolpath& tp, const Job& job,
                          const LaserProfile* laser, JobResult& out, Diagnostics* diag,
                          double nozzle) {
  tp.job = embedded_job(job, path);
  Toolpath3mfOptions o;
  o.laser = laser;
  const JobGeometry& g = out.geometry;
  o.mesh = g.mesh.get();
  o.mesh_is_surface = g.surface;
  o.transform = g.transform;
  for (const JobGeometry::Part& p : g.parts)
    o.parts.push_back({p.mesh.get(), false, nullptr, p.transform, p.name});
  o.bead_width = nozzle;
  BeamLattice3mf beams;
  if (g.struts) {
    beams = lattice_beams(*g.struts, bead_radius(tp, nozzle), diag);
    if (!beams.beams.empty()) o.lattice = &beams;
  }
  const std::string bytes = write_toolpath_3mf(tp, o);
  write_file_atomic(path, bytes);
  out.files.push_back(path);
  return bytes.size();
}

void write_laser_build(const std::string& path, Toolpath& tp, const Job& job, const Config& c,
                       JobResult& out, const std::vector<CliParameterSet>& sets) {
  if (is_3mf_output(path)) {
    write_3mf_out(path, tp, job, &c.laser, out);
    return;
  }
  tp.job = embedded_job(job, path);
  write_cli_file(path, tp, c.laser, CliWriteOptions{c.pbf.binary, true, sets});
  out.files.push_back(path);
}

// A deposition print as a 3MF toolpath: checked against the machine and estimated as the G-code
// the machine would get (made in memory, not written), so the run says the same either way.
static GcodeStats write_3mf_print(const std::string& path, Toolpath tp, const Job& job,
                                  const MachineProfile& machine, JobResult& out,
                                  Diagnostics& diag) {
  GcodeStats stats;
  write_gcode(tp, machine, &stats);
  for (const auto& [kind, message] : stats.warnings) diag.warn(kind, message);
  stats.bytes = write_3mf_out(path, tp, job, nullptr, out, &diag, machine.nozzle_diameter);
  return stats;
}

GcodeStats write_gcode_out(const std::string& path, Toolpath tp, const Job& job,
                           const MachineProfile& machine, JobResult& out, Diagnostics& diag) {
  GcodeStats stats;
  if (!out.toolpath) out.toolpath = std::make_shared<Toolpath>(tp);
  if (path.empty()) return stats;
  check_settings_used(job, &tp,
                      diag);  // now that the toolpath is known: mixtures, tools, process values
  if (is_3mf_output(path)) return write_3mf_print(path, std::move(tp), job, machine, out, diag);
  tp.job = embedded_job(job, path);
  stats = write_gcode_file(path, tp, machine, gcode_thumbnails(tp, machine));
  for (const auto& [kind, message] : stats.warnings) diag.warn(kind, message);
  out.files.push_back(path);
  return stats;
}

bool output_alone(const Job& job) {
  return !job.output.empty() && !job.keep_toolpath && job.toolpath.empty() && job.preview.empty();
}

GcodeStats write_gcode_streamed(const std::string& path, Toolpath meta, std::size_t layers,
                                const LayerSource& source, const Job& job,
                                const MachineProfile& machine, JobResult& out, Diagnostics& diag,
                                bool shared_source) {
  if (is_3mf_output(path)) {
    // The package is made in memory (its layer parts are deflated together), so the streamed
    // layers are gathered first.
    source([&](std::size_t, const Layer& layer) { meta.layers.push_back(layer); });
    return write_3mf_print(path, std::move(meta), job, machine, out, diag);
  }
  meta.job = embedded_job(job, path);
  const GcodeStats stats =
      shared_source ? write_gcode_stream(
                          path, meta, layers, source, machine,
                          GcodeThumbnailMaker([&] { return gcode_thumbnails(source, machine); }))
                    : write_gcode_stream(path, meta, layers, source, machine,
                                         gcode_thumbnails(source, machine));
  for (const auto& [kind, message] : stats.warnings) diag.warn(kind, message);
  out.files.push_back(path);
  return stats;
}

void require_bath(const Job& job, const MachineProfile& m, const std::string& route,
                  const std::string& why) {
  const RouteSpec& spec = route_spec(job.route);
  const std::string& out = job.*spec.main_output;
  if (out.empty() || fs::path(out).extension() == ".json" || is_3mf_output(out) || m.has_bath())
    return;
  throw MachineError(route + ": " + why + ", but the machine '" + m.name +
                         "' prints in air (machine.flavor = " + std::string(to_string(m.flavor)) +
                         "); use a bath profile (machine.flavor = embedded), e.g. " +
                         spec.bath_example + ", or write a toolpath (.json) instead of G-code",
                     {job.machine, 0, "machine.flavor"});
}

void note_planar_in_bath(const MachineProfile& m, const std::string& route, Diagnostics& diag) {
  if (!m.has_bath()) return;
  diag.warn("planar_in_bath", route + " prints flat layers but the machine '" + m.name +
                                  "' prints in a support bath (machine.flavor = embedded): "
                                  "travel lifts out of the bath between paths");
}

void write_toolpath_with_job(const std::string& path, Toolpath toolpath, const Job& job) {
  toolpath.job = embedded_job(job, path);
  write_toolpath(path, toolpath);
}

std::string preview_name(const std::string& dir, const std::string& file) {
  return (fs::path(dir) / file).string();
}

void previews(const Toolpath& tp, const std::string& dir, int count, const RenderOptions& ro,
              JobResult& out, const std::string& prefix) {
  const std::size_t n = tp.layers.size();
  if (dir.empty() || count <= 0 || n == 0) return;
  create_output_directories(dir);
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(count), n);
  for (std::size_t t = 0; t < k; ++t) {
    const std::size_t layer = k == 1 ? n / 2 : t * (n - 1) / (k - 1);
    out.files.push_back(preview_name(dir, fmt::format("{}{:04}.png", prefix, layer)));
    render_layer_png(tp, layer, out.files.back(), ro);
  }
}

std::string fixed(double v, int decimals) {
  return fmt::format("{:.{}f}", v, decimals);
}

// The facts of a run that Setting::when names (settings.hpp).
static UseContext use_context(const Job& job) {
  UseContext u;
  u.route = job.route;
  u.settings = &job.settings;
  const RouteSpec& spec = route_spec(job.route);
  const std::string& main = job.*spec.main_output;
  const std::string ext = fs::path(main).extension().string();
  using G = RouteSpec::Gcode;
  const bool gcode = spec.gcode == G::always || (spec.gcode == G::when_written && !main.empty()) ||
                     (spec.gcode == G::when_named_gcode && !main.empty() && ext != ".json" &&
                      ext != ".stl" && ext != ".obj");
  if (gcode) u.facts.push_back("gcode");
  if (!job.preview.empty()) u.facts.push_back("preview");
  if (!job.input.empty() || !job.parts.empty()) u.facts.push_back("input");
  if (!job.report.empty()) u.facts.push_back("report");
  if (ext == ".3mf") u.facts.push_back("3mf");
  std::string in = fs::path(job.input).extension().string();
  std::transform(in.begin(), in.end(), in.begin(),
                 [](unsigned char ch) { return std::tolower(ch); });
  if (in == ".stl" || in == ".obj" || in == ".3mf") u.facts.push_back("mesh");
  if (ext == ".bgcode" || fs::path(job.gcode).extension() == ".bgcode") u.facts.push_back("bgcode");
  if (!job.origin.empty()) u.facts.push_back("job");
  return u;
}

// Every setting the user gave (on the command line, in a job file or from Python; a machine
// profile describes the machine and may hold settings a route does not use) must change this
// run's output: one its route does not use here is refused with the reason (Setting::when). A
// job file's setting left idle by the command line (`--set plan.planner=euler` over a job's
// [gippo] table, `--set output.png=false` over its preview settings) is a warning instead: the
// job file is right as written.
void check_settings_used(const Job& job, const Toolpath* written, Diagnostics& diag) {
  if (job.embedded) return;  // an output's header records every setting, used or not
  UseContext before = use_context(job);
  before.unknown = {"graded", "tools", "process"};
  UseContext use = before;
  if (written) {
    use.unknown.clear();
    bool graded = false, process = false;
    std::set<int> tools;
    for (const auto& l : written->layers)
      for (const auto& p : l.paths) {
        graded |= !p.mixture.empty();
        process |= p.temperature > 0;
        tools.insert(p.tool);
      }
    if (graded) use.facts.push_back("graded");
    if (tools.size() > 1) use.facts.push_back("tools");
    if (process) use.facts.push_back("process");
  }
  const auto from_job_file = [&](const Settings::Entry& e) {
    return !job.origin.empty() && e.origin.source == job.origin;
  };
  const auto from_profile = [&](const Settings::Entry& e) {
    return !job.machine.empty() && e.origin.source == job.machine;
  };
  bool overridden = false;  // the command line (or Python) set something over the job file
  for (const auto& [key, e] : job.settings.entries())
    overridden |= !from_job_file(e) && !from_profile(e);
  for (const auto& [key, e] : job.settings.entries()) {
    if (from_profile(e)) continue;
    const Setting* s = find_setting(key);
    if (!s) continue;
    const std::string why = unused_reason(*s, use);
    if (why.empty()) continue;
    if (written && !unused_reason(*s, before).empty()) continue;  // said before the run
    if (from_job_file(e) && overridden) {
      diag.warn("setting_unused", fmt::format("{}:{}: {}: the {} route does not use it in this run "
                                              "(the command line changed what it depends on): {}",
                                              e.origin.source, e.origin.line, key, job.route, why));
      continue;
    }
    throw SettingError("the " + job.route + " route does not use it in this run: " + why,
                       {e.origin.source, e.origin.line, key});
  }
}

}  // namespace routes

std::vector<GcodeThumbnail> gcode_thumbnails(const Toolpath& toolpath,
                                             const MachineProfile& machine) {
  return gcode_thumbnails(layers_of(toolpath), machine);
}

std::vector<GcodeThumbnail> gcode_thumbnails(const LayerSource& layers,
                                             const MachineProfile& machine) {
  const std::vector<std::pair<int, int>> sizes = machine.thumbnail_sizes();
  std::vector<GcodeThumbnail> out;
  if (sizes.empty()) return out;
  std::vector<std::string> pngs = render_thumbnails_png(layers, sizes);
  for (std::size_t i = 0; i < sizes.size(); ++i)
    out.push_back({sizes[i].first, sizes[i].second, std::move(pngs[i])});
  return out;
}

double solid_section_z(const BBox3& box, int layer, double h) {
  return std::min(box.min.z + (layer + 0.5) * h, box.max.z - 1e-3 * h);
}

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

// How a G-code print is read back: with the valve commands of its machine (given, or of the job
// its header embeds); `snap` gets that machine's node overlap + kNodeSnap.
GcodeReadOptions print_read_options(std::string_view text, const std::string& path,
                                    const Settings* machine, double* snap,
                                    bool commanded_mixtures) {
  Settings embedded;
  if (!machine && text.find("\n; job: ") != std::string_view::npos) {
    embedded = job_from_output(path).settings;
    machine = &embedded;
  }
  GcodeReadOptions read;
  read.commanded_mixtures = commanded_mixtures;
  if (!machine) return read;
  const MachineProfile profile = machine->config().machine;
  if (!profile.marlin_family()) {
    read.valve_on = profile.valve_on;
    read.valve_off = profile.valve_off;
  }
  if (snap && *snap == kNodeSnap) *snap = profile.node_overlap + kNodeSnap;
  return read;
}

}  // namespace

Toolpath read_print(const std::string& path, const Settings* machine, double* snap,
                    Diagnostics& diag, bool commanded_mixtures) {
  const std::string ext = lower_extension(path);
  if (routes::is_3mf_output(path)) return read_toolpath_3mf_file(path, &diag);
  // The G-code names every route writes (check_output_names), else a toolpath JSON.
  if (ext != ".gcode" && ext != ".nc" && ext != ".g" && ext != ".gco" && ext != ".bgcode")
    return read_toolpath(path);
  std::string text = read_file(path);
  if (is_bgcode(text)) text = bgcode_to_text(text, path);  // the header lines are read below
  const GcodeReadOptions read = print_read_options(text, path, machine, snap, commanded_mixtures);
  Toolpath tp = read_gcode(text, read, diag, path);
  // Back to design coordinates: undo the placement written into the header and the tool offsets.
  to_design_coordinates(tp, text);
  return tp;
}

LayerSource print_layers(const std::string& path, const Settings* machine, double* snap,
                         Diagnostics& diag, bool commanded_mixtures) {
  const std::string ext = lower_extension(path);
  if (ext != ".gcode" && ext != ".nc" && ext != ".g" && ext != ".gco") return {};
  const std::string header = read_gcode_header(path);
  {
    std::ifstream in(path, std::ios::binary);
    char magic[4] = {};
    in.read(magic, 4);
    if (is_bgcode(std::string_view(magic, static_cast<std::size_t>(in.gcount())))) return {};
  }
  // Mixtures as deposited are settled over the whole toolpath (machine/mixing_lag.hpp).
  if (!commanded_mixtures && header.find("; mixture lookahead = ") != std::string::npos) return {};
  const GcodeReadOptions read = print_read_options(header, path, machine, snap, commanded_mixtures);
  const Vec3 shift = design_shift(header);
  auto visits = std::make_shared<int>(0);
  return [path, read, shift, visits, &diag](const LayerVisitor& visit) {
    Diagnostics again;  // a second reading warns of nothing new
    scan_gcode_layers(path, read, (*visits)++ == 0 ? diag : again,
                      [&](std::size_t k, const Layer& layer) {
                        if (shift.x == 0 && shift.y == 0 && shift.z == 0) return visit(k, layer);
                        Layer moved = layer;
                        to_design_coordinates(moved, shift);
                        visit(k, moved);
                      });
  };
}

namespace {

JobResult run_route(const Job& job, const Config& c, const RunContext& context) {
  return route_spec(job.route).run(job, c, context);
}

// A machine profile is for one kind of machine: a laser profile has [laser], [scan] or [timing];
// an extrusion profile (FDM, pneumatic, bath) has machine.flavor or the extrusion sections. A
// route given the other kind is refused (its keys would be ignored), naming the kind it needs.
void check_profile_kind(const Job& job, const std::vector<std::string>& sections) {
  if (job.machine.empty()) return;
  const Settings::Entry* laser = nullptr;
  const Settings::Entry* extrusion = nullptr;
  std::string laser_key, extrusion_key;
  const auto& deposition = machine_sections();
  for (const auto& [key, e] : job.settings.entries()) {
    if (e.origin.source != job.machine) continue;
    const std::string sec = key.substr(0, key.find('.'));
    if ((sec == "laser" || sec == "lasers" || sec == "scan" || sec == "timing") && !laser) {
      laser = &e;
      laser_key = key;
    } else if ((key == "machine.flavor" ||
                (sec != "machine" &&
                 std::find(deposition.begin(), deposition.end(), sec) != deposition.end())) &&
               !extrusion) {
      extrusion = &e;
      extrusion_key = key;
    }
  }
  const bool route_laser = std::find(sections.begin(), sections.end(), "laser") != sections.end();
  if (route_laser && extrusion && !laser)
    throw SettingError("the " + job.route +
                           " route makes laser paths and needs a laser profile "
                           "(with [laser] and [scan]); this is an extrusion profile",
                       {job.machine, extrusion->origin.line, extrusion_key});
  if (!route_laser && laser && !extrusion)
    throw SettingError(
        "the " + job.route +
            " route makes extrusion paths and needs an FDM, "
            "pneumatic or bath profile; this is a laser profile (a laser build is a .cli file: "
            "the pbf route, or Toolpath.cli in Python)",
        {job.machine, laser->origin.line, laser_key});
}

}  // namespace

namespace {

// `path`'s extension is one of `formats` (RouteSpec::formats), else SettingError naming `key` (the
// job key; the CLI flag of the same name) and what it may be called.
void require_format(const std::string& path, const std::vector<std::string>& formats,
                    const Config& c, const std::string& route, const std::string& what,
                    const std::string& key) {
  if (path.empty() || formats.empty() || is_stream_output(path)) return;
  const std::string ext = lower_extension(path);
  std::string own = c.machine.file_extension;
  for (char& ch : own) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (!own.empty() && own[0] != '.') own.insert(own.begin(), '.');
  std::vector<std::string> names;
  for (const std::string& f : formats) {
    if (f == "gcode") {
      std::vector<std::string> g = {".gcode", ".g", ".gco", ".nc", ".bgcode"};
      if (!own.empty() && std::find(g.begin(), g.end(), own) == g.end()) g.push_back(own);
      for (const std::string& e : g) {
        if (ext == e) return;
        names.push_back(e + (e == ".bgcode" ? " (binary G-code)" : " (G-code)"));
      }
      continue;
    }
    if (ext == f) return;
    names.push_back(f == ".json"  ? f + " (JSON)"
                    : f == ".3mf" ? f + " (3MF)"
                    : f == ".stl" ? f + " (binary STL)"
                    : f == ".obj" ? f + " (Wavefront OBJ)"
                    : f == ".cli" ? f + " (CLI build file)"
                                  : f);
  }
  std::string list;
  for (std::size_t i = 0; i < names.size(); ++i)
    list += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  throw SettingError(
      fmt::format("'{}' is named {}, but the {} route writes {} as {}: name it so", path,
                  ext.empty() ? "without an extension" : ext, route, what, list),
      {"", 0, key});
}

}  // namespace

void check_output_names(const Job& job, const Config& c) {
  const RouteSpec& spec = route_spec(job.route);
  const std::vector<std::string> formats = spec.formats_of ? spec.formats_of(c) : spec.formats;
  const bool plan = spec.main_output == &Job::gcode;
  require_format(job.*spec.main_output, formats, c, job.route, "its output",
                 plan ? "gcode" : "output");
  require_format(job.toolpath, {".json"}, c, job.route, "the toolpath", "toolpath");
  require_format(job.lattice, {".json", ".3mf"}, c, job.route, "the lattice", "lattice");
  require_format(job.report, {".json"}, c, job.route, "the report", "report");
}

RunFiles job_files(const Job& job, bool follow_symlinks) {
  RunFiles files(follow_symlinks);
  files.input("the job file", job.origin);  // (an embedded job's origin names no file)
  files.input("the input", job.input);
  files.input("the machine profile", job.machine);
  const std::vector<std::string> sections = route_sections(job.route);
  for (const auto& [key, e] : job.settings.entries()) {
    const Setting* s = find_setting(key);
    if (s && s->unit == "path" &&
        std::find(sections.begin(), sections.end(), s->section()) != sections.end())
      files.input("the file of " + key, std::get<std::string>(e.value));
  }
  for (const PlatePart& p : job.parts) files.input("the design of part " + p.label, p.input);
  files.output("the output", job.output);
  files.output("the report", job.report);
  files.output("the toolpath", job.toolpath);
  files.output("the G-code", job.gcode);
  files.output("the lattice", job.lattice);
  files.output_folder("the preview folder", job.preview);
  // A plan's shards are named after its G-code, the other routes' after their output.
  const std::string& sharded = job.*route_spec(job.route).main_output;
  if (job.shards > 0 && !sharded.empty()) {
    const std::string data = shard_name(sharded, job.shard, job.shards);
    files.output("the shard", data);
    files.output("the shard manifest", data + ".json");
  }
  return files;
}

JobResult run_job(const Job& job, Diagnostics& diag, const Progress& progress) {
  RunContext context;
  context.progress = progress;
  context.diagnostics = &diag;
  return run_job(job, context);
}

JobResult run_job(const Job& job, const RunContext& given) {
  // A reader runs as its command does (readers.cpp).
  const RouteSpec& spec = route_spec(job.route);
  if (spec.reads) return routes::run_reader(spec, job, given);
  const std::vector<std::string>& sections = spec.sections;
  const Config c = job.settings.config();
  // The route's context: the caller's progress and diagnostics, the run section's threads and
  // budget.
  Diagnostics dropped;  // a context without diagnostics drops the warnings
  RunContext context = routes::run_context(job.settings, c, given);
  if (!context.diagnostics) context.diagnostics = &dropped;
  Diagnostics& diag = *context.diagnostics;
  check_rules(c, job.settings, sections);
  check_profile_kind(job, sections);
  routes::check_settings_used(job, nullptr, diag);
  // Every output of the job is staged and committed together at the end; an error, a cancel or
  // running out of memory leaves the output folders as they were (core/file.hpp). Its files are
  // checked before anything is written, and its inputs are never written (core/run_files.hpp).
  OutputBatch batch;
  job_files(job, c.follow_symlinks).check();
  check_output_names(job, c);
  // Binary G-code for a machine without Prusa's firmware: refused before any work.
  for (const std::string* g : {&job.output, &job.gcode}) {
    const std::string ext = fs::path(*g).extension().string();
    const bool gcode = ext == ".bgcode" || ext == ".gcode" || ext == ".g" || ext == ".gco";
    if (gcode && std::find(sections.begin(), sections.end(), "gcode") != sections.end())
      binary_gcode_output(*g, c.machine);
  }
  // The context's threads (run.threads) bound every parallel loop of the run, the entry points'
  // arenas and the writers' loops alike (0 = all cores).
  std::unique_ptr<tbb::global_control> threads;
  if (context.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(context.threads));
  for (const std::string* out :
       {&job.output, &job.report, &job.toolpath, &job.gcode, &job.lattice}) {
    if (out->empty()) continue;
    const fs::path dir = fs::path(*out).parent_path();
    if (!dir.empty()) create_output_directories(dir.string());
  }
  // The previews, before the work they would follow: at most output.preview_layers layer
  // images, the 3-D picture and plots, and AERO's step frames.
  if (!job.preview.empty() && c.output.preview_layers + c.output.frames > 0) {
    Estimate e = layer_images_estimate(c.output.preview_layers + c.output.frames + 2.0,
                                       c.output.image_size, 0);
    e.change = "output.image_size or output.preview_layers";
    context.check_budget(e);
  }
  JobResult result = [&] {
    try {
      return run_route(job, c, context);
    } catch (const std::bad_alloc&) {
      throw ResourceError(
          "ran out of memory (the estimate before the run was too low): lower the resolution "
          "or the size of the job, or raise the memory available (run.max_memory)",
          {"", 0, "run.max_memory"});
    }
  }();
  batch.commit();
  return result;
}

}  // namespace trellis
