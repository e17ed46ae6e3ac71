#include "trellis/slice/pipeline.hpp"

#include <fmt/format.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "fgm_tower.hpp"
#include "trellis/core/error.hpp"
#include "trellis/field/implicit_3mf.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/fgm.hpp"
#include "trellis/slice/fgm_process.hpp"
#include "trellis/toolpath/layer_spill.hpp"

namespace trellis {

SliceRoute slice_route_from_string(const std::string& name) {
  if (name == "auto") return SliceRoute::Auto;
  if (name == "field") return SliceRoute::Field;
  if (name == "mesh") return SliceRoute::Mesh;
  throw SettingError("unknown route '" + name + "' (expected auto, field or mesh)");
}

const char* to_string(SliceRoute route) {
  switch (route) {
    case SliceRoute::Auto:
      return "auto";
    case SliceRoute::Field:
      return "field";
    case SliceRoute::Mesh:
      return "mesh";
  }
  return "?";
}

namespace {

// A mesh that is not a closed 2-manifold: repaired (counts in `r`), or refused when repair is
// off or leaves it open; the messages say what to do.
TriangleMesh closed_mesh(TriangleMesh mesh, const SliceJob& job, SliceResult& r,
                         const RunContext& context) {
  const MeshCheck c = check_mesh(mesh);
  if (c.closed()) return mesh;
  if (!job.repair)
    throw GeometryError(
        fmt::format("mesh is not closed and manifold: {} open edges, {} "
                    "non-manifold edges; first: {}. Slice with slice.repair = true to "
                    "have it repaired, or fix it in a mesh editor",
                    c.open_edges, c.nonmanifold_edges, c.first_problem),
        {job.input, 0, ""});
  context.check_budget(mesh_repair_estimate(mesh.triangles.size(), c.open_edges));
  TriangleMesh fixed;
  try {
    fixed = repair_mesh(mesh, job.repair_options, r.repair);
  } catch (const GeometryError& e) {
    if (!e.where().file.empty()) throw;
    throw GeometryError(e.message(), {job.input, 0, ""});
  }
  r.repaired = true;
  const MeshCheck after = check_mesh(fixed);
  if (!after.closed() || fixed.triangles.empty())
    throw GeometryError(
        fmt::format("mesh is not closed and manifold ({} open edges, {} non-manifold edges) and "
                    "repair could not close it ({}); still {} open edges, {} non-manifold edges; "
                    "first: {}. Close the large holes in a mesh editor (or export the part "
                    "again as a solid) and slice that",
                    c.open_edges, c.nonmanifold_edges, r.repair.summary(), after.open_edges,
                    after.nonmanifold_edges, after.first_problem),
        {job.input, 0, ""});
  // A surface, not a solid (e.g. one sheet whose edge became a "hole" and was filled).
  const BBox3 b = bounds(fixed);
  const double diagonal = norm(b.max - b.min);
  if (!(std::abs(volume(fixed)) > 1e-9 * diagonal * diagonal * diagonal))
    throw GeometryError(
        fmt::format("mesh is not closed and manifold ({} open edges, {} non-manifold edges) and "
                    "encloses no volume once repaired ({}): it is a surface, not a solid. Export "
                    "the part as a solid",
                    c.open_edges, c.nonmanifold_edges, r.repair.summary()),
        {job.input, 0, ""});
  return fixed;
}

// A TPMS cell the sampling grid cannot resolve is refused, as pbf refuses one (8 samples a cell at
// least): a 0.001 mm gyroid cell sampled every 0.1 mm traced 13,448 aliasing paths, none of them
// the design. `step` is the grid (slice.resolution, or slice.mesh_voxel for marching cubes).
void check_cells(const Field& field, double step, const char* setting, const std::string& input) {
  const double cell = field.smallest_period();
  if (cell < 8 * step)
    throw SettingError(fmt::format("its TPMS cell of {:.4g} mm is not resolved by the {} mm "
                                   "sampling grid ({}): cells need at least 8 samples, {:.4g} mm; "
                                   "raise the cell or lower {}",
                                   cell, step, setting, 8 * step, setting),
                       {input, 0, setting});
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Work of a slice from its extent and settings: the field route samples an XY grid per layer,
// walls offset the outline, graded strategies sample the material grid for every colour.
// Constants measured on one core (csg_bracket at 0.05 mm: 5.9e7 samples, 1.1 s; the palette
// plate, 16 colours at 1 mm: 3.8e6 cell-colours, 6.9 s), rounded up; walls 6e-7 s a point of
// outline and wall since the direct offsets (bench/estimate_calibration.py). A large design costs
// per sample and node of its tree besides: a union of 1,000 spheres (3,001 nodes) over 2.4e7
// samples took 22.7 s, 100 spheres 0.8 s (pruning by bounds helps less as they crowd): 3e-10 s.
Estimate slice_estimate(const SliceJob& job, const BBox3& e, std::size_t layers, bool field,
                        double nodes) {
  const double wx = e.max.x - e.min.x, wy = e.max.y - e.min.y;
  const double L = double(layers);
  const double threads = std::max(1, tbb::this_task_arena::max_concurrency());
  const double res = job.field.resolution;
  const double samples = field ? L * (wx / res + 3) * (wy / res + 3) : 0;
  const double outline_points = 2 * (wx + wy) / std::min(res, job.planar.bead_width);
  const double wall_work = L * (job.planar.walls + 2) * outline_points;
  double fgm = 0;
  if (job.strategy == 1 || job.strategy == 2) {
    const double m = job.fgm.material_resolution;
    fgm = L * job.fgm.palette.colors * (wx / m + 3) * (wy / m + 3);
  }
  // Infill patterns that cost more than lines: a lattice is generated over about 4.5 times the
  // part's box and cropped every layer (~15 µs a cell, the cell about w / density); a gyroid
  // is marched at 1/16 of its period and clipped (~0.4 µs a grid point). Measured on Vase.stl.
  double pattern = 0;
  const double w = job.planar.bead_width, d = std::max(job.planar.infill_density, 1e-3);
  if (job.planar.infill_pattern == InfillPattern::Lattice) {
    const double cell = w / d;
    pattern = L * 4.5 * wx * wy / (cell * cell) * 1.5e-5;
  } else if (job.planar.infill_pattern == InfillPattern::Gyroid) {
    const double res = 2 * 3.14159 * 0.3913 * w / d / 16;
    pattern = L * wx * wy / (res * res) * 4e-7;
  }
  Estimate est;
  est.seconds =
      (samples * (2e-8 + nodes * 3e-10) + wall_work * 6e-7 + fgm * 2e-6 + pattern) / threads;
  est.bytes = threads * (field ? (wx / res + 3) * (wy / res + 3) * 16 : 0) + wall_work * 48 +
              (fgm > 0 ? threads * fgm / L / job.fgm.palette.colors * 24 : 0);
  est.what = fmt::format("slicing {} layers of {:.0f} x {:.0f} mm", layers, wx, wy);
  est.change = "slice.resolution, extrusion.layer_height, slice.walls";
  if (field && nodes > 1000) {
    est.what += fmt::format(" of a design of {:.3g} nodes", nodes);
    est.change += ", the design (fewer shapes)";
  }
  if (pattern > 0) est.change += ", slice.infill_pattern";
  if (fgm > 0) {
    est.what += fmt::format(" in {} colours", job.fgm.palette.colors);
    est.change += ", fgm.colors, fgm.material_resolution";
  }
  return est;
}

// A mesh's signed distance field (OpenVDB, narrow band of ±3 voxels): its surface area over the
// voxel's square, 6 voxels deep. Measured: a 10 mm cube at 0.01 mm, 3.6e7 voxels, 1.3 GB and 41 s
// to slice; at 0.02 mm 0.31 GB and 9 s (about 36 B and 1.1 µs a voxel, rounded up).
Estimate mesh_field_estimate(const TriangleMesh& m, double voxel) {
  double area = 0;
  for (const auto& t : m.triangles) {
    const Vec3 u = m.vertices[t[1]] - m.vertices[t[0]], v = m.vertices[t[2]] - m.vertices[t[0]];
    area += 0.5 * norm({u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x});
  }
  const double voxels = 6 * area / (voxel * voxel);
  Estimate e;
  e.bytes = voxels * 40;
  e.seconds = voxels * 1.2e-6;
  e.what = fmt::format("a distance field of {:.3g} voxels ({:.0f} mm2 of surface at {} mm)", voxels,
                       area, voxel);
  e.change = "slice.mesh_voxel or slice.route = mesh";
  return e;
}

// Marching cubes of a design over its box: every 8^3 block's bound is visited, the band around
// the surface sampled (the box's surface area stands in for the design's). Measured: a sphere
// of 80 mm at 0.05 mm, 4.1e9 box voxels, 1.8 GB, 17 s.
Estimate meshing_estimate(const BBox3& box, double voxel) {
  const Vec3 s = box.max - box.min;
  const double cells = (s.x / voxel + 2) * (s.y / voxel + 2) * (s.z / voxel + 2);
  const double area = 2 * (s.x * s.y + s.y * s.z + s.z * s.x);
  Estimate e;
  e.bytes = 6 * area / (voxel * voxel) * 40;
  e.seconds = cells * 4e-9;
  e.what =
      fmt::format("marching cubes over {:.0f} x {:.0f} x {:.0f} mm at {} mm", s.x, s.y, s.z, voxel);
  e.change = "slice.mesh_voxel or slice.route = field";
  return e;
}

struct SlicedDesign {
  Field field;
  TriangleMesh mesh;
  std::vector<double> zs;  // slicing planes over the extent
};

// The design read (a field, or a mesh closed by repair), its route chosen, its layers' planes
// and the budget checked; with `outline_all`, every plane outlined into r.outlines.
SlicedDesign open_design(const SliceJob& job, SliceResult& r, const RunContext& context,
                         bool outline_all) {
  const Progress& progress = context.progress;
  SlicedDesign d;
  const bool is_vcad = is_field_design(job.input);
  r.route =
      job.route == SliceRoute::Auto ? (is_vcad ? SliceRoute::Field : SliceRoute::Mesh) : job.route;
  const double h = job.planar.layer_height;
  if (!(h > 0)) throw SettingError("layer height must be > 0");
  const bool ranged = !outline_all;
  std::vector<double>& zs = d.zs;
  Field& field = d.field;
  TriangleMesh& mesh = d.mesh;
  auto check_layers = [&](const BBox3& e) {
    if (e.empty() || !std::isfinite(e.min.z) || !std::isfinite(e.max.z))
      throw GeometryError("the design has no finite extent in Z; give it a root() box",
                          {job.input, 0, ""});
    zs = layer_planes(e.min.z, e.max.z, h);
    if (zs.size() > 200000)
      throw SettingError("more than 200,000 layers: check the layer height and the units");
    if (zs.empty()) throw GeometryError("the design is thinner than one layer", {job.input, 0, ""});
    const bool sampled = is_vcad || r.route == SliceRoute::Field;
    context.check_budget(
        slice_estimate(job, e, zs.size(), sampled, field.empty() ? 1 : field.nodes()));
  };
  // A design is a field, a mesh file a mesh; each route turns one into the other if it must.
  if (is_vcad) {
    VcadOptions vo;
    vo.mesh_voxel = job.mesh_voxel;
    VcadDesign design = read_field_design(job.input, vo);
    field = std::move(design.field);
    r.design_min_feature = design.min_feature_size;
    // A graded design printed as one material must be asked for: nothing silent.
    if (job.strategy == 0 && !job.strategy_chosen && field.materials().size() >= 2)
      throw SettingError("the design is graded (" + std::to_string(field.materials().size()) +
                             " materials) but no gradient strategy was chosen: slice with "
                             "slice.strategy = 1 (walls and infill by colour, purge) or 2 (dense "
                             "fill by colour), or slice.strategy = none to print it as one "
                             "material on "
                             "purpose",
                         {job.input, 0, "slice.strategy"});
  } else {
    context.check_budget(mesh_read_estimate(job.input));
    mesh = closed_mesh(read_mesh(job.input), job, r, context);  // welded by the reader
    r.mesh_triangles = mesh.triangles.size();
  }
  if (r.route == SliceRoute::Field) {
    if (!is_vcad) {
      MeshSdfOptions mo;
      mo.voxel = job.mesh_voxel;
      context.check_budget(mesh_field_estimate(mesh, mo.voxel));
      field = mesh_field(mesh, mo, job.input);
    }
    if (is_vcad) check_cells(field, job.field.resolution, "slice.resolution", job.input);
    r.extent = field.extent();
    check_layers(r.extent);
    if (!ranged) r.outlines = slice_field(field, zs, job.field, &r.field_stats, context);
  } else {
    if (is_vcad) {
      // The classic route for a design: marching cubes of its field (OpenVDB) at the mesh
      // voxel, then plane cuts — for comparison with the direct route.
      check_cells(field, job.mesh_voxel, "slice.mesh_voxel", job.input);
      r.extent = field.extent();
      check_layers(r.extent);
      if (is_finite(r.extent.max - r.extent.min))
        context.check_budget(meshing_estimate(r.extent, job.mesh_voxel));
      mesh = field_to_mesh(field, r.extent, job.mesh_voxel);
      r.mesh_triangles = mesh.triangles.size();
    } else {
      r.extent = bounds(mesh);
      check_layers(r.extent);
    }
    progress.check("slicing");
    if (!ranged) r.outlines = slice_mesh_layers(mesh, zs, 1e-6, r.repaired);
    progress("outlines", 1.0);
  }
  return d;
}

// Outlines of the design at `planes` (the route's slicer).
std::vector<LayerOutline> outlines_at(const SlicedDesign& d, const SliceJob& job, SliceResult& r,
                                      const std::vector<double>& planes, SliceStats* stats,
                                      const RunContext& context) {
  return r.route == SliceRoute::Field ? slice_field(d.field, planes, job.field, stats, context)
                                      : slice_mesh_layers(d.mesh, planes, 1e-6, r.repaired);
}

// The part's printed planes [first, last) of d.zs: its ends found plane by plane from the bottom
// and the top (the extent of a design is a bound: blends, clip boxes).
std::pair<std::size_t, std::size_t> printed_planes(const SlicedDesign& d, const SliceJob& job,
                                                   SliceResult& r, const RunContext& context) {
  // An empty plane's samples count (the whole run samples it too); a printed plane is sampled
  // again with its layer.
  auto empty_at = [&](double z) {
    SliceStats probe;
    const bool empty = outlines_at(d, job, r, {z}, &probe, context)[0].regions.empty();
    if (empty) {
      r.field_stats.samples += probe.samples;
      r.field_stats.blocks += probe.blocks;
      r.field_stats.skipped_blocks += probe.skipped_blocks;
    }
    return empty;
  };
  std::size_t first = 0, last = d.zs.size();
  while (first < last && empty_at(d.zs[first])) ++first;
  while (last > first && empty_at(d.zs[last - 1])) --last;
  if (first == last)
    throw GeometryError("no layer has any outline: the design is empty at every slicing plane",
                        {job.input, 0, ""});
  r.bottom = r.extent.min.z + static_cast<double>(first) * job.planar.layer_height;
  return {first, last};
}

// A fraction that is not a number (GeometryError without a file): name the design.
template <class Work>
void naming_design(const SliceJob& job, Work&& work) {
  try {
    work();
  } catch (const GeometryError& e) {
    if (!e.where().file.empty()) throw;
    throw GeometryError(e.message(), {job.input, 0, e.where().element});
  }
}

void require_graded_design(const SliceJob& job, bool is_vcad, const Field& field) {
  if (!is_vcad || field.materials().size() < 2)
    throw GeometryError("slice.strategy = " + std::to_string(job.strategy) +
                            " needs a .vcad design with two or three materials (fgrade)",
                        {job.input, 0, ""});
  if (field.materials().size() > 3)
    throw GeometryError("gradient slicing mixes two or three materials; the design has " +
                            std::to_string(field.materials().size()),
                        {job.input, 0, ""});
}

// A tool changer prints a two-material mixture with its nearest tool: tool k of n + 1 prints
// the first material's share 1 - k/n.
double nearest_tool_share(double share, int tools) {
  const double n = tools - 1;
  return 1 - std::round((1 - std::clamp(share, 0.0, 1.0)) * n) / n;
}

// The mixtures a tool changer writes, after the prime tower (which reads the palette's).
void tool_mixtures(const SliceJob& job, Layer& layer) {
  if (job.tools <= 1) return;
  for (auto& p : layer.paths)
    if (p.mixture.size() == 2) {
      const double t = nearest_tool_share(p.mixture[0], job.tools);
      p.mixture = {t, 1 - t};
    }
}

// The bound on the gradient error of what is printed: the palette's (zippering prints the
// neighbouring colour up to β/2 beyond a boundary); on a tool changer, of the tools' mixtures.
double graded_error_bound(const SliceJob& job, const FgmOptions& fo) {
  const double zipper = job.strategy == 1 ? fo.zipper / 2 : 0.0;
  if (job.tools <= 1) return fo.palette.error_bound() + zipper;
  double bound = 0;
  for (int k = 0; k < fo.palette.colors; ++k) {
    const double lo = k == 0 ? 0.0 : fo.palette.level(k);
    const double hi = k + 1 == fo.palette.colors ? 1.0 : fo.palette.level(k + 1);
    const double t = nearest_tool_share(fo.palette.mixture(k)[0], job.tools);
    bound = std::max({bound, std::abs(t - lo), std::abs(hi - t)});
  }
  return bound + zipper;
}

// The layers below and above a planned layer whose outlines its skins read: planar layers and
// Strategy 1's (cut from them); Strategy 2 plans each layer from its own outline.
std::pair<std::size_t, std::size_t> skin_margins(const SliceJob& job) {
  if (job.strategy == 2) return {0, 0};
  return {static_cast<std::size_t>(std::max(0, job.planar.bottom_layers)),
          static_cast<std::size_t>(std::max(0, job.planar.top_layers))};
}

// A graded print's paths are cut by colour (Strategy 1) or planned per colour face (Strategy 2):
// the report's path count and extruded length are summed over the printed part paths (not purges
// or the tower) in print order, the same for the whole and the streamed run.
// The planar slicer's options for a design of extent r.extent: lattice infill on the part's
// box, whatever window of layers is planned (shards and streamed runs stack the same cells).
PlanarOptions planar_options(const SliceJob& job, const SliceResult& r) {
  PlanarOptions po = job.planar;
  const BBox3& e = r.extent;
  if (!(po.infill_frame.width() > 0) && std::isfinite(e.min.x) && std::isfinite(e.max.x) &&
      std::isfinite(e.min.y) && std::isfinite(e.max.y))
    po.infill_frame = {{e.min.x, e.min.y}, {e.max.x, e.max.y}};
  return po;
}

void count_graded_path(const Path& path, PlanarStats& s) {
  if (path.role == PathRole::Purge) return;
  ++s.paths;
  s.extruded_length += path.length();
}

}  // namespace

int graded_colours_used(const Toolpath& tp) {
  std::set<std::vector<double>> used;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths)
      if (p.role != PathRole::Purge && !p.mixture.empty()) used.insert(p.mixture);
  return static_cast<int>(used.size());
}

FgmOptions graded_options(const SliceJob& job, int materials, int* quantized_from) {
  FgmOptions fo = job.fgm;
  fo.palette.materials = materials;
  fo.palette.check();
  if (quantized_from) *quantized_from = 0;
  if (job.tools > 0) {
    // A tool changer prints N fixed mixes (tool 0 = material A … the last = B): the palette's
    // colours are those mixes, never more colours than tools unless quantising is asked for.
    if (fo.palette.materials != 2)
      throw GeometryError(
          "a tool changer prints two-material gradients (one fixed mix per "
          "tool); the design has three materials",
          {job.input, 0, ""});
    if (fo.palette.colors > job.tools) {
      if (!job.quantize)
        throw SettingError(
            std::to_string(fo.palette.colors) + " colours on " + std::to_string(job.tools) +
                " tools: each colour needs a tool (use fgm.colors = " + std::to_string(job.tools) +
                ", or gradient.quantize = true to print each colour with the "
                "nearest tool)",
            {"", 0, "fgm.colors"});
      if (quantized_from) *quantized_from = fo.palette.colors;
      fo.palette.colors = job.tools;
    }
    fo.palette.ends = fo.palette.colors > 1;
    fo.tool_changer = true;
  }
  fo.layer_height = job.planar.layer_height;
  fo.bead_width = job.planar.bead_width;
  fo.resolution = job.field.resolution;
  return fo;
}

bool graded_tower(const SliceJob& job) {
  return (job.strategy == 1 && job.fgm.order == FgmOrder::Faces) || job.tools > 0;
}

void finish_graded(const SliceJob& job, const FgmOptions& fo, Toolpath& tp, FgmStats& st) {
  // Strategy 1 in face order purges into the tower; a tool changer primes each tool it changes
  // to (in path order, and Strategy 2, a mixing hotend runs the change ahead instead:
  // gradient.lookahead, the writer's).
  if (graded_tower(job)) naming_design(job, [&] { add_prime_tower(tp, fo, job.purge, st); });
  for (auto& l : tp.layers) tool_mixtures(job, l);
}

namespace {

SliceResult run_slice_on(const SliceJob& job, const RunContext& context) {
  const Progress& progress = context.progress;
  SliceResult r;
  const bool is_vcad = is_field_design(job.input);
  const auto t0 = std::chrono::steady_clock::now();
  const double h = job.planar.layer_height;
  const bool ranged = job.layer_begin != 0 || job.layer_end != static_cast<std::size_t>(-1) ||
                      static_cast<bool>(job.range_of);
  SlicedDesign d = open_design(job, r, context, !ranged);
  const std::vector<double>& zs = d.zs;
  const Field& field = d.field;

  // A range of the part's layers (a shard): the part's ends found plane by plane from the
  // bottom and the top, then only the range and the layers its skins look at are sliced.
  std::size_t range_lo = 0, range_a = 0, range_b = 0;
  const bool graded = job.strategy == 1 || job.strategy == 2;
  if (graded) require_graded_design(job, is_vcad, field);
  if (ranged) {
    auto outlines_of = [&](const std::vector<double>& planes) {
      return outlines_at(d, job, r, planes, &r.field_stats, context);
    };
    const auto [first, last] = printed_planes(d, job, r, context);
    const std::size_t n = last - first;
    const std::pair<std::size_t, std::size_t> asked =
        job.range_of ? job.range_of(r.extent, n) : std::pair{job.layer_begin, job.layer_end};
    range_a = std::min(asked.first, n);
    range_b = std::max(range_a, std::min(asked.second, n));
    // Planar shard files do not carry the values; graded slicing leaves the process pass to
    // the merge (it runs after the prime tower, over the tower's paths too).
    if (field.has_process() && range_a < range_b && !graded)
      throw SettingError(
          "a design with process fields (fprocess) does not shard with planar "
          "slicing: slice it whole",
          {job.input, 0, "fprocess"});
    r.process_fields = field.has_process();
    const auto [below, above] = skin_margins(job);
    range_lo = range_a >= below ? range_a - below : 0;
    const std::size_t hi = range_a < range_b ? std::min(n, range_b + above) : range_lo;
    r.outlines = outlines_of(std::vector<double>(zs.begin() + static_cast<long>(first + range_lo),
                                                 zs.begin() + static_cast<long>(first + hi)));
    r.part_layers = n;
    r.first_layer = range_a;
    r.outline_first = range_lo;
    r.outline_seconds = seconds_since(t0);
    PlanarOptions po = planar_options(job, r);
    po.first_index = range_lo;
    po.plan_begin = range_a;
    po.plan_end = range_b;
    if (graded && range_a < range_b) {
      // The layer-local step of graded slicing; the whole-print step (finish_graded) is the
      // merge's.
      int quantized_from = 0;
      FgmOptions fo =
          graded_options(job, static_cast<int>(field.materials().size()), &quantized_from);
      fo.first_layer = range_lo;
      r.fgm.materials = fo.palette.materials;
      r.fgm.quantized_from = quantized_from;
      naming_design(job, [&] {
        if (job.strategy == 2) {
          r.toolpath = plan_fgm_strategy2(field, r.outlines, fo, &r.fgm);
        } else {
          const Toolpath planar = plan_planar(r.outlines, po, &r.planar);
          r.toolpath = plan_fgm_strategy1(field, r.outlines, planar, fo, PurgeOptions{}, &r.fgm);
        }
      });
    } else if (range_a < range_b) {
      r.toolpath = plan_planar(r.outlines, po, &r.planar);
    }
    r.toolpath.source = "trellis slice " + job.input + " (" + to_string(r.route) + " route)";
    r.plan_seconds = seconds_since(t0) - r.outline_seconds;
    return r;
  }
  // The extent of a design is a bound (blends, clip boxes): drop empty layers below and above
  // the part so its first layer sits on the bed.
  std::size_t first = 0, last = r.outlines.size();
  while (first < last && r.outlines[first].regions.empty()) ++first;
  while (last > first && r.outlines[last - 1].regions.empty()) --last;
  r.bottom = r.extent.min.z + static_cast<double>(first) * h;
  r.outlines = std::vector<LayerOutline>(r.outlines.begin() + static_cast<long>(first),
                                         r.outlines.begin() + static_cast<long>(last));
  r.outline_seconds = seconds_since(t0);
  r.part_layers = r.outlines.size();
  if (r.outlines.empty())
    throw GeometryError("no layer has any outline: the design is empty at every slicing plane",
                        {job.input, 0, ""});
  const auto t1 = std::chrono::steady_clock::now();
  progress.check("slicing");
  progress("walls and infill", 0.0);
  if (graded) {
    int quantized_from = 0;
    const FgmOptions fo =
        graded_options(job, static_cast<int>(field.materials().size()), &quantized_from);
    // The layer-local step (what a shard does for its layers), then the whole-print step (what
    // the merge does on all layers): one construction for the whole and the sharded run.
    naming_design(job, [&] {
      if (job.strategy == 2) {
        r.toolpath = plan_fgm_strategy2(field, r.outlines, fo, &r.fgm);
      } else {
        const Toolpath planar = plan_planar(r.outlines, planar_options(job, r), &r.planar);
        r.toolpath = plan_fgm_strategy1(field, r.outlines, planar, fo, PurgeOptions{}, &r.fgm);
      }
    });
    r.planar.paths = 0, r.planar.extruded_length = 0;
    for (const Layer& layer : r.toolpath.layers)
      for (const Path& path : layer.paths) count_graded_path(path, r.planar);
    r.fgm.materials = fo.palette.materials;
    r.fgm.band = fo.palette.band();
    r.fgm.quantized_from = quantized_from;
    r.fgm.colours_used = graded_colours_used(r.toolpath);
    r.fgm.colours_total = fo.palette.colors;
    finish_graded(job, fo, r.toolpath, r.fgm);
    r.fgm.error_bound = graded_error_bound(job, fo);
    naming_design(job, [&] {
      // As deposited where the writer runs the changes ahead (no tower flushing them instead).
      Toolpath deposited;
      const bool ahead = job.lookahead > 0 && !graded_tower(job) &&
                         deposit_start_mixtures(deposited = r.toolpath, job.lookahead);
      measure_gradient_error(field, ahead ? deposited : r.toolpath, r.outlines, h, r.fgm);
      if (job.lookahead > 0 && !graded_tower(job)) r.fgm.error_lookahead = job.lookahead;
    });
  } else {
    r.toolpath = plan_planar(r.outlines, planar_options(job, r), &r.planar);
  }
  apply_slice_process(job, field, r);
  r.toolpath.source = "trellis slice " + job.input + " (" + to_string(r.route) + " route)";
  progress("walls and infill", 1.0);
  r.plan_seconds = seconds_since(t1);
  return r;
}

SliceResult stream_slice_on(const SliceJob& job, const LayerSink& sink,
                            const SliceStreamOptions& options, const RunContext& context) {
  const Progress& progress = context.progress;
  const bool graded = job.strategy == 1 || job.strategy == 2;
  // A prime tower (Strategy 1 in face order, tool changers) is placed and sized from every layer,
  // and a tool changer's mixtures are made the tools' after it: the planned layers go to a
  // temporary file first (the tower observes each), then are read back in order with the tower and
  // the tools' mixtures added (tower::PrimeTower), and only then handed to the sink.
  const bool tower_step = graded && graded_tower(job);
  SliceResult r;
  r.streamed = true;
  const auto t0 = std::chrono::steady_clock::now();
  const SlicedDesign d = open_design(job, r, context, false);
  if (graded) require_graded_design(job, is_field_design(job.input), d.field);
  int quantized_from = 0;
  const FgmOptions fo =
      graded ? graded_options(job, static_cast<int>(d.field.materials().size()), &quantized_from)
             : FgmOptions{};
  std::optional<LayerSpill> held;
  std::optional<tower::PrimeTower> tower;
  if (tower_step) held.emplace(), tower.emplace(fo, job.purge);
  // Process fields (fprocess): each layer split where a value changes and the written values
  // counted in print order, after the tower (its paths take the field too), as the whole run's
  // apply_slice_process.
  std::optional<ProcessPass> process;
  if (d.field.has_process()) process.emplace(d.field, job.process);
  double error_sum = 0;
  int last_colour = -1;
  std::vector<double> last_mixture;
  std::set<std::vector<double>> colours_used;
  std::map<std::vector<double>, int> colour_of_mixture;
  if (graded) {
    r.fgm.shortest_path = std::numeric_limits<double>::infinity();
    r.fgm.min_segment = fo.min_segment;
    for (int k = 0; k < fo.palette.colors; ++k) colour_of_mixture.emplace(fo.palette.mixture(k), k);
  }
  // (Not a structured binding: clang 14, which builds the fuzz targets, cannot capture one.)
  const std::pair<std::size_t, std::size_t> planes = printed_planes(d, job, r, context);
  const std::size_t first = planes.first, n = planes.second - planes.first;
  r.part_layers = n;
  r.layers = n;
  // Process fields on a run of layers in print order: each layer's outline plane is part layer
  // g's, printed at (g + 1) h.
  const auto process_layers = [&](std::vector<Layer>& run) {
    std::vector<Layer*> ptrs;
    std::vector<double> dz;
    for (std::size_t i = 0; i < run.size(); ++i) {
      const long g = std::lround(run[i].z / job.planar.layer_height) - 1;
      const std::size_t plane =
          first + static_cast<std::size_t>(std::clamp<long>(g, 0, static_cast<long>(n) - 1));
      ptrs.push_back(&run[i]);
      dz.push_back(d.zs[plane] - run[i].z);
    }
    naming_design(job, [&] { process->layers(ptrs, dz); });
  };
  // The gradient error, summed layer by layer in print order. With the writer's mixing
  // look-ahead (no tower), the layers holding the first job.lookahead mm of path are kept until
  // the path passes it, then measured with their mixtures as deposited (deposit_start_mixtures),
  // as run_slice measures the whole toolpath.
  const auto add_error = [&](const GradientErrorSum& a) {
    error_sum += a.sum;
    r.fgm.error_max = std::max(r.fgm.error_max, a.max);
    r.fgm.error_samples += a.n;
    r.fgm.error_length += a.length;
  };
  std::optional<Toolpath> early;
  std::vector<double> early_z;
  double early_length = 0;
  if (graded && job.lookahead > 0 && !graded_tower(job)) {
    early.emplace();
    r.fgm.error_lookahead = job.lookahead;
  }
  const auto flush_early = [&] {
    deposit_start_mixtures(*early, job.lookahead);
    Evaluator ev(d.field);
    for (std::size_t i = 0; i < early->layers.size(); ++i)
      if (!std::isnan(early_z[i]))
        naming_design(job,
                      [&] { add_error(layer_gradient_error(ev, early->layers[i], early_z[i])); });
    early.reset();
  };
  // (Not a structured binding: the pipeline's lambdas capture them.)
  const std::pair<std::size_t, std::size_t> margins = skin_margins(job);
  const std::size_t below = margins.first, above = margins.second;
  const std::size_t chunk = std::max<std::size_t>(1, options.chunk_layers);
  const std::size_t chunks = (n + chunk - 1) / chunk;
  const std::size_t tokens =
      options.tokens
          ? options.tokens
          : 2 * static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  // Outlines of a run of planes [a, b) of the part.
  struct Outlined {
    std::size_t a = 0, b = 0;
    std::vector<LayerOutline> outlines;  // graded
    // Planar: each outline simplified (the planar slicer's outline), its plane and area.
    std::vector<SkinWindows::Ptr> simplified;
    std::vector<double> planes, areas;
    SliceStats stats;
    double seconds = 0;
  };
  // Layers [a, b) to plan, with the outlines of part layers [lo, …) around them that their skins
  // read (bottom_layers below, top_layers above, within the part).
  struct Planned {
    std::size_t a = 0, b = 0, lo = 0;
    std::vector<LayerOutline> window;     // graded
    std::vector<PlanarLayerInput> input;  // planar
    Toolpath toolpath;
    PlanarStats stats;
    FgmStats fgm;                         // graded
    std::vector<GradientErrorSum> error;  // graded: per toolpath layer
    std::vector<double> error_z;          // the design plane each was measured at (NaN: none)
    double seconds = 0;
  };
  // Part layers [window_start, received): graded, the outlines; planar, the simplified outlines
  // (what skins read under and over them is in `skins`, each window intersected once).
  std::deque<LayerOutline> window;
  std::deque<std::pair<double, SkinWindows::Ptr>> planar;
  std::optional<SkinWindows> skins;
  if (!graded) skins.emplace(n, job.planar.bottom_layers, job.planar.top_layers);
  std::size_t window_start = 0, received = 0, next_plan = 0, next_chunk = 0, written = 0;
  double outline_cpu = 0, plan_cpu = 0;
  std::optional<Vec3> last_point;
  const auto add_travel = [&](const Layer& layer) {
    for (const Path& path : layer.paths) {
      if (path.points.empty()) continue;
      if (last_point) {
        const double dd = travel_into(*last_point, path);
        if (dd > 1e-9) ++r.travel.moves, r.travel.length += dd;
      }
      last_point = path.points.back();
    }
  };
  auto clock = [] { return std::chrono::steady_clock::now(); };
  tbb::parallel_pipeline(
      tokens,
      tbb::make_filter<void, Outlined>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control&
                                                                                  fc) {
        Outlined o;
        if (next_chunk == chunks) {
          fc.stop();
          return o;
        }
        progress.check("slicing");
        o.a = next_chunk * chunk;
        o.b = std::min(n, o.a + chunk);
        ++next_chunk;
        return o;
      }) & tbb::make_filter<Outlined, Outlined>(tbb::filter_mode::parallel, [&](Outlined o) {
        const auto t = clock();
        o.outlines = outlines_at(d, job, r,
                                 std::vector<double>(d.zs.begin() + static_cast<long>(first + o.a),
                                                     d.zs.begin() + static_cast<long>(first + o.b)),
                                 &o.stats, RunContext{});
        if (!graded) {
          // Simplified here, in parallel, once a layer (not again by each run that reads it).
          const double tol = job.planar.simplify;
          for (auto& l : o.outlines) {
            o.areas.push_back(area(l.regions));
            o.planes.push_back(l.z);
            o.simplified.push_back(std::make_shared<const Regions>(
                tol > 0 ? simplify(l.regions, tol) : std::move(l.regions)));
          }
          o.outlines.clear();
        }
        o.seconds = seconds_since(t);
        return o;
      }) & tbb::make_filter<Outlined, Planned>(tbb::filter_mode::serial_in_order, [&](Outlined o) {
        outline_cpu += o.seconds;
        r.field_stats.samples += o.stats.samples;
        r.field_stats.blocks += o.stats.blocks;
        r.field_stats.skipped_blocks += o.stats.skipped_blocks;
        for (auto& l : o.outlines) {
          r.outline_area += area(l.regions);
          r.empty_layers += l.regions.empty() ? 1 : 0;
          window.push_back(std::move(l));
        }
        for (std::size_t k = 0; k < o.simplified.size(); ++k) {
          r.outline_area += o.areas[k];
          r.empty_layers += o.simplified[k]->empty() ? 1 : 0;
          planar.emplace_back(o.planes[k], o.simplified[k]);
        }
        if (skins) skins->add(o.simplified);
        received = o.b;
        // Layer j is ready when the outlines up to j + top_layers are in (or all are).
        const std::size_t ready = received == n ? n : (received > above ? received - above : 0);
        Planned p;
        p.a = next_plan;
        // (Runs of at least plan_layers: fewer, larger runs in flight.)
        const bool run_ready = ready == n || ready >= next_plan + options.plan_layers;
        p.b = run_ready ? std::max(next_plan, ready) : next_plan;
        if (p.a < p.b) {
          p.lo = p.a >= below ? p.a - below : 0;
          const std::size_t hi = std::min(n, p.b + above);
          if (graded) {
            for (std::size_t k = p.lo; k < hi; ++k) p.window.push_back(window[k - window_start]);
          } else {
            for (std::size_t k = p.a; k < p.b; ++k) {
              const auto& [plane, outline] = planar[k - window_start];
              p.input.push_back({k, plane, outline, skins->under(k), skins->over(k)});
            }
            skins->forget_before(p.b);
          }
          next_plan = p.b;
          // The next batch starts at next_plan and reads below_layers under it (graded; the
          // planar slicer reads the windows).
          const std::size_t keep = !graded ? next_plan : next_plan >= below ? next_plan - below : 0;
          while (window_start < keep) {
            if (graded)
              window.pop_front();
            else
              planar.pop_front();
            ++window_start;
          }
        }
        return p;
      }) & tbb::make_filter<Planned, Planned>(tbb::filter_mode::parallel, [&](Planned p) {
        if (p.a == p.b) return p;
        const auto t = clock();
        PlanarOptions po = planar_options(job, r);
        po.first_index = p.lo;
        po.plan_begin = p.a;
        po.plan_end = p.b;
        if (graded) {
          FgmOptions o = fo;
          o.first_layer = p.lo;
          naming_design(job, [&] {
            if (job.strategy == 2) {
              p.toolpath = plan_fgm_strategy2(d.field, p.window, o, &p.fgm);
            } else {
              const Toolpath planar = plan_planar(p.window, po, &p.stats);
              p.toolpath = plan_fgm_strategy1(d.field, p.window, planar, o, PurgeOptions{}, &p.fgm);
            }
          });
          // The error of what is printed: a tool changer's nearest tool (finish_graded).
          Toolpath mixed;
          if (job.tools > 1) {
            mixed = p.toolpath;
            for (Layer& l : mixed.layers) tool_mixtures(job, l);
          }
          naming_design(job, [&] {
            p.error = gradient_error_sums(d.field, job.tools > 1 ? mixed : p.toolpath, p.window,
                                          job.planar.layer_height, p.lo);
          });
          for (const Layer& l : p.toolpath.layers) {
            const auto idx =
                static_cast<std::size_t>(std::llround(l.z / job.planar.layer_height)) - 1 - p.lo;
            p.error_z.push_back(idx < p.window.size() ? p.window[idx].z : std::nan(""));
          }
        } else {
          p.toolpath = plan_planar_layers(p.input, po, &p.stats);
        }
        p.window.clear();
        p.window.shrink_to_fit();
        p.input.clear();
        p.input.shrink_to_fit();
        p.seconds = seconds_since(t);
        return p;
      }) & tbb::make_filter<Planned, void>(tbb::filter_mode::serial_in_order, [&](Planned p) {
        plan_cpu += p.seconds;
        r.planar.layers += p.stats.layers;
        if (!graded) r.planar.paths += p.stats.paths;  // (graded: count_graded_path)
        r.planar.walls += p.stats.walls;
        r.planar.skin_lines += p.stats.skin_lines;
        r.planar.infill_lines += p.stats.infill_lines;
        r.planar.link.add(p.stats.link);
        r.planar.lattice_trails += p.stats.lattice_trails;
        r.planar.lattice_trail_bound += p.stats.lattice_trail_bound;
        r.planar.layer_seconds += p.stats.layer_seconds;
        r.planar.link_seconds += p.stats.link_seconds;
        r.planar.layer_link.insert(r.planar.layer_link.end(), p.stats.layer_link.begin(),
                                   p.stats.layer_link.end());
        if (graded) {
          // As plan_fgm_strategy2 and measure_gradient_error sum them over the whole print.
          r.fgm.faces += p.fgm.faces;
          r.fgm.short_merged += p.fgm.short_merged;
          r.fgm.short_kept += p.fgm.short_kept;
          r.fgm.short_kept_bound += p.fgm.short_kept_bound;
          r.fgm.short_beads += p.fgm.short_beads;
          for (const Layer& layer : p.toolpath.layers) {
            r.fgm.shortest_path = std::min(r.fgm.shortest_path, shortest_piece(layer));
            for (const Path& path : layer.paths) {
              // The palette colour whose mixture the path prints (plan_fgm_strategy2 counts
              // changes of its faces' colours).
              const auto known = colour_of_mixture.find(path.mixture);
              const int colour = known != colour_of_mixture.end()
                                     ? known->second
                                     : fo.palette.color_of(path.mixture);
              if (colour != last_colour && last_colour >= 0) ++r.fgm.colour_changes;
              last_colour = colour;
              r.fgm.abrupt_changes += abrupt_start(last_mixture, path, fo.palette);
              last_mixture = path.mixture;
              r.fgm.joined += path.joined;
              ++r.fgm.paths;
              if (path.role != PathRole::Purge && !path.mixture.empty())
                colours_used.insert(path.mixture);
            }
          }
          for (std::size_t i = 0; i < p.error.size(); ++i) {
            if (!early) {
              add_error(p.error[i]);
              continue;
            }
            early->layers.push_back(p.toolpath.layers[i]);
            early_z.push_back(p.error_z[i]);
            for (const Path& path : p.toolpath.layers[i].paths)
              if (path.points.size() >= 2) early_length += path.length();
            if (early_length > job.lookahead) flush_early();
          }
        }
        if (held) {
          for (Layer& layer : p.toolpath.layers) {
            // Counted when read back with the tower (the travel goes through it).
            for (const Path& path : layer.paths) count_graded_path(path, r.planar);
            tower->observe(layer);
            held->append(layer);
            ++written;
          }
        } else {
          // Summed path by path in print order, as plan_planar sums it (before process fields
          // split the paths).
          for (const Layer& layer : p.toolpath.layers)
            for (const Path& path : layer.paths) {
              if (!graded)
                r.planar.extruded_length += path.length();
              else
                count_graded_path(path, r.planar);
            }
          if (process) process_layers(p.toolpath.layers);
          for (Layer& layer : p.toolpath.layers) {
            if (graded) add_colour_use(job, layer, r.colour_use);
            add_travel(layer);
            sink(written++, std::move(layer));
          }
        }
        if (progress.report) progress("layers", static_cast<double>(written) / double(n));
      }));
  if (early) flush_early();  // a print shorter than the look-ahead
  if (graded) {
    if (r.fgm.paths == 0) r.fgm.shortest_path = 0;
    r.fgm.error_mean = r.fgm.error_length > 0 ? error_sum / r.fgm.error_length : 0;
    r.fgm.materials = fo.palette.materials;
    r.fgm.band = fo.palette.band();
    r.fgm.quantized_from = quantized_from;
    r.fgm.colours_used = static_cast<int>(colours_used.size());
    r.fgm.colours_total = fo.palette.colors;
    r.fgm.error_bound = graded_error_bound(job, fo);
  }
  if (held) {
    // The tower's place and size from every layer, then each layer read back in order with its
    // tower step and the tools' mixtures, as finish_graded does on the whole toolpath.
    naming_design(job, [&] { tower->plan(r.fgm); });
    held->rewind();
    std::vector<Layer> run;  // a run of layers read back (process fields split a run at once)
    bool done = false;
    for (std::size_t i = 0; !done;) {
      progress.check("slicing");
      run.clear();
      Layer layer;
      while (run.size() < chunk && !(done = !held->next(layer))) {
        tower->add(i + run.size(), layer);
        tool_mixtures(job, layer);
        run.push_back(std::move(layer));
        layer = Layer{};
      }
      if (process && !run.empty()) process_layers(run);
      for (Layer& l : run) {
        add_colour_use(job, l, r.colour_use);
        add_travel(l);
        sink(i++, std::move(l));
      }
    }
    tower->finish(r.fgm);
  }
  if (process) {
    r.process = process->stats();
    check_process_temperature(job, r.process);
  }
  // Outlining and planning overlap: the wall time is shared out by their summed thread times.
  const double wall = seconds_since(t0), cpu = outline_cpu + plan_cpu;
  r.outline_seconds = cpu > 0 ? wall * outline_cpu / cpu : 0;
  r.plan_seconds = wall - r.outline_seconds;
  return r;
}

}  // namespace

SliceResult run_slice(const SliceJob& job, const RunContext& context) {
  SliceResult r;
  context.run([&] { r = run_slice_on(job, context); });
  return r;
}

SliceResult stream_slice(const SliceJob& job, const LayerSink& sink,
                         const SliceStreamOptions& options, const RunContext& context) {
  SliceResult r;
  context.run([&] { r = stream_slice_on(job, sink, options, context); });
  return r;
}

void add_colour_use(const SliceJob& job, const Layer& l,
                    std::map<std::vector<double>, std::pair<double, double>>& use) {
  for (const auto& p : l.paths) {
    if (p.role == PathRole::Purge || p.mixture.empty()) continue;
    const double len = p.length();
    const double speed = p.speed > 0 ? p.speed : job.purge.speed;
    auto& [length, time] = use[p.mixture];
    length += len;
    time += speed > 0 ? len / speed : 0;
  }
}

}  // namespace trellis
