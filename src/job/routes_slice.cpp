// Slicing routes: planar and graded slicing, laser powder-bed TPMS sheets, non-planar layers on
// a surface and the non-planar paper's test surfaces.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/resource.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "process_json.hpp"
#include "routes.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/implicit_3mf.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/job/plate.hpp"
#include "trellis/job/reports.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/slice/nonplanar.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/pipeline.hpp"
#include "trellis/slice/slice.hpp"
#include "trellis/toolpath/layer_spill.hpp"

namespace trellis::routes {

namespace fs = std::filesystem;

void warn_min_feature(const std::string& input, double feature, const char* width_name,
                      double width, double step, const char* step_key, const RunContext& context) {
  if (!(feature > 0) || (feature >= width && feature >= step)) return;
  context.warn(
      "design_min_feature",
      fmt::format("{} asks for features down to {} mm (minfeaturesize); the {} is {} mm "
                  "and the design is sampled every {} mm ({}), so finer features are not "
                  "printed as designed",
                  fs::path(input).filename().string(), feature, width_name, width, step, step_key));
}

void laser_previews(const Toolpath& tp, const Job& job, const Config& c, JobResult& out) {
  RenderOptions ro;
  ro.colour_by_role = true;
  ro.colour_by_tool = c.laser.lasers > 1;  // which laser scans each vector
  ro.tools_are_lasers = true;
  ro.travel = false;
  ro.starts = false;
  ro.bead_width = c.laser.melt_pool_width;
  ro.margin_mm = 0.2;
  ro.size_px = c.output.image_size;
  previews(tp, job.preview, c.output.preview_layers, ro, out);
}

LaserSetup lasers_of(const Config& c) {
  const std::vector<LaserParameters> each = laser_parameters(c.laser);
  // Lasers that differ only when the profile says so: else every laser is the profile's.
  LaserSetup s =
      lasers_differ(c.laser)
          ? laser_setup(c.laser.fields, c.pbf.laser_overlap, profile_laser(c.laser), each)
          : laser_setup(c.laser.lasers, c.laser.fields, c.pbf.laser_overlap, scan_timing(c.laser));
  s.axis = c.pbf.laser_split_axis;
  return s;
}

bool splits_layers(const Config& c) {
  return c.laser.lasers > 1 || !c.laser.fields.empty();
}

void add_laser_report(nlohmann::ordered_json& j, const LaserTimes& t, const Config& c) {
  if (c.laser.lasers <= 1) return;
  const std::vector<double> totals = t.totals();
  double all = 0;
  for (double s : totals) all += s;
  nlohmann::ordered_json per = nlohmann::ordered_json::array(),
                         build = nlohmann::ordered_json::array();
  for (const auto& l : t.per_layer) {
    per.push_back(l);
    build.push_back(l.empty() ? 0.0 : *std::max_element(l.begin(), l.end()));
  }
  j["lasers"] = {{"count", c.laser.lasers},
                 {"overlap_mm", c.pbf.laser_overlap},
                 {"split_axis", to_string(c.pbf.laser_split_axis)},
                 {"layers_split_along_y", t.along_y},
                 {"scan_time_s", totals},
                 {"build_time_s", t.build_seconds()},
                 {"all_lasers_time_s", all},
                 {"cut_vectors", t.cut},
                 {"per_layer", {{"build_time_s", build}, {"scan_time_s", per}}}};
}

std::string laser_summary(const LaserTimes& t) {
  const std::vector<double> totals = t.totals();
  if (totals.size() <= 1) return "";
  std::string each;
  double all = 0;
  for (double s : totals) each += (each.empty() ? "" : " + ") + fixed(s, 1), all += s;
  return fmt::format(
      "; {} lasers scan {} s, build time {} s (max per layer, summed; {} s of "
      "scanning in all), {} vectors cut at stripe boundaries",
      totals.size(), each, fixed(t.build_seconds(), 1), fixed(all, 1), t.cut);
}

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
Field tpms_spec(const std::string& spec, double* weight, const char* key) {
  const auto a = spec.find(':');
  if (a == std::string::npos)
    throw SettingError("expected TYPE:CELL, got '" + spec + "'", {"", 0, key});
  const auto b = spec.find(':', a + 1);
  double cell = 0;
  try {
    cell = std::stod(spec.substr(a + 1, b == std::string::npos ? std::string::npos : b - a - 1));
    if (weight && b != std::string::npos) *weight = std::stod(spec.substr(b + 1));
  } catch (const std::exception&) {
    throw SettingError("bad number in '" + spec + "'", {"", 0, key});
  }
  if (!(cell > 0)) throw SettingError("cell size must be > 0 in '" + spec + "'", {"", 0, key});
  return tpms(tpms_kind(spec.substr(0, a)), {cell, cell, cell});
}

// A shard's ending (`--shard K/N`): its layers and manifest written, the data file listed first
// (the manifest's name without ".json"), and a summary of what it holds.
JobResult shard_written(const Job& job, const Toolpath& tp, std::size_t first, std::size_t end,
                        std::size_t total, const std::string& holds, JobResult out,
                        const std::string& graded_json = {}) {
  out.files.push_back(
      write_shard(job, tp.layers, first, total, tp.source, tp.part_labels, graded_json));
  out.files.insert(out.files.begin(), out.files.back().substr(0, out.files.back().size() - 5));
  out.summary = fmt::format("shard {} of {}: layers {}..{} of {}, {}", job.shard, job.shards, first,
                            end, total, holds);
  return out;
}

// A laser design (.vcad): process fields (fprocess) are FDM settings the laser route has no use
// for, refused rather than dropped.
Field laser_vcad(const std::string& path, const char* key = "job.input",
                 double* min_feature = nullptr) {
  // A mesh is not read as .vcad text ("unexpected character '\x00'"): the lattice's envelope and
  // solids are fields; a mesh part is scanned on its own (pbf_solid).
  if (is_mesh_path(path) && !is_implicit_3mf(path))
    throw SettingError(
        "the TPMS lattice's envelope and solids are .vcad designs (fields); a mesh "
        "part is scanned as a solid by giving it as the input (`trellis pbf "
        "part.stl`), or describe the envelope in .vcad",
        {path, 0, key});
  VcadDesign design = read_field_design(path);
  if (min_feature) *min_feature = design.min_feature_size;
  Field f = std::move(design.field);
  if (f.has_process())
    throw SettingError(
        "the design sets process fields (fprocess: temperature, speed, flow, fan), "
        "which only the FDM slice route writes; remove the fprocess node for laser "
        "powder-bed fusion (scan parameters come from the laser profile)",
        {path, 0, "fprocess"});
  return f;
}

PbfDesign pbf_design(const PbfConfig& p) {
  if (p.wall_thickness > 0) {
    // The paper's thin-wall experiments (Fig. 3): a plane wall cut by the box.
    const Vec3 s = p.size.size() == 3 ? Vec3{p.size[0], p.size[1], p.size[2]} : Vec3{2, 2, 20};
    return plane_wall(p.wall_thickness, p.wall_inclination, p.wall_azimuth, s);
  }
  PbfDesign d;
  d.phi = tpms(p.cell_type, {p.cell, p.cell, p.cell});
  if (!p.grade_to.empty()) {
    const Field other = tpms_spec(p.grade_to, nullptr, "pbf.grade_to");
    const std::string s = p.grade_axis == GradeAxis::Z ? "z" : "rho";
    d.phi = blend(d.phi, other,
                  {fmt::format("1/(1+exp(-({}-({}))/({})))", s, p.grade_center, p.grade_width)});
  }
  if (!p.hierarchical.empty()) {
    double w = 0.3;
    const Field fine = tpms_spec(p.hierarchical, &w, "pbf.hierarchical");
    d.phi = blend(d.phi, fine, {fmt::format("{}", w)});
  }
  d.c = {p.c};
  d.thickness = p.thickness;
  if (!p.envelope.empty()) {
    d.envelope = laser_vcad(p.envelope, "pbf.envelope");
  } else {
    const double side = 4 * p.cell;
    const Vec3 s =
        p.size.size() == 3 ? Vec3{p.size[0], p.size[1], p.size[2]} : Vec3{side, side, side};
    d.envelope = rectprism(s);
  }
  if (!p.solids.empty()) d.solids = laser_vcad(p.solids, "pbf.solids");
  return d;
}

// The .vcad given to `trellis pbf` (or a plate part): a design that is itself one TPMS sheet
// (cut by a root box or intersected with solids) is planned as it is — its φ, c and boxes — and
// the lattice settings that would have filled it are named as ignored; any other design is the
// envelope the configured lattice fills, with a warning when it holds a TPMS of its own (the
// part is then the intersection of two lattices).
void warn_lattice_envelope(const Field& f, const std::string& path, const PbfConfig& p,
                           Diagnostics& diag) {
  if (has_tpms(f))
    diag.warn("pbf.envelope_lattice",
              fmt::format("{} holds a TPMS that is not one sheet cut by boxes or intersections, so "
                          "it is the envelope the configured lattice ({} cells of {} mm) fills: "
                          "the part is the intersection of the two",
                          path, to_string(p.cell_type), p.cell));
}

bool pbf_input(PbfDesign& d, const std::string& path, const Config& c, const Settings& set,
               const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  const PbfConfig& p = c.pbf;
  double feature = 0;
  const Field f = laser_vcad(path, "job.input", &feature);
  warn_min_feature(path, feature, "laser's melt pool (laser.melt_pool_width)",
                   c.laser.melt_pool_width, p.options.resolution, "pbf.resolution", context);
  if (p.wall_thickness <= 0) {
    if (auto s = split_sheet(f)) {
      d.phi = s->phi;
      d.c = s->c;
      d.thickness = s->thickness;
      d.envelope = s->envelope;
      d.clip = s->boxes;
      // The sheet's own cell against the sampling grid, as check_pbf_cells does for pbf.cell (a
      // 0.001 mm cell traced 330,000 aliasing contour vectors).
      const Vec3 per = d.phi.period();
      const double cell = std::min({per.x > 0 ? per.x : HUGE_VAL, per.y > 0 ? per.y : HUGE_VAL,
                                    per.z > 0 ? per.z : HUGE_VAL});
      if (cell < 8 * p.options.resolution)
        throw SettingError(fmt::format("its TPMS cell of {} mm is not resolved by the {} mm "
                                       "sampling grid (2 × pbf.resolution); cells need at least 8 "
                                       "× pbf.resolution = {} mm: raise the cell or lower "
                                       "pbf.resolution",
                                       cell, 2 * p.options.resolution, 8 * p.options.resolution),
                           {path, 0, "pbf.resolution"});
      std::vector<std::string> ignored;
      for (const char* k : {"pbf.cell_type", "pbf.cell", "pbf.c", "pbf.thickness", "pbf.size",
                            "pbf.envelope", "pbf.grade_to", "pbf.hierarchical"})
        if (set.has(k)) ignored.push_back(k);
      if (!ignored.empty())
        diag.warn("pbf.design_lattice",
                  fmt::format("{} is itself a TPMS sheet: its own lattice is planned and {} "
                              "ignored (give a solid .vcad to fill it with the configured lattice)",
                              path, fmt::join(ignored, ", ")));
      return true;
    }
  }
  warn_lattice_envelope(f, path, p, diag);
  d.envelope = f;
  return false;
}

// The part's design from its settings and its input .vcad (if any); *from_design: the lattice
// is the input's own sheet.
PbfDesign pbf_part_design(const Config& c, const std::string& input, const Settings& set,
                          const RunContext& context, bool* from_design = nullptr) {
  Diagnostics& diag = *context.diagnostics;
  const PbfConfig& p = c.pbf;
  PbfDesign d = pbf_design(p);
  if (!p.envelope.empty() && p.wall_thickness <= 0)
    warn_lattice_envelope(d.envelope, p.envelope, p, diag);
  const bool own = !input.empty() && pbf_input(d, input, c, set, context);
  if (from_design) *from_design = own;
  return d;
}

// Per-layer columns of the report (z, FR_a of the path and of R67, lengths, area, scan times).
nlohmann::ordered_json pbf_layer_series(const PbfResult& r) {
  nlohmann::ordered_json s;
  for (const char* k :
       {"z_mm", "fr_a", "fr_a_r67", "contour_mm", "hatch_mm", "r67_hatch_mm", "area_mm2",
        "scan_time_s", "scan_time_r67_s", "hatch_angle_deg", "fr_a_eq", "fr_a_eq_r67"})
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
    s["hatch_angle_deg"].push_back(L.hatch_angle);
    s["fr_a_eq"].push_back(L.fr_eq);
    s["fr_a_eq_r67"].push_back(L.fr_eq_r67);
  }
  return s;
}

// FR_a over layers (paper Fig. 3(b)): this path and the R67 baseline.
void render_fr_plot(const PbfResult& r, bool r67, const std::string& path) {
  std::vector<double> x;
  PlotSeries fh{r67 ? "R67" : "hybrid", {}, 0.85, 0.1, 0.1}, fb{"R67 baseline", {}, 0.1, 0.3, 0.8};
  for (std::size_t i = 0; i < r.layers.size(); ++i) {
    x.push_back(static_cast<double>(i + 1));
    const bool any = r.layers[i].area > 0;
    fh.values.push_back(any ? r.layers[i].fr : NAN);
    fb.values.push_back(any ? r.layers[i].fr_r67 : NAN);
  }
  render_series_png(x, {fh, fb}, "filling ratio FR_a = D·ΣL/A per layer", "layer", path);
}

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

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
      throw SettingError("bad entry '" + item +
                             "' (expected LAYERS:TOOL groups like 3:0,3:1,3:0 or tools like 0,1)",
                         {"", 0, "nonplanar.layer_tools"});
    }
    start = comma + 1;
  }
  return out;
}

HeightField test_surface(const SurfaceConfig& s) {
  if (s.kind == SurfaceKind::Corrugation) return corrugation(s.corrugation);
  if (s.kind == SurfaceKind::Miura) {
    MiuraParams m = s.miura;
    m.length = s.corrugation.length, m.width = s.corrugation.width;
    return miura(m);
  }
  if (s.kind == SurfaceKind::MCurve) {
    MCurveParams m = s.m_curve;
    m.fillet_diameter = s.corrugation.fillet_diameter;
    return m_curve(m);
  }
  return sphere_cap(s.radius, s.diameter);
}

}  // namespace

namespace {

// The slicing job of a configuration (the machine's layer, bead, purge and bed over [slice]).
SliceJob slice_job_of(const Job& job, const Config& c, const std::string& input) {
  SliceJob sj = c.slice;
  sj.input = input;
  sj.strategy_chosen = job.settings.has("slice.strategy");
  sj.planar.layer_height = c.machine.layer_height;
  if (!job.settings.has("slice.bead_width")) sj.planar.bead_width = c.machine.nozzle_diameter;
  sj.fgm.angle_deg = sj.planar.infill_angle;
  sj.purge.melt_volume = c.machine.melt_volume;
  sj.purge.threshold = c.machine.purge_threshold;
  sj.purge.x = c.machine.purge_x;
  sj.purge.y = c.machine.purge_y;
  sj.purge.side = c.machine.purge_side;
  sj.purge.automatic = c.machine.purge_position == PurgePosition::Auto;
  sj.purge.clearance = c.machine.purge_clearance;
  {
    // The bed as the writer will place the toolpath on it.
    const MachineProfile& placed = c.machine;
    sj.purge.bed_x = placed.bed_x;
    sj.purge.bed_y = placed.bed_y;
    sj.purge.centred = placed.center;
    sj.purge.circular = placed.bed_shape == BedShape::Circle;
    sj.purge.origin_centre = placed.origin == BedOrigin::Center;
    sj.purge.offset_x = placed.offset_x;
    sj.purge.offset_y = placed.offset_y;
  }
  if (c.machine.gradient_mode == GradientMode::Tools)
    sj.tools = std::max(1, c.machine.gradient_tool_count());
  else if (!job.output.empty())
    sj.lookahead = c.machine.lookahead;  // the writer's look-ahead
  sj.quantize = c.machine.quantize;
  sj.purge.speed = c.machine.print_speed;
  sj.purge.density = {c.machine.density_a, c.machine.density_b, c.machine.density_c};
  sj.process.max_temperature = c.machine.max_nozzle_temperature;
  sj.process.max_speed = c.machine.max_speed;
  sj.process.temperature_from_mixture = c.machine.gradient_mode == GradientMode::Temperature;
  sj.process.short_path_segments = c.machine.short_path_segments;
  sj.process.short_path_factor = c.machine.short_path_factor;
  return sj;
}

// A single part's design as a 3MF output's build item (a plate's: slice_plate_geometry): the mesh
// as read, a field meshed at the step its route samples it.
// `bottom`: the design's z its first layer starts at (SliceResult::bottom), dropped to the bed.
void slice_geometry(const Job& job, const SliceJob& sj, double bottom, const Budget& budget,
                    JobResult& out) {
  if (!job.parts.empty() || job.input.empty() || out.geometry.mesh) return;
  out.geometry.mesh = design_mesh_3mf(
      job.input, sj.route == SliceRoute::Mesh ? sj.mesh_voxel : sj.field.resolution, budget);
  out.geometry.transform = kIdentity3mf;
  out.geometry.transform[11] = -bottom;
}

// slice_geometry for a run that has not sliced the part (a merge, a toolpath read back): its
// first printed layer found as a shard finds it.
void slice_geometry(const Job& job, const SliceJob& sj, const Budget& budget, JobResult& out) {
  SliceJob probe = sj;
  probe.layer_begin = probe.layer_end = 0;
  probe.range_of = nullptr;
  slice_geometry(job, sj, run_slice(probe).bottom, budget, out);
}

void warn_palette(const std::string& input, int used, int total, Diagnostics& diag) {
  if (used < total)
    diag.warn("palette_partly_used",
              fmt::format("{}: only {} of the {} palette colours are printed: the design's "
                          "fractions span part of 0..1 (each band stays 1/{} wide; the paper's "
                          "palettes span the whole range)",
                          input, used, total, total));
}

// The printed mixtures are further from the design than the palette's bound allows (the tools
// of a tool changer, zippering, or the design sampled at path points between faces): said
// beyond 1 % of the bound.
void warn_error_bound(const std::string& input, const FgmStats& st, Diagnostics& diag) {
  if (st.error_bound > 0 && st.error_max > st.error_bound * 1.01 + 1e-9)
    diag.warn("gradient_bound_exceeded",
              fmt::format("{}: the printed mixture is up to {} from the design's, beyond the "
                          "bound {} the palette promises (length-weighted mean {}{}); use more "
                          "colours (or tools), or a smaller zipper{}",
                          input, fixed(st.error_max, 4), fixed(st.error_bound, 4),
                          fixed(st.error_mean, 4),
                          st.error_lookahead > 0
                              ? fmt::format(", as deposited with the mixing look-ahead of {} mm",
                                            fixed(st.error_lookahead, 0))
                              : "",
                          st.error_lookahead > 0
                              ? "; where the look-ahead runs past the start of the print, a "
                                "larger part or a smaller gradient.lookahead"
                              : ""));
}

// (A shard: its layers' short pieces.)
void warn_short_segments(const std::string& input, const FgmStats& st, Diagnostics& diag) {
  if (st.short_kept > 0)
    diag.warn(
        "short_segments_kept",
        fmt::format("{}: {} pieces under fgm.min_segment = {} mm are printed ({} merged into a "
                    "neighbour; {} of them beads of their own, the others runs of one "
                    "mixture inside a longer bead): {} merges refused because merging "
                    "would exceed the gradient bound {} = {}, the other short pieces touch "
                    "no piece of another colour end to end; use more colours or a smaller "
                    "fgm.min_segment",
                    input, st.short_kept, fixed(st.min_segment, 2), st.short_merged, st.short_beads,
                    st.short_kept_bound, st.materials == 3 ? "2α/3" : "α/2",
                    fixed(st.error_bound, 4)));
}

void warn_process(const ProcessStats& stats, const ProcessOptions& options, Diagnostics& diag) {
  for (const auto& [kind, message] : process_warnings(stats, options)) diag.warn(kind, message);
}

// A part of a plate sliced: its job, extent and printed layers.
struct SlicePart {
  SliceJob sj;
  BBox3 extent;
  double bottom = 0;  // the design's z on the bed (SliceResult::bottom)
  std::size_t layers = 0;
  ProcessStats process;  // what its process fields wrote (the plate report's per-part object)
};

// What the design read needs said: a mesh repaired; features finer than its minfeaturesize asks
// (a 3MF level set, Volumetric & Implicit Part I §4.1.1: a consumer that cannot resolve them
// "SHOULD raise a warning") lost under the bead width or the route's sampling step.
void warn_design(const SliceJob& sj, const SliceResult& r, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  const std::string name = fs::path(sj.input).filename().string();
  if (r.repaired)
    diag.warn("mesh_repaired",
              name + " was not closed and manifold; repaired: " + r.repair.summary());
  const bool field = r.route == SliceRoute::Field;
  warn_min_feature(sj.input, r.design_min_feature, "bead width", sj.planar.bead_width,
                   field ? sj.field.resolution : sj.mesh_voxel,
                   field ? "slice.resolution" : "slice.mesh_voxel", context);
}

// Each part's slicing job, extent and printed layers (its ends found plane by plane), for the
// plate check and the shards' ranges before any layer is sliced, and for a 3MF's build items.
std::vector<SlicePart> slice_parts_of(const Job& job, const Config& c,
                                      const std::vector<PlatePart>& placed,
                                      const RunContext& context = {}) {
  const bool plate = !job.parts.empty();
  const double h = c.machine.layer_height;
  std::vector<SlicePart> parts;
  for (const PlatePart& pp : placed) {
    Settings st = job.settings;
    if (!pp.settings_toml.empty())
      st.load_toml(pp.settings_toml, job.origin + " part '" + pp.label + "'");
    const Config pc = st.config();
    const std::string input = plate ? pp.input : job.input;
    const Where where{job.origin, pp.line, plate ? "part.input" : "job.input"};
    if (input.empty()) throw SettingError("slice needs a design (.vcad) or mesh to read", where);
    if (pc.machine.layer_height != h)
      throw SettingError("part '" + pp.label +
                             "' sets its own layer height: every part of a "
                             "plate prints in the plate's layers (extrusion.layer_height)",
                         {job.origin, pp.line, "extrusion.layer_height"});
    SlicePart p;
    p.sj = slice_job_of(job, pc, input);
    if (p.sj.strategy != 0 && plate)
      throw SettingError(
          "graded slicing (slice.strategy 1 or 2) does not go on plates: its "
          "purge tower and look-ahead would cross parts (one graded part shards: "
          "docs/plates.md)",
          {job.origin, pp.line, "slice.strategy"});
    SliceJob probe = p.sj;
    probe.layer_begin = probe.layer_end = 0;
    const SliceResult r = run_slice(probe, context);
    p.extent = r.extent;
    p.bottom = r.bottom;
    p.layers = r.part_layers;
    parts.push_back(std::move(p));
  }
  return parts;
}

// A plate's parts as a 3MF's build items: each part's design (design_mesh_3mf, at the step its
// route samples it) placed as its paths are, its bottom on the bed; parts of one design sampled
// alike share a mesh.
void slice_plate_geometry(const Job& job, const std::vector<SlicePart>& parts, const Budget& budget,
                          JobResult& out) {
  std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes;
  for (std::size_t k = 0; k < parts.size() && k < job.parts.size(); ++k) {
    const PlatePart& pp = job.parts[k];
    const SliceJob& sj = parts[k].sj;
    const double voxel = sj.route == SliceRoute::Mesh ? sj.mesh_voxel : sj.field.resolution;
    std::shared_ptr<const TriangleMesh>& mesh = meshes[fmt::format("{}\n{}", pp.input, voxel)];
    if (!mesh) mesh = design_mesh_3mf(pp.input, voxel, budget);
    out.geometry.parts.push_back({mesh, place_transform(pp, parts[k].extent, -parts[k].bottom),
                                  fs::path(pp.input).filename().string()});
  }
}

// The plate's report (trellis.plate_report) and summary of the slice route.
void plate_report(const Job& job, const std::vector<PlatePart>& placed,
                  const std::vector<SlicePart>& parts, std::size_t total, std::size_t paths,
                  const GcodeStats& g, Diagnostics& diag, JobResult& out) {
  if (!job.report.empty()) {
    nlohmann::ordered_json j;
    j["format"] = "trellis.plate_report";
    j["version"] = 1;
    j["route"] = "slice";
    j["layers"] = total;
    j["paths"] = paths;
    j["print_time_s"] = g.print_time_s;
    j["parts"] = nlohmann::ordered_json::array();
    bool process = false;
    for (std::size_t k = 0; k < placed.size(); ++k) {
      j["parts"].push_back({{"label", placed[k].label},
                            {"input", fs::path(placed[k].input).filename().string()},
                            {"x_mm", placed[k].x},
                            {"y_mm", placed[k].y},
                            {"rotation_deg", placed[k].rotation},
                            {"layers", parts[k].layers},
                            {"print_time_s", k < g.part_time_s.size() ? g.part_time_s[k] : 0.0}});
      // A part's process fields: what was written against its field (the commands are the
      // plate's, below: one nozzle prints every part).
      if (parts[k].process.active) {
        j["parts"].back()["process"] = process_json(parts[k].process, parts[k].sj.process);
        process = true;
      }
    }
    if (process)
      j["process"] = {{"temperature_commands", g.temperature_changes},
                      {"settle_time_s", g.settle_time_s},
                      {"fan_commands", g.fan_changes}};
    write_file_atomic(job.report, with_job(j.dump(2) + "\n", job, job.report, true, &diag));
    out.files.push_back(job.report);
  }
}

std::string plate_summary(std::size_t parts, bool sequential, std::size_t layers, double h,
                          std::size_t paths, const GcodeStats& g) {
  return fmt::format("plate of {} parts{}: {} layers of {} mm, {} paths, ~{} min", parts,
                     sequential ? " printed one after another" : "", layers, fixed(h, 3), paths,
                     fixed(g.print_time_s / 60, 1));
}

// A plate's layers (each holding layer i of every part, paths tagged with their part) reordered
// to print part by part: part 1's layers, then part 2's, … (plate.sequence = parts).
std::vector<Layer> part_by_part(std::vector<Layer> plate_layers,
                                const std::vector<SlicePart>& parts, double h) {
  std::vector<Layer> out;
  for (std::size_t k = 0; k < parts.size(); ++k)
    for (std::size_t i = 0; i < parts[k].layers && i < plate_layers.size(); ++i) {
      Layer layer;
      layer.z = static_cast<double>(i + 1) * h;
      for (Path& path : plate_layers[i].paths)
        if (path.part == static_cast<int>(k + 1)) layer.paths.push_back(std::move(path));
      out.push_back(std::move(layer));
    }
  return out;
}

// A plate (or one part) whose G-code alone is asked for, in bounded memory: each part's layers
// streamed (slice/pipeline.hpp) into a temporary file of its own, placed; plate layer i then read
// as layer i of every part that tall, in the job's order, for each pass of the writer.
JobResult slice_plate_streamed(const Job& job, const Config& c, std::vector<SlicePart>& parts,
                               const std::vector<PlatePart>& placed, std::size_t total,
                               bool sequential, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult out;
  const bool plate = !job.parts.empty();
  const double h = c.machine.layer_height;
  if (plate && is_3mf_output(job.output)) slice_plate_geometry(job, parts, context.budget, out);
  std::vector<std::unique_ptr<LayerSpill>> spills;
  Toolpath meta;
  std::size_t paths = 0;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    SlicePart& p = parts[k];
    if (plate) meta.part_labels.push_back(placed[k].label);
    spills.push_back(std::make_unique<LayerSpill>());
    LayerSpill& spill = *spills.back();
    const SliceResult r = stream_slice(
        p.sj,
        [&](std::size_t, Layer&& layer) {
          for (Path& path : layer.paths) {
            if (plate) {
              for (Vec3& q : path.points) q = place_point(placed[k], p.extent, q);
              path.part = static_cast<int>(k + 1);
            }
            ++paths;
          }
          spill.append(layer);
        },
        {}, context);
    warn_process(r.process, p.sj.process, diag);
    p.process = r.process;
    warn_design(p.sj, r, context);
    if (!plate)
      meta.source = "trellis slice " + fs::path(p.sj.input).filename().string() + " (" +
                    to_string(r.route) + " route)";
  }
  if (plate) meta.source = fmt::format("trellis slice plate ({} parts)", parts.size());
  // Part by part: each part's layers in turn.
  const LayerSource one_by_one = [&](const LayerVisitor& visit) {
    std::size_t i = 0;
    for (auto& s : spills) s->visit([&](std::size_t, const Layer& layer) { visit(i++, layer); });
  };
  if (sequential) {
    total = 0;
    for (auto& s : spills) total += s->layers();
  }
  const LayerSource layers = sequential ? one_by_one : [&](const LayerVisitor& visit) {
    for (auto& s : spills) s->rewind();
    Layer layer, piece;
    for (std::size_t i = 0; i < total; ++i) {
      layer.z = static_cast<double>(i + 1) * h;
      layer.paths.clear();
      for (auto& s : spills)
        if (i < s->layers() && s->next(piece))
          for (Path& path : piece.paths) layer.paths.push_back(std::move(path));
      visit(i, layer);
    }
  };
  note_planar_in_bath(c.machine, "slice", diag);
  MachineProfile m = c.machine;
  if (plate) m.center = false;  // a plate is placed already: its parts' x, y are bed coordinates
  const GcodeStats g = write_gcode_streamed(job.output, meta, total, layers, job, m, out, diag);
  plate_report(job, placed, parts, total, paths, g, diag, out);
  out.summary = plate_summary(placed.size(), sequential, total, h, paths, g);
  return out;
}

// A shard of one part (planar or graded slicing): the design opened once, its printed layers
// found plane by plane, the shard's range of them (balanced by work as a plate's) sliced with
// the layers its skins read and planned; a graded part's layers before the whole-print step
// (slice/pipeline.hpp finish_graded, the merge's), the manifest saying so.
JobResult slice_part_shard(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult out;
  if (job.input.empty())
    throw SettingError("slice needs a design (.vcad) or mesh to read",
                       {job.origin, 0, "job.input"});
  const double h = c.machine.layer_height;
  SliceJob sj = slice_job_of(job, c, job.input);
  std::size_t a = 0, b = 0, total = 0;
  sj.range_of = [&](const BBox3& e, std::size_t layers) {
    // As a plate's: layer i's work is the part's XY area.
    total = layers;
    const std::vector<double> work(layers, 0.0 + (e.max.x - e.min.x) * (e.max.y - e.min.y));
    std::tie(a, b) = shard_range(work, job.shard, job.shards);
    return std::pair<std::size_t, std::size_t>{a, b};
  };
  SliceResult r = run_slice(sj, context);
  warn_process(r.process, sj.process, diag);
  warn_design(sj, r, context);
  const bool graded = sj.strategy != 0;
  if (graded) warn_short_segments(sj.input, r.fgm, diag);
  Toolpath tp;
  tp.source = "trellis slice " + fs::path(sj.input).filename().string() + " (" +
              to_string(r.route) + " route)";
  tp.layers.resize(b - a);
  for (std::size_t i = a; i < b; ++i) tp.layers[i - a].z = static_cast<double>(i + 1) * h;
  std::size_t paths = 0;
  for (Layer& layer : r.toolpath.layers) {
    // The part's layer from its z (graded slicing leaves out layers without paths).
    const auto i = static_cast<std::size_t>(std::llround(layer.z / h)) - 1;
    if (i < a || i >= b) continue;
    paths += layer.paths.size();
    for (Path& path : layer.paths) tp.layers[i - a].paths.push_back(std::move(path));
  }
  std::string graded_json;
  if (graded) {
    // The same in every shard of the job: the strategy, the design's materials, whether its
    // process fields need the merge's pass; and this shard's outline planes (that pass samples
    // the design at them).
    nlohmann::ordered_json gj{
        {"strategy", sj.strategy}, {"materials", r.fgm.materials}, {"process", r.process_fields}};
    if (r.process_fields) {
      std::vector<double> zs;
      for (std::size_t i = a; i < b; ++i) zs.push_back(r.outlines.at(i - r.outline_first).z);
      gj["outline_z"] = zs;
    }
    graded_json = gj.dump();
  }
  return shard_written(job, tp, a, b, total, fmt::format("{} paths", paths), std::move(out),
                       graded_json);
}

// A build plate of sliced parts, or a shard of one (job/plate.hpp): each part sliced with its own
// settings, placed (its x, y are bed coordinates) and dropped on the bed; plate layer i holds
// layer i of every part that tall, parts in the order of the job file. A shard slices the parts
// whole (skins look at the layers above and below) and keeps its layer range.
JobResult slice_plate(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult out;
  const bool plate = !job.parts.empty();
  const std::vector<PlatePart> placed = plate ? job.parts : std::vector<PlatePart>{PlatePart{}};
  const double h = c.machine.layer_height;
  const bool sequential = plate && c.plate.sequence == PlateSequence::Parts;
  std::vector<SlicePart> parts = slice_parts_of(job, c, placed, context);
  if (plate) {
    std::vector<PartFootprint> fp;
    for (std::size_t k = 0; k < parts.size(); ++k)
      fp.push_back(place_footprint(placed[k], parts[k].extent));
    const MachineProfile& m = c.machine;
    const BBox2 bed = m.origin == BedOrigin::Center
                          ? BBox2{{-m.bed_x / 2, -m.bed_y / 2}, {m.bed_x / 2, m.bed_y / 2}}
                          : BBox2{{0, 0}, {m.bed_x, m.bed_y}};
    check_plate(fp, bed, c.plate.clearance, job.origin);
    if (sequential) {
      if (job.shards)
        throw SettingError(
            "a plate printed part by part (plate.sequence = parts) does not shard "
            "by layers; shard it per layer (plate.sequence = layers)",
            {job.origin, 0, "plate.sequence"});
      std::vector<double> heights;
      for (const auto& p : parts) heights.push_back(static_cast<double>(p.layers) * h);
      check_sequential(fp, heights, m.extruder_clearance_radius, m.extruder_clearance_height,
                       job.origin);
    }
  }
  // Plate layer i holds layer i of every part that tall; its work is the parts' XY areas.
  std::size_t total = 0;
  for (const auto& p : parts) total = std::max(total, p.layers);
  std::vector<double> work(total, 0.0);
  for (const auto& p : parts)
    for (std::size_t i = 0; i < p.layers; ++i)
      work[i] += (p.extent.max.x - p.extent.min.x) * (p.extent.max.y - p.extent.min.y);
  // (Not a structured binding: clang 14, which builds the fuzz targets, cannot capture one.)
  const std::pair<std::size_t, std::size_t> range =
      job.shards ? shard_range(work, job.shard, job.shards)
                 : std::pair<std::size_t, std::size_t>{0, total};
  const std::size_t a = range.first, b = range.second;
  if (!job.shards && output_alone(job))
    return slice_plate_streamed(job, c, parts, placed, total, sequential, context);
  Toolpath tp;
  tp.layers.resize(b - a);
  for (std::size_t i = a; i < b; ++i) tp.layers[i - a].z = static_cast<double>(i + 1) * h;
  std::size_t paths = 0;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    SlicePart& p = parts[k];
    if (plate) tp.part_labels.push_back(placed[k].label);
    if (a >= p.layers) continue;
    if (job.shards) p.sj.layer_begin = a, p.sj.layer_end = b;
    SliceResult r = run_slice(p.sj, context);
    warn_process(r.process, p.sj.process, diag);
    p.process = r.process;
    warn_design(p.sj, r, context);
    if (!plate)
      tp.source = "trellis slice " + fs::path(p.sj.input).filename().string() + " (" +
                  to_string(r.route) + " route)";
    for (std::size_t j = 0; j < r.toolpath.layers.size(); ++j) {
      const std::size_t i = r.first_layer + j;  // the part's layer = the plate's layer
      if (i < a || i >= b) continue;
      for (Path& path : r.toolpath.layers[j].paths) {
        if (plate) {
          for (Vec3& q : path.points) q = place_point(placed[k], p.extent, q);
          path.part = static_cast<int>(k + 1);
        }
        tp.layers[i - a].paths.push_back(std::move(path));
        ++paths;
      }
    }
  }
  if (plate) tp.source = fmt::format("trellis slice plate ({} parts)", parts.size());
  if (job.shards)
    return shard_written(job, tp, a, b, total, fmt::format("{} paths", paths), std::move(out));
  if (sequential) tp.layers = part_by_part(std::move(tp.layers), parts, h);
  if (!job.output.empty()) note_planar_in_bath(c.machine, "slice", diag);
  if (plate && is_3mf_output(job.output)) slice_plate_geometry(job, parts, context.budget, out);
  GcodeStats g;
  write_slice_main(job, c, tp, out, diag, &g);
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, tp, job);
    out.files.push_back(job.toolpath);
  }
  plate_report(job, placed, parts, tp.layers.size(), paths, g, diag, out);
  RenderOptions ro;
  ro.colour_by_role = true;
  ro.size_px = c.output.image_size;
  previews(tp, job.preview, c.output.preview_layers, ro, out);
  out.summary = plate_summary(placed.size(), sequential, tp.layers.size(), h, paths, g);
  return out;
}

}  // namespace

JobResult slice(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  if (job.parts.empty() && job.shards) return slice_part_shard(job, c, context);
  if (!job.parts.empty() || job.shards) return slice_plate(job, c, context);
  JobResult out;
  if (job.input.empty())
    throw SettingError("slice needs a design (.vcad) or mesh to read", {"", 0, "job.input"});
  SliceJob sj = slice_job_of(job, c, job.input);
  // G-code alone: layers stream through a temporary file in bounded memory (planar and graded
  // slicing, a prime tower and process fields included); the toolpath JSON and previews hold
  // the whole toolpath.
  std::optional<LayerSpill> spill;
  if (output_alone(job)) spill.emplace();
  SliceResult r = spill ? stream_slice(
                              sj, [&](std::size_t, Layer&& l) { spill->append(l); }, {}, context)
                        : run_slice(sj, context);
  const std::size_t layers = r.streamed ? r.layers : r.outlines.size();
  warn_design(sj, r, context);
  if (sj.strategy != 0) {
    warn_palette(job.input, r.fgm.colours_used, r.fgm.colours_total, diag);
    warn_short_segments(job.input, r.fgm, diag);
    warn_error_bound(job.input, r.fgm, diag);
  }
  warn_process(r.process, sj.process, diag);
  // The file name only: outputs must not depend on where the command ran.
  r.toolpath.source = "trellis slice " + fs::path(job.input).filename().string() + " (" +
                      to_string(r.route) + " route)";
  GcodeStats g;
  if (!job.output.empty()) note_planar_in_bath(c.machine, "slice", diag);
  if (is_3mf_output(job.output)) slice_geometry(job, sj, r.bottom, context.budget, out);
  if (spill) {
    Toolpath meta;
    meta.source = r.toolpath.source;
    g = write_gcode_streamed(job.output, meta, spill->layers(), spill->source(), job, c.machine,
                             out, diag, true);
  } else {
    g = write_gcode_out(job.output, r.toolpath, job, c.machine, out, diag);
  }
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, r.toolpath, job);
    out.files.push_back(job.toolpath);
  }
  if (!job.report.empty()) {
    write_file_atomic(job.report,
                      with_job(slice_report_json(sj, r, &g), job, job.report, true, &diag));
    out.files.push_back(job.report);
  }
  RenderOptions ro;
  ro.colour_by_role = true;  // slice previews: feature type by default
  ro.colour_by_mixture = sj.strategy != 0;
  ro.starts = sj.strategy == 0;
  ro.size_px = c.output.image_size;
  previews(r.toolpath, job.preview, c.output.preview_layers, ro, out);
  if (sj.strategy != 0)
    out.summary = fmt::format(
        "strategy {}: {} colours, {} faces, {} paths{}, {} {} changes (look-ahead {} mm), {} "
        "purges "
        "({} mm3), gradient error mean {} max {} (bound {}), shortest {} mm; {} route, {} layers, "
        "~{} min",
        sj.strategy,
        r.fgm.quantized_from ? fmt::format("{} (quantized from {})", sj.tools, r.fgm.quantized_from)
                             : std::to_string(sj.fgm.palette.colors),
        r.fgm.faces, r.fgm.paths,
        r.fgm.joined ? fmt::format(" in {} beads (path order)", r.fgm.paths - r.fgm.joined) : "",
        g.gradient_changes, to_string(c.machine.gradient_mode), fixed(g.lookahead, 0), r.fgm.purges,
        fixed(r.fgm.purge_volume, 0), fixed(r.fgm.error_mean, 4), fixed(r.fgm.error_max, 4),
        fixed(r.fgm.error_bound, 4), fixed(r.fgm.shortest_path, 2), to_string(r.route), layers,
        fixed(g.print_time_s / 60, 1));
  else
    out.summary = fmt::format(
        "{} route: {} layers of {} mm, {} paths ({} wall loops, {} skin paths, {} infill lines), "
        "{} mm extruded, ~{} min; outlines {} s, walls+infill {} s",
        to_string(r.route), layers, fixed(c.machine.layer_height, 3), r.planar.paths,
        r.planar.walls, r.planar.skin_lines, r.planar.infill_lines,
        fixed(r.planar.extruded_length, 1), fixed(g.print_time_s / 60, 1),
        fixed(r.outline_seconds, 2), fixed(r.plan_seconds, 2));
  if (sj.strategy != 0 && r.fgm.min_segment > 0)
    out.summary += fmt::format("; min segment {} mm: {} merged, {} kept under it",
                               fixed(r.fgm.min_segment, 1), r.fgm.short_merged, r.fgm.short_kept);
  out.summary += process_summary(r.process, g);
  if (sj.strategy != 0 && r.fgm.tower.built)
    out.summary += fmt::format(
        "; prime tower {} at ({}, {}), {} layers, {} mm3, {} g, ~{} min",
        r.fgm.tower.size_x == r.fgm.tower.size_y
            ? fixed(r.fgm.tower.side, 1) + " mm square"
            : fixed(r.fgm.tower.size_x, 1) + " x " + fixed(r.fgm.tower.size_y, 1) + " mm",
        fixed(r.fgm.tower.x, 1), fixed(r.fgm.tower.y, 1), r.fgm.tower.layers,
        fixed(r.fgm.tower.volume, 0), fixed(r.fgm.tower.mass, 1), fixed(r.fgm.tower.time / 60, 1));
  return out;
}

namespace {

// Where a pbf design lies in its toolpath: layer i's top at (i + 1) × the layer thickness, so the
// design's bottom at z = 0.
Transform3mf pbf_design_transform(const PbfDesign& d) {
  Transform3mf m = kIdentity3mf;
  m[11] = -d.part().extent().min.z;
  return m;
}

// Every TPMS cell of the design resolved by the sampling grid, else SettingError naming the key.
void check_pbf_cells(const Config& c, const PbfOptions& po) {
  if (!(c.pbf.wall_thickness > 0)) {
    // The direct route traces φ = 0 on a grid of 2 × resolution: a cell of fewer than four grid
    // steps is not resolved (the traced lines jump between branches of the sheet; found by
    // fuzz_job_run with pbf.cell = 0.1 at the default 25 µm).
    std::vector<std::pair<double, const char*>> cells = {{c.pbf.cell, "pbf.cell"}};
    for (const auto& [spec, key] : {std::pair{c.pbf.grade_to, "pbf.grade_to"},
                                    std::pair{c.pbf.hierarchical, "pbf.hierarchical"}})
      if (const std::size_t colon = spec.find(':'); colon != std::string::npos)
        cells.emplace_back(std::strtod(spec.c_str() + colon + 1, nullptr), key);
    for (const auto& [cell, key] : cells)
      if (cell > 0 && cell < 8 * po.resolution)
        throw SettingError(fmt::format(
            "{}: a cell of {} mm is not resolved by the {} mm sampling grid (2 × pbf.resolution); "
            "cells need at least 8 × pbf.resolution = {} mm: raise the cell or lower "
            "pbf.resolution",
            key, cell, 2 * po.resolution, 8 * po.resolution));
  }
}

// The PBF options of a configuration (the laser profile's scan parameters over [pbf]).
PbfOptions pbf_options(const Job& job, const Config& c) {
  const LaserProfile& prof = c.laser;
  PbfOptions po = c.pbf.options;
  po.layer = prof.layer;
  po.segment_length = prof.segment_length;
  po.segment_gap = prof.segment_gap;
  po.hatch_distance = prof.hatch_distance;
  po.beam_compensation = prof.beam_compensation;
  po.melt_pool = prof.melt_pool_width;
  po.hybrid = c.pbf.strategy == PbfStrategy::Hybrid;
  po.machine_origin = pbf_machine_origin(c);
  po.stl_route = c.pbf.route == PbfRoute::Stl;
  po.timing = scan_timing(prof);
  return po;
}

bool finite_box(const BBox3& e) {
  return !e.empty() && std::isfinite(e.min.x) && std::isfinite(e.max.x) && std::isfinite(e.min.y) &&
         std::isfinite(e.max.y) && std::isfinite(e.min.z) && std::isfinite(e.max.z);
}

// A build plate of PBF parts, or a shard of one part or of a plate (job/plate.hpp): every part
// planned for the plate layers [a, b) only, placed, and its paths tagged with the part.
JobResult pbf_plate(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult out;
  const LaserProfile& prof = c.laser;
  struct Part {
    PlatePart place;
    Config config;
    PbfDesign design;
    BBox3 extent;
    std::size_t layers = 0;
  };
  std::vector<Part> parts;
  const bool plate = !job.parts.empty();
  const std::vector<PlatePart> placed = plate ? job.parts : std::vector<PlatePart>{PlatePart{}};
  for (const PlatePart& pp : placed) {
    Part p;
    p.place = pp;
    Settings st = job.settings;
    if (!pp.settings_toml.empty())
      st.load_toml(pp.settings_toml, job.origin + " part '" + pp.label + "'");
    p.config = st.config();
    try {
      check_pbf_cells(p.config, pbf_options(job, p.config));
    } catch (const SettingError& e) {
      if (!plate) throw;
      throw SettingError("part '" + pp.label + "': " + e.message(),
                         {job.origin, pp.line, e.where().element});
    }
    p.design = pbf_part_design(p.config, plate ? pp.input : job.input, st, context);
    p.extent = p.design.part().extent();
    if (!finite_box(p.extent))
      throw GeometryError("part '" + pp.label + "' has no finite extent: give it an envelope",
                          {job.origin, pp.line, "part"});
    if (p.config.laser.layer != prof.layer)
      throw SettingError("part '" + pp.label +
                             "' sets its own layer thickness: every part of a "
                             "plate is built in the plate's layers (scan.layer)",
                         {job.origin, pp.line, "scan.layer"});
    p.layers = layer_planes(p.extent.min.z, p.extent.max.z, prof.layer).size();
    parts.push_back(std::move(p));
  }
  if (plate) {
    std::vector<PartFootprint> fp;
    for (const auto& p : parts) fp.push_back(place_footprint(p.place, p.extent));
    check_plate(fp, {{0, 0}, {prof.build_x, prof.build_y}}, c.plate.clearance, job.origin);
    for (const auto& p : parts)
      if (p.extent.max.z - p.extent.min.z > prof.build_z)
        throw SettingError(
            fmt::format("part '{}' is {:.3f} mm tall, the build height is {} mm", p.place.label,
                        p.extent.max.z - p.extent.min.z, prof.build_z),
            {job.origin, p.place.line, "laser.build_z"});
  }
  // Plate layer i holds layer i of every part that tall; its work is the parts' XY areas.
  std::size_t total = 0;
  for (const auto& p : parts) total = std::max(total, p.layers);
  std::vector<double> work(total, 0.0);
  for (const auto& p : parts)
    for (std::size_t i = 0; i < p.layers; ++i)
      work[i] += (p.extent.max.x - p.extent.min.x) * (p.extent.max.y - p.extent.min.y);
  // (Not a structured binding: clang 14, which builds the fuzz targets, cannot capture one.)
  const std::pair<std::size_t, std::size_t> range =
      job.shards ? shard_range(work, job.shard, job.shards)
                 : std::pair<std::size_t, std::size_t>{0, total};
  const std::size_t a = range.first, b = range.second;
  Toolpath tp;
  tp.source = plate ? fmt::format("trellis pbf plate ({} parts)", parts.size()) : "trellis pbf";
  tp.layers.resize(b - a);
  for (std::size_t i = a; i < b; ++i) tp.layers[i - a].z = static_cast<double>(i + 1) * prof.layer;
  tp.lasers = declared_lasers(&prof, tp);
  std::size_t contour_vectors = 0, hatch_vectors = 0;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const Part& p = parts[k];
    if (plate) tp.part_labels.push_back(p.place.label);
    if (a >= p.layers) continue;
    const PbfOptions po = pbf_options(job, p.config);
    const std::size_t end = std::min(b, p.layers);
    // Each layer placed into the plate as it comes (laser's in-order layer sink).
    // Its warnings go to the context (plan_pbf).
    plan_pbf(
        p.design, po,
        [&](std::size_t i, const PbfLayer& L) {
          Layer layer = pbf_layer_toolpath(L, i, prof.layer, prof.contour_power, prof.contour_speed,
                                           prof.hatch_power, prof.hatch_speed);
          for (Path& path : layer.paths) {
            if (plate) {
              for (Vec3& q : path.points) q = place_point(p.place, p.extent, q);
              path.part = static_cast<int>(k + 1);
            }
            (path.points.size() == 2 &&
                     (path.role == PathRole::Hatch || path.role == PathRole::Infill)
                 ? hatch_vectors
                 : contour_vectors)++;
            tp.layers[i - a].paths.push_back(std::move(path));
          }
        },
        PbfLayerRange{a, end}, context);
  }
  // The plate's layers shared among the lasers, every part's paths together.
  LaserTimes times;
  if (splits_layers(c)) {
    const LaserSetup setup = lasers_of(c);
    for (std::size_t i = 0; i < tp.layers.size(); ++i)
      times.add(split_among_lasers(tp.layers[i], setup, a + i));
  }
  if (job.shards)
    return shard_written(
        job, tp, a, b, total,
        fmt::format("{} contour and {} hatch vectors", contour_vectors, hatch_vectors),
        std::move(out));
  out.toolpath = std::make_shared<Toolpath>(tp);
  write_pbf_main(job, c, tp, out);
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, tp, job);
    out.files.push_back(job.toolpath);
  }
  if (!job.report.empty()) {
    nlohmann::ordered_json j;
    j["format"] = "trellis.plate_report";
    j["version"] = 1;
    j["route"] = "pbf";
    j["layers"] = total;
    j["contour_vectors"] = contour_vectors;
    j["hatch_vectors"] = hatch_vectors;
    j["parts"] = nlohmann::ordered_json::array();
    for (const auto& p : parts)
      j["parts"].push_back({{"label", p.place.label},
                            {"x_mm", p.place.x},
                            {"y_mm", p.place.y},
                            {"rotation_deg", p.place.rotation},
                            {"layers", p.layers}});
    add_laser_report(j, times, c);
    write_file_atomic(job.report, with_job(j.dump(2) + "\n", job, job.report, true, &diag));
    out.files.push_back(job.report);
  }
  laser_previews(tp, job, c, out);
  out.summary =
      fmt::format("plate of {} parts: {} layers, {} contour vectors, {} hatch vectors{}",
                  parts.size(), total, contour_vectors, hatch_vectors, laser_summary(times));
  return out;
}

// A plate's parts as a 3MF's build items (write_pbf_main: the single run's and the merge's): each
// part's design meshed at its own pbf.resolution, placed as its paths are (the design's bottom on
// the plate, as its layers are counted from it); parts of one design and settings share a mesh.
void pbf_plate_geometry(const Job& job, const Config& c, JobResult& out) {
  std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes;
  for (const PlatePart& pp : job.parts) {
    Settings st = job.settings;
    if (!pp.settings_toml.empty())
      st.load_toml(pp.settings_toml, job.origin + " part '" + pp.label + "'");
    const Config pc = st.config();
    Diagnostics said;  // (the run's to give)
    const PbfDesign d = pbf_part_design(pc, pp.input, st, RunContext{.diagnostics = &said});
    const BBox3 e = d.part().extent();
    std::shared_ptr<const TriangleMesh>& mesh = meshes[pp.input + '\n' + pp.settings_toml];
    if (!mesh)
      mesh = field_mesh_3mf(d.part(), pbf_options(job, pc).resolution,
                            budget_of(job.settings, c, Progress{}));
    out.geometry.parts.push_back(
        {mesh, place_transform(pp, e, -e.min.z),
         pp.input.empty() ? pp.label : fs::path(pp.input).filename().string()});
  }
}

}  // namespace

void write_slice_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out,
                      Diagnostics& diag, GcodeStats* stats) {
  MachineProfile m = c.machine;
  // A plate is placed already: its parts' x, y are bed coordinates.
  if (!tp.part_labels.empty()) m.center = false;
  if (tp.part_labels.empty() && is_3mf_output(job.output))
    slice_geometry(job, slice_job_of(job, c, job.input), budget_of(job.settings, c, Progress{}),
                   out);
  // A plate's merge: its parts found again as the single run found them.
  if (!job.parts.empty() && is_3mf_output(job.output) && out.geometry.parts.empty())
    slice_plate_geometry(job, slice_parts_of(job, c, job.parts),
                         budget_of(job.settings, c, Progress{}), out);
  const GcodeStats g = write_gcode_out(job.output, tp, job, m, out, diag);
  if (stats) *stats = g;
}

void write_graded_merge(const Job& job, const Config& c, Toolpath& tp, const std::string& graded,
                        const std::vector<double>& outline_z, std::size_t total_layers,
                        JobResult& out, Diagnostics& diag) {
  const nlohmann::json g = nlohmann::json::parse(graded);
  const SliceJob sj = slice_job_of(job, c, job.input);
  if (!g.contains("strategy") || !g["strategy"].is_number_integer() || !g.contains("materials") ||
      !g["materials"].is_number_integer() || g["strategy"].get<int>() != sj.strategy)
    throw SettingError(
        "the shards' manifests say graded slicing, their job does not agree "
        "(slice.strategy): merge the shards of one run",
        {job.origin, 0, "slice.strategy"});
  const FgmOptions fo = graded_options(sj, g["materials"].get<int>());
  // Mixtures as a shard plans them: one share per material, each in 0..1.
  for (std::size_t i = 0; i < tp.layers.size(); ++i)
    for (const Path& p : tp.layers[i].paths)
      if (!p.mixture.empty() &&
          (p.mixture.size() != static_cast<std::size_t>(fo.palette.materials) ||
           std::any_of(p.mixture.begin(), p.mixture.end(),
                       [](double v) { return !(v >= 0 && v <= 1); })))
        throw ParseError(fmt::format("graded shard layer {}: a path's mixture is not {} shares in "
                                     "0..1; the shard files do not belong to this job",
                                     i, fo.palette.materials),
                         {job.origin});
  // The whole run has no layer without paths (a shard keeps its empty layers for the count).
  std::erase_if(tp.layers, [](const Layer& l) { return l.paths.empty(); });
  warn_palette(job.input, graded_colours_used(tp), fo.palette.colors, diag);
  FgmStats st;
  finish_graded(sj, fo, tp, st);
  if (g.value("process", false)) {
    // The process pass of the single run (slice/fgm_process.hpp), over every path, the tower's
    // too, the design sampled at the outlines' planes.
    if (outline_z.size() != total_layers)
      throw SettingError(fmt::format("the shards carry {} outline planes for {} layers",
                                     outline_z.size(), total_layers),
                         {job.origin, 0, "outline_z"});
    VcadOptions vo;
    vo.mesh_voxel = sj.mesh_voxel;
    const Field field = read_field_design(job.input, vo).field;
    if (!field.has_process())
      throw SettingError("the shards say the design has process fields, " + job.input +
                             " has none: merge the shards of one run",
                         {job.input, 0, "fprocess"});
    SliceResult r;
    r.toolpath = std::move(tp);
    for (double z : outline_z) r.outlines.push_back({z, {}});
    apply_slice_process(sj, field, r);
    warn_process(r.process, sj.process, diag);
    tp = std::move(r.toolpath);
  }
  write_slice_main(job, c, tp, out, diag);
}

// The surface the nonplanar route prints on: a mesh, nonplanar.height_fn over its domain, or a
// test surface (surface.kind).
static HeightField nonplanar_surface(const Job& job, const Config& c) {
  const auto& np = c.nonplanar;
  if (!job.input.empty() && !np.height_fn.empty())
    throw SettingError("give a surface mesh or nonplanar.height_fn, not both",
                       {"", 0, "nonplanar.height_fn"});
  if ((!job.input.empty() || !np.height_fn.empty()) && job.settings.has("surface.kind") &&
      !job.embedded)
    throw SettingError(
        "give one surface: a mesh, nonplanar.height_fn or a test surface (surface.kind)",
        {"", 0, "surface.kind"});
  if (!job.input.empty()) {
    return HeightField::from_mesh(read_mesh(job.input), fs::path(job.input).filename().string());
  }
  if (!np.height_fn.empty()) {
    if (np.domain.size() != 4)
      throw SettingError("the height function needs nonplanar.domain = x0,y0,x1,y1",
                         {"", 0, "nonplanar.domain"});
    return HeightField::from_expression(
        np.height_fn, {{np.domain[0], np.domain[1]}, {np.domain[2], np.domain[3]}},
        "z = " + np.height_fn);
  }
  if (job.settings.has("surface.kind")) {
    return test_surface(c.surface);
  }
  throw SettingError(
      "give a surface mesh, nonplanar.height_fn with nonplanar.domain, or a test surface "
      "(surface.kind)",
      {"", 0, "job.input"});
}

GcodeStats write_nonplanar_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out,
                                Diagnostics& diag) {
  // The surface printed on as the 3MF's build item.
  if (is_3mf_output(job.output) && !out.geometry.mesh) nonplanar_design(job, c, out);
  return write_gcode_out(job.output, tp, job, c.machine, out, diag);
}

void write_pbf_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out) {
  if (job.output.empty()) return;
  if (is_3mf_output(job.output) && tp.part_labels.empty() && !out.geometry.mesh) {
    // The shards' part, as a single run writes it (its warnings were the shards' to give).
    Diagnostics said;
    const PbfDesign d =
        pbf_part_design(c, job.input, job.settings, RunContext{.diagnostics = &said});
    out.geometry.mesh = field_mesh_3mf(d.part(), pbf_options(job, c).resolution,
                                       budget_of(job.settings, c, Progress{}));
    out.geometry.transform = pbf_design_transform(d);
  }
  // A plate's parts, each its design at its place.
  if (is_3mf_output(job.output) && !job.parts.empty() && out.geometry.parts.empty())
    pbf_plate_geometry(job, c, out);
  write_laser_build(job.output, tp, job, c, out);
}

JobResult pbf(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  if (pbf_solid_job(job, c)) return pbf_solid(job, c, context);
  if (!job.parts.empty() || job.shards) return pbf_plate(job, c, context);
  JobResult out;
  const LaserProfile& prof = c.laser;
  bool from_design = false;
  PbfDesign d = pbf_part_design(c, job.input, job.settings, context, &from_design);
  PbfOptions po = pbf_options(job, c);
  check_pbf_cells(c, po);
  const Budget budget = context.budget;
  if (finite_box(d.part().extent()) && po.layer > 0)
    check_budget(estimate_pbf_time(d, po, !job.toolpath.empty(), is_3mf_output(job.output)),
                 budget);
  // A build file alone is written layer by layer as the layers come (memory does not grow with
  // the layer count); the toolpath JSON, the layer previews and a 3MF package need the whole
  // toolpath.
  const bool stream = !job.keep_toolpath && !job.output.empty() && job.toolpath.empty() &&
                      job.preview.empty() && !is_3mf_output(job.output);
  Toolpath tp;
  PbfResult r;
  const bool split = splits_layers(c);
  const LaserSetup setup = lasers_of(c);
  LaserTimes times;
  if (stream) {
    CliStreamWriter writer(job.output, prof, CliWriteOptions{c.pbf.binary, true}, "trellis pbf",
                           embedded_job(job, job.output));
    r = plan_pbf(
        d, po,
        [&](std::size_t i, const PbfLayer& L) {
          Layer layer = pbf_layer_toolpath(L, i, po.layer, prof.contour_power, prof.contour_speed,
                                           prof.hatch_power, prof.hatch_speed);
          if (split) times.add(split_among_lasers(layer, setup, i));
          writer.add(layer);
        },
        {}, context);  // its warnings go to the context
    writer.finish();
    out.files.push_back(job.output);
  } else {
    r = plan_pbf(d, po, context);  // its warnings go to the context
    tp =
        pbf_toolpath(r, prof.contour_power, prof.contour_speed, prof.hatch_power, prof.hatch_speed);
    tp.lasers = declared_lasers(&prof, tp);  // the lasers that differ, in the toolpath JSON too
    if (split)
      for (std::size_t i = 0; i < tp.layers.size(); ++i)
        times.add(split_among_lasers(tp.layers[i], setup, i));
    out.toolpath = std::make_shared<Toolpath>(tp);
  }
  if (is_3mf_output(job.output)) {
    out.geometry.mesh = field_mesh_3mf(d.part(), po.resolution, budget);
    out.geometry.transform = pbf_design_transform(d);
  }
  if (!job.output.empty() && !stream) write_laser_build(job.output, tp, job, c, out);
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, tp, job);
    out.files.push_back(job.toolpath);
  }
  // A degenerate hybrid result is said: no wall was thin enough to be traced as contours, so the
  // build is hatched throughout, as the R67 baseline would be.
  if (c.pbf.strategy == PbfStrategy::Hybrid && r.contour_vectors == 0 && r.hatch_vectors > 0)
    diag.warn("pbf_no_contours",
              fmt::format("the hybrid strategy made no contour vectors: no wall is as thin as "
                          "pbf.thin_multiple × the melt pool ({} mm), so every wall was hatched as "
                          "R67 would; thinner sheets (pbf.c, pbf.thickness) or a larger "
                          "pbf.thin_multiple give contours",
                          fixed(po.thin_multiple * po.melt_pool, 3)));
  const PbfStats h = fr_stats(r.layers, false), b = fr_stats(r.layers, true);
  const double rss = peak_rss_mb();
  if (!job.report.empty()) {
    nlohmann::ordered_json j;
    j["format"] = "trellis.pbf_report";
    j["version"] = 1;
    j["route"] = to_string(c.pbf.route);
    j["strategy"] = to_string(c.pbf.strategy);
    // The lattice is the design's own sheet (its φ named by the design file) or the settings'.
    j["settings"] = {
        {"lattice", from_design ? "design " + fs::path(job.input).filename().string()
                                : std::string("settings")},
        {"cell_type", from_design ? nlohmann::ordered_json()
                                  : nlohmann::ordered_json(to_string(c.pbf.cell_type))},
        {"cell_mm", from_design ? nlohmann::ordered_json() : nlohmann::ordered_json(c.pbf.cell)},
        {"c", d.c.text},
        {"thickness_mm", d.thickness},
        {"layer_mm", po.layer},
        {"segment_length_mm", po.segment_length},
        {"segment_gap_mm", po.segment_gap},
        {"hatch_distance_mm", po.hatch_distance},
        {"beam_compensation_mm", po.beam_compensation},
        {"melt_pool_mm", po.melt_pool},
        {"resolution_mm", po.resolution},
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
    // Eq. 8 with the equivalent scan length L̃_p of every vector (its melt track's round ends).
    const PbfStats he = fr_eq_stats(r.layers, false), be = fr_eq_stats(r.layers, true);
    j["fr_a_eq"] = {{"mean", he.mean}, {"min", he.min}, {"max", he.max}, {"cv", he.cv}};
    j["fr_a_eq_r67_baseline"] = {
        {"mean", be.mean}, {"min", be.min}, {"max", be.max}, {"cv", be.cv}};
    const PbfStats t = thickness_stats(r.layers);
    j["wall_thickness_mm"] = {{"mean", t.mean}, {"min", t.min}, {"max", t.max}, {"spread", t.cv}};
    if (po.stl_route)
      j["mesh"] = {{"triangles", r.mesh_triangles},
                   {"mesh_bytes", r.mesh_bytes},
                   {"grid_bytes", r.grid_bytes}};
    j["scan_time_s"] = {{"hybrid", r.scan_time},
                        {"r67_baseline", r.scan_time_r67},
                        {"saving", r.scan_time_r67 > 0 ? 1 - r.scan_time / r.scan_time_r67 : 0}};
    j["per_layer"] = pbf_layer_series(r);  // paper Fig. 3(b)
    add_laser_report(j, times, c);
    // Every warning of the run: the design's (pbf_part_design) and the planner's.
    j["warnings"] = nlohmann::json::array();
    for (const auto& m : diag.messages())
      j["warnings"].push_back({{"kind", m.kind}, {"message", m.text}});
    j["memory_estimate_mb"] = r.memory_estimate / 1e6;
    j["time_s"] = r.seconds;
    j["peak_memory_mb"] = rss;
    write_file_atomic(job.report, with_job(j.dump(2) + "\n", job, job.report));
    out.files.push_back(job.report);
  }
  laser_previews(tp, job, c, out);
  if (!job.preview.empty() && c.output.preview_layers > 0) {
    out.files.push_back(preview_name(job.preview, "fr_a.png"));
    render_fr_plot(r, c.pbf.strategy == PbfStrategy::R67, out.files.back());
  }
  out.summary = fmt::format(
      "{} ({} route): {} layers, {} contour vectors ({} mm), {} hatch vectors ({} mm); FR_a mean "
      "{} "
      "cv {} (R67 baseline {} cv {}); scan time {} s (R67 {} s); {} s, peak {} MB",
      to_string(c.pbf.strategy), to_string(c.pbf.route), r.layers.size(), r.contour_vectors,
      fixed(r.contour_length, 1), r.hatch_vectors, fixed(r.hatch_length, 1), fixed(h.mean, 3),
      fixed(h.cv, 3), fixed(b.mean, 3), fixed(b.cv, 3), fixed(r.scan_time, 1),
      fixed(r.scan_time_r67, 1), fixed(r.seconds, 2), fixed(rss, 0));
  out.summary += laser_summary(times);
  return out;
}

namespace {

// nonplanar.planar_control: the same layers as a solid sliced flat, one tool per layer group.
JobResult planar_control(const Job& job, const Config& c, const HeightField& surface,
                         const NonplanarParams& prm, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  if (job.shards)
    throw SettingError("the planar control is sliced whole: drop --shard",
                       {"", 0, "nonplanar.planar_control"});
  // The non-planar lines' own settings (surface_spacing, chord_tolerance, max_join) are refused
  // by the schema with it: they are used only when nonplanar.planar_control = false.
  JobResult out;
  PlanarControlResult r = slice_planar_control(surface, prm, context);
  const GcodeStats g = write_nonplanar_main(job, c, r.toolpath, out, diag);
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, r.toolpath, job);
    out.files.push_back(job.toolpath);
  }
  std::size_t paths = 0;
  for (const auto& l : r.toolpath.layers) paths += l.paths.size();
  if (!job.report.empty()) {
    const nlohmann::ordered_json rep = {{"planar_control", true},
                                        {"surface", surface.name()},
                                        {"layers", r.toolpath.layers.size()},
                                        {"layer_height_mm", prm.layer_height},
                                        {"paths", paths},
                                        {"tool_changes", r.tool_changes},
                                        {"layers_with_several_tools", r.layers_with_several_tools},
                                        {"gcode_tool_changes", g.tool_changes},
                                        {"travel_moves", g.travel_moves}};
    write_file_atomic(job.report, with_job(rep.dump(2), job, job.report, true, &diag));
    out.files.push_back(job.report);
  }
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    View3dOptions v;
    v.size_px = c.output.image_size;
    v.title = "planar control of " + surface.name();
    v.colour = View3dOptions::Colour::Tool;
    out.files.push_back(preview_name(job.preview, "3d.png"));
    render_3d_png(r.toolpath, out.files.back(), v);
  }
  out.summary = fmt::format(
      "planar control: {} flat layers of {} mm, {} paths, {} tool changes ({} layers need more "
      "than one tool), {} travel moves, ~{} min",
      r.toolpath.layers.size(), fixed(prm.layer_height, 3), paths, r.tool_changes,
      r.layers_with_several_tools, g.travel_moves, fixed(g.print_time_s / 60, 1));
  return out;
}

}  // namespace

JobResult nonplanar(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  const Progress& progress = context.progress;
  JobResult out;
  const auto& np = c.nonplanar;
  const HeightField surface = nonplanar_surface(job, c);
  NonplanarParams prm = np.params;
  prm.layer_height = c.machine.layer_height;
  if (!job.settings.has("nonplanar.bead_width")) prm.width = c.machine.nozzle_diameter;
  if (!np.layer_tools.empty()) {
    prm.layer_tools = parse_layer_tools(np.layer_tools);
    if (np.layer_tools.find(':') != std::string::npos && !job.settings.has("nonplanar.layers"))
      prm.layers = static_cast<int>(prm.layer_tools.size());
  }
  require_bath(job, c.machine, "nonplanar",
               "non-planar layers are printed inside a support bath (the "
               "non-planar paper's FRESH set-up)");
  check_budget(estimate_nonplanar(surface.domain(), prm), context.budget);
  if (np.planar_control) return planar_control(job, c, surface, prm, context);
  // A shard (`--shard K/N`) keeps layers [a, b) of the run. Each layer's lines are its own, but
  // its serpentine starts where the layer before ended, so a shard slices layers 0..b-1 (the
  // ones before it only for that start point; truncating prm.layers leaves them unchanged).
  const std::size_t total = static_cast<std::size_t>(prm.layers);
  const auto [a, b] = job.shards
                          ? shard_range(std::vector<double>(total, 1.0), job.shard, job.shards)
                          : std::pair<std::size_t, std::size_t>{0, total};
  if (job.shards) prm.layers = static_cast<int>(std::max<std::size_t>(b, 1));
  NonplanarResult r = slice_nonplanar(surface, prm, context);
  if (job.shards) {
    prm.layers = static_cast<int>(total);
    r.toolpath.layers.resize(b);
    r.toolpath.layers.erase(r.toolpath.layers.begin(),
                            r.toolpath.layers.begin() + static_cast<std::ptrdiff_t>(a));
    r.layers.resize(b);
    r.layers.erase(r.layers.begin(), r.layers.begin() + static_cast<std::ptrdiff_t>(a));
  }
  std::size_t jumps = 0;
  for (const auto& l : r.layers) jumps += l.jumps;
  if (jumps)
    diag.warn("surface_jumps",
              fmt::format("the surface jumps at {} place(s) along the lines (a discontinuous "
                          "height): the paths are split there instead of bridged through the air",
                          jumps));
  if (job.shards) {
    std::size_t paths = 0;
    for (const auto& l : r.toolpath.layers) paths += l.paths.size();
    return shard_written(job, r.toolpath, a, b, total, fmt::format("{} paths", paths),
                         std::move(out));
  }
  progress("surface check", 0);
  const SurfaceDeviation dev = surface_deviation(r.toolpath, surface, prm);
  progress("surface check", 1);
  const GcodeStats g = write_nonplanar_main(job, c, r.toolpath, out, diag);
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, r.toolpath, job);
    out.files.push_back(job.toolpath);
  }
  if (!job.report.empty()) {
    write_file_atomic(job.report, with_job(nonplanar_report_json(r, prm, surface, dev, &g), job,
                                           job.report, true, &diag));
    out.files.push_back(job.report);
  }
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    View3dOptions v;
    v.size_px = c.output.image_size;
    v.title = surface.name();
    // Two or more tools: each tool's group in its colour; else the height, so curved layers
    // read as curved.
    std::set<int> tools;
    for (const auto& l : r.toolpath.layers)
      for (const auto& p : l.paths) tools.insert(p.tool);
    v.colour = tools.size() > 1 ? View3dOptions::Colour::Tool : View3dOptions::Colour::Height;
    out.files.push_back(preview_name(job.preview, "3d.png"));
    render_3d_png(r.toolpath, out.files.back(), v);
  }
  std::size_t paths = 0, travel = 0;
  double length = 0;
  for (const auto& l : r.layers) paths += l.paths, travel += l.travel_moves, length += l.length;
  out.summary = fmt::format(
      "{} layers of {} mm, {} paths of {} mm width, {} travel moves within layers, {} tool "
      "changes, "
      "{} mm of path, steepest descent {} deg, max deviation from the surface {} mm (chords {} "
      "mm), ~{} min",
      r.layers.size(), fixed(prm.layer_height, 3), paths, fixed(prm.width, 3), travel,
      g.tool_changes, fixed(length, 1), fixed(r.max_descent_deg, 1), fixed(dev.max_point, 4),
      fixed(dev.max_chord, 4), fixed(g.print_time_s / 60, 1));
  return out;
}

JobResult surface(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult out;
  if (c.surface.kind == SurfaceKind::AngleTest) {
    // The print-angle test path: toolpath JSON, or G-code for the job's machine.
    AngleTestParams p;
    Toolpath tp = angle_test(p);
    out.toolpath = std::make_shared<Toolpath>(tp);
    const std::string ext = fs::path(job.output).extension().string();
    if (job.output.empty()) {
    } else if (ext == ".json") {
      write_toolpath_with_job(job.output, tp, job);
      out.files.push_back(job.output);
    } else {
      if (job.machine.empty())
        throw SettingError("the angle test as G-code needs --machine (or write .json)",
                           {"", 0, "--machine"});
      GcodeStats g;
      g = write_gcode_out(job.output, tp, job, c.machine, out, diag);
    }
    if (!job.preview.empty()) {
      create_output_directories(job.preview);
      out.files.push_back(preview_name(job.preview, "3d.png"));
      render_3d_png(tp, out.files.back(), {});
    }
    out.summary = fmt::format("angle test: {} lines", tp.layers[0].paths.size());
    return out;
  }
  const HeightField s = test_surface(c.surface);
  {
    // The mesh's grid (profiled surfaces need fewer points: an upper bound).
    const BBox2 box = s.domain();
    const double points = (std::ceil(box.width() / c.surface.resolution) + 1) *
                          (std::ceil(box.height() / c.surface.resolution) + 1);
    Estimate e;
    e.bytes = points * 80;
    e.seconds = points * 2e-7;
    e.what = fmt::format("a {:.3g}-point surface mesh", points);
    e.change = "surface.resolution";
    check_budget(e, context.budget);
  }
  const TriangleMesh mesh = surface_mesh(s, c.surface.resolution);
  if (!job.output.empty()) {
    // By its extension (checked before the run: RouteSpec::formats): STL, OBJ or a 3MF package.
    write_mesh(job.output, mesh, s.name(), "output");
    out.files.push_back(job.output);
  }
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    NonplanarParams prm;
    prm.layers = 1;
    View3dOptions v;
    v.size_px = c.output.image_size;
    v.title = s.name();
    v.colour = View3dOptions::Colour::Height;
    out.files.push_back(preview_name(job.preview, "3d.png"));
    render_3d_png(slice_nonplanar(s, prm).toolpath, out.files.back(), v);
  }
  out.summary = fmt::format("{}: {} triangles", s.name(), mesh.triangles.size());
  return out;
}

void slice_design(const Job& job, const Config& c, JobResult& out) {
  const Budget budget = budget_of(job.settings, c, Progress{});
  if (!job.parts.empty())
    slice_plate_geometry(job, slice_parts_of(job, c, job.parts), budget, out);
  else
    slice_geometry(job, slice_job_of(job, c, job.input), budget, out);
}

void pbf_design(const Job& job, const Config& c, JobResult& out) {
  if (pbf_solid_job(job, c)) return;  // a mesh part: its beads (docs/limitations.md)
  if (!job.parts.empty()) return pbf_plate_geometry(job, c, out);
  Diagnostics said;  // (the run's to give)
  const PbfDesign d = pbf_part_design(c, job.input, job.settings, RunContext{.diagnostics = &said});
  out.geometry.mesh = field_mesh_3mf(d.part(), pbf_options(job, c).resolution,
                                     budget_of(job.settings, c, Progress{}));
  out.geometry.transform = pbf_design_transform(d);
}

// An open "surface" object: a mesh as read, else its grid at half the bead width, as the planar
// control meshes it.
void nonplanar_design(const Job& job, const Config& c, JobResult& out) {
  out.geometry.mesh = std::make_shared<const TriangleMesh>(
      job.input.empty() ? surface_mesh(nonplanar_surface(job, c), c.machine.nozzle_diameter / 2)
                        : read_mesh(job.input));
  out.geometry.surface = true;
}

}  // namespace trellis::routes
