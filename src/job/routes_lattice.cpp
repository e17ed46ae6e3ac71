// Lattice routes: 2D atlas, 3D cells and foams, planning (GIPPO / Euler / AERO with its
// independent collision check) and G-code from a toolpath.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <tuple>

#include "routes.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/analysis/pores.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/job/plate.hpp"
#include "trellis/job/reports.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::routes {

namespace fs = std::filesystem;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The struts as one path each in one layer: a picture of the design itself.
Toolpath strut_picture(const Graph& g) {
  Toolpath tp;
  tp.layers.emplace_back();
  if (!g.nodes.empty()) tp.layers[0].z = g.nodes.front().z;
  for (const auto& e : g.edges) {
    Path p;
    p.points = {g.nodes[e.a], g.nodes[e.b]};
    p.tool = e.material;
    tp.layers[0].paths.push_back(std::move(p));
  }
  return tp;
}

AtlasParams atlas_of(const Config& c, const Settings& st) {
  AtlasParams a = c.lattice2d;
  if (c.target_porosity > 0) {
    const char* scale = a.pattern == Pattern::Voronoi ? "lattice2d.density" : "lattice2d.cell";
    if (st.has(scale))
      throw SettingError(
          fmt::format("give {} or lattice2d.target_porosity, not both (the target sets it)", scale),
          {"", 0, "lattice2d.target_porosity"});
    a = tune_for_porosity(a, c.target_porosity, c.line_width);
  }
  if (!st.has("lattice2d.center")) a.region.center = corner_at_origin(a);
  return a;
}

HeightField onto_surface(const OntoConfig& o) {
  if (o.kind == OntoKind::SphereCap) return sphere_cap(o.radius, o.diameter);
  if (o.kind == OntoKind::Mesh) {
    if (o.file.empty())
      throw SettingError("onto.kind = mesh needs onto.file", {"", 0, "onto.file"});
    return HeightField::from_mesh(read_mesh(o.file), o.file);
  }
  if (o.domain.size() != 4 || o.height_fn.empty())
    throw SettingError("onto.kind = function needs onto.height_fn and onto.domain",
                       {"", 0, "onto.height_fn"});
  return HeightField::from_expression(
      o.height_fn, {{o.domain[0], o.domain[1]}, {o.domain[2], o.domain[3]}}, "z = " + o.height_fn);
}

// GIPPO parts: layer i at z = i·h, rotated by i·rotation, cropped to the solid's section.
// Only layers [from, to) are made (a shard's); `sections` (when given) gets every layer's
// section area of the solid (1 without a solid, 0 where the layer misses it: no layer there)
// and `edges` each made layer's strut count, both over all layers.
Graph layered_lattice(AtlasParams base, const Config& c, int from = 0, int to = INT_MAX,
                      std::vector<double>* sections = nullptr,
                      std::vector<std::size_t>* edges = nullptr) {
  Graph all;
  TriangleMesh solid;
  BBox3 box;
  int count = c.layers.count;
  const double h = c.machine.layer_height;
  if (!c.layers.solid.empty()) {
    solid = read_mesh(c.layers.solid);
    require_closed(solid, c.layers.solid);
    box = bounds(solid);
    // The layer rule (GIPPO paper: a 4 mm part in 0.148 mm layers prints 28 layers): every
    // started layer is printed, ceil(H / h); a layer is cropped to the solid's section at its
    // middle, or just below the top for a partial top layer.
    if (count <= 0) count = static_cast<int>(std::ceil((box.max.z - box.min.z) / h - 1e-9));
    if (count < 1) throw GeometryError("solid '" + c.layers.solid + "' is thinner than one layer");
  }
  if (count < 1)
    throw SettingError("layers.count must be >= 1 without layers.solid", {"", 0, "layers.count"});
  if (sections) sections->assign(static_cast<std::size_t>(count), 1.0);
  if (edges) edges->assign(static_cast<std::size_t>(count), 0);
  for (int i = 0; i < count; ++i) {
    AtlasParams a = base;
    a.rotation_deg += i * c.layers.rotation_deg;
    a.z = a.z + i * h;
    if (!c.layers.solid.empty()) {
      a.crop = slice_mesh(solid, trellis::solid_section_z(box, i, h));
      if (sections)
        (*sections)[static_cast<std::size_t>(i)] =
            a.crop.empty() ? 0.0 : std::max(area(a.crop), 1e-9);
      if (a.crop.empty()) continue;
      a.region.shape = RegionShape::Circle;
      a.region.center = {(box.min.x + box.max.x) / 2, (box.min.y + box.max.y) / 2};
      a.region.diameter =
          std::hypot(box.max.x - box.min.x, box.max.y - box.min.y) + 2 * a.cell_size;
    }
    if (i < from || i >= to) continue;
    const Graph layer = make_lattice2d(a);
    if (edges) (*edges)[static_cast<std::size_t>(i)] = layer.edges.size();
    const auto offset = static_cast<NodeId>(all.nodes.size());
    all.nodes.insert(all.nodes.end(), layer.nodes.begin(), layer.nodes.end());
    for (Edge e : layer.edges) {
      e.a += offset, e.b += offset;
      all.edges.push_back(e);
    }
  }
  return all;
}

// [layers] on an input lattice: a 2D lattice is printed layers.count times, layer i at z + i·h
// and turned by i·layers.rotation about the lattice's centre, as a pattern made in the job is.
// What cannot apply is refused: layers.solid (it crops a pattern made in the job) and layers on
// a 3D lattice.
Graph stacked_layers(Graph g, const Job& job, const Config& c) {
  const bool count = job.settings.has("layers.count") && c.layers.count != 1;
  const bool turned = job.settings.has("layers.rotation") && c.layers.rotation_deg != 0;
  if (!c.layers.solid.empty())
    throw SettingError(
        "layers.solid crops a pattern made in the job; the input lattice " + job.input +
            " is planned as it is (give the pattern's [lattice2d] settings instead of "
            "an input, or crop the lattice before)",
        {"", 0, "layers.solid"});
  if (!count && !turned) return g;
  const BBox3 b = g.bbox();
  if (g.nodes.empty() || b.max.z - b.min.z > 1e-9)
    throw SettingError("layers.count and layers.rotation stack a 2D lattice; " + job.input +
                           " is a 3D lattice (z " + fixed(b.min.z, 3) + " .. " + fixed(b.max.z, 3) +
                           " mm), planned as it is",
                       {"", 0, count ? "layers.count" : "layers.rotation"});
  if (c.layers.count < 1)
    throw SettingError("layers.count must be >= 1 without layers.solid", {"", 0, "layers.count"});
  if (turned && c.layers.count == 1)
    throw SettingError("layers.rotation turns each further layer, but layers.count is 1",
                       {"", 0, "layers.rotation"});
  const Vec3 centre{(b.min.x + b.max.x) / 2, (b.min.y + b.max.y) / 2, 0};
  Graph all;
  for (int i = 0; i < c.layers.count; ++i) {
    const double a = i * c.layers.rotation_deg * std::numbers::pi / 180;
    const double ca = std::cos(a), sa = std::sin(a);
    const auto offset = static_cast<NodeId>(all.nodes.size());
    for (const Vec3& p : g.nodes) {
      const double x = p.x - centre.x, y = p.y - centre.y;
      all.nodes.push_back({centre.x + ca * x - sa * y, centre.y + sa * x + ca * y,
                           p.z + i * c.machine.layer_height});
    }
    for (Edge e : g.edges) {
      e.a += offset, e.b += offset;
      all.edges.push_back(e);
    }
  }
  return all;
}

Graph cells_or_foam(const Config& c, Diagnostics& diag) {
  Graph g;
  if (c.lattice3d.kind == Lattice3dKind::Conformal) {
    ConformalParams p = c.lattice3d.conformal;
    p.mesh = c.lattice3d.foam.mesh;
    if (p.mesh.empty())
      throw SettingError("a conformal lattice needs lattice3d.mesh (a mesh file)",
                         {"", 0, "lattice3d.mesh"});
    p.cell = c.lattice3d.cells.cell;
    p.size = c.lattice3d.cells.size;
    p.seed = c.lattice3d.foam.seed;
    g = conformal_lattice(p, diag);
  } else {
    g = c.lattice3d.kind == Lattice3dKind::Foam ? voronoi_foam(c.lattice3d.foam, diag)
                                                : cell_lattice(c.lattice3d.cells);
  }
  assign_materials(g, c.lattice3d.materials);
  return g;
}

JobResult plan_aero_route(const Job& job, const Config& c, const Graph& g, const std::string& input,
                          const RunContext& context, std::chrono::steady_clock::time_point t0,
                          JobResult out) {
  Diagnostics& diag = *context.diagnostics;
  require_bath(job, c.machine, "plan aero",
               "AERO trails are printed inside a support bath (the "
               "AERO paper's embedded printing)");
  const AeroParams& p = c.aero;
  const AeroResult r = plan_aero(g, p, diag, context);
  Toolpath tp = aero_toolpath(g, r, "trellis " + job.route + " aero " + input);
  // The independent check sees the struts as printed (ends pushed past their nodes by the
  // overlap, as the embedded writer does).
  CheckOptions check;
  check.nozzle = p.nozzle;
  check.snap = p.nozzle.end_overlap + kNodeSnap;
  check.budget = context.budget;
  Toolpath printed = tp;
  for (auto& l : printed.layers)
    for (auto& path : l.paths) extend_path_ends(path, p.nozzle.end_overlap);
  const CollisionCheck chk = check_collisions(g, printed, check);
  if (p.collisions && chk.collisions != r.collisions_planned)
    diag.warn("collision_count_mismatch",
              fmt::format("the independent check finds {} collision(s), the plan counts {}",
                          chk.collisions, r.collisions_planned));
  out.toolpath = std::make_shared<Toolpath>(tp);
  out.lattice = std::make_shared<Graph>(g);
  out.geometry.struts = out.lattice;  // a 3MF's build item: the struts as beams
  const double secs = seconds_since(t0);
  // G-code first: the machine check refuses before any file is written.
  if (!job.gcode.empty()) write_gcode_out(job.gcode, tp, job, c.machine, out, diag);
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, tp, job);
    out.files.push_back(job.toolpath);
  }
  if (!job.report.empty()) {
    AeroReportInput in{input, g.nodes.size(), g.edges.size(), secs};
    in.checked_collisions = static_cast<long long>(chk.collisions);
    in.checked_once = chk.printed_once == g.edges.size() && chk.repeated.empty();
    write_file_atomic(job.report, with_job(aero_report_json(r, p, diag, in), job, job.report));
    out.files.push_back(job.report);
  }
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    View3dOptions v;
    v.size_px = c.output.image_size;
    for (const auto& h : chk.hits) v.marks.push_back(h.point);
    v.title = std::to_string(r.trails.trails.size()) + " trails, " +
              std::to_string(chk.collisions) + " collisions (" +
              fs::path(input).filename().string() + ")";
    out.files.push_back(preview_name(job.preview, "3d.png"));
    render_3d_png(tp, out.files.back(), v);
    const auto frames =
        std::min<std::size_t>(static_cast<std::size_t>(c.output.frames), r.trails.trails.size());
    for (std::size_t k = 1; k <= frames; ++k) {
      View3dOptions f;
      f.size_px = c.output.image_size;
      f.upto = k;
      f.title = "step " + std::to_string(k) + " of " + std::to_string(r.trails.trails.size());
      out.files.push_back(preview_name(job.preview, fmt::format("step_{:04}.png", k)));
      render_3d_png(tp, out.files.back(), f);
    }
  }
  out.summary = fmt::format(
      "aero {}: {} struts, {} groups, {} trails (lower bound {}), longest {} struts, travel {} "
      "moves / {} mm, collisions {} (checked; planned {}, lower bound {}{}), {} s",
      to_string(p.method), g.edges.size(), r.groups, r.trails.trails.size(), r.lower_bound_trails,
      r.max_trail_edges, r.travel_moves, fixed(r.travel_length, 1), chk.collisions,
      r.collisions_planned, r.collisions_lower_bound,
      r.collisions_proven_minimal() ? ", proven minimal" : "", fixed(secs, 3));
  return out;
}

// `--shard` on the plan route, before any work: what does not shard is refused (exit 2), saying
// why and what does (docs/plates.md).
void check_plan_shard(const Job& job, const Config& c) {
  if (c.planner == LatticePlanner::Aero)
    throw SettingError(
        "the plan route does not shard with the aero planner: AERO plans the whole 3D lattice as "
        "one problem (which struts obstruct which under the nozzle, between separate pieces of the "
        "lattice too; the order breaking obstruction cycles with the fewest collisions; the best "
        "of several planner runs by collisions, trails and travel over the whole lattice), so "
        "neither its layers nor its connected parts plan alone (docs/plates.md)",
        {"", 0, "--shard"});
  if (job.gcode.empty())
    throw SettingError(
        "a shard of the plan route holds layers of its G-code: the job needs a machine "
        "(job.machine) and output.gcode = true",
        {"", 0, "--shard"});
}

// A planned lattice's design as a 3MF's build item: the struts as beams where the toolpath prints
// them as they lie, the surface printed on (an open "surface" object, meshed at half the bead
// width as the nonplanar route's) where onto.* lays them on one.
void plan_geometry(const Config& c, std::shared_ptr<const Graph> lattice, JobResult& out) {
  if (c.onto.kind == OntoKind::Flat) {
    out.geometry.struts = std::move(lattice);
    return;
  }
  out.geometry.mesh = std::make_shared<const TriangleMesh>(
      surface_mesh(onto_surface(c.onto), c.machine.nozzle_diameter / 2));
  out.geometry.surface = true;
}

// The lattice an euler or gippo plan of `job` prints (its input's, or the pattern it makes),
// for a merge's 3MF: as the single run makes it before planning.
std::shared_ptr<const Graph> planned_lattice(const Job& job, const Config& c) {
  Diagnostics said;  // (the shards' to give)
  if (job.input.empty() && c.planner == LatticePlanner::Aero)
    return std::make_shared<const Graph>(cells_or_foam(c, said));
  if (!job.input.empty())
    return std::make_shared<const Graph>(
        stacked_layers(read_lattice(job.input, c.clean_options(), said), job, c));
  AtlasParams a = atlas_of(c, job.settings);
  if (c.onto.kind != OntoKind::Flat && !job.settings.has("lattice2d.center")) {
    const BBox2 b = onto_surface(c.onto).domain();
    a.region.center = {(b.min.x + b.max.x) / 2, (b.min.y + b.max.y) / 2};
  }
  return std::make_shared<const Graph>(layered_lattice(a, c));
}

// The design of a toolpath JSON that `trellis gcode` writes as a 3MF, from the job it embeds:
// a plan's lattice or surface (plan_geometry), a sliced part's or the surface a nonplanar route
// printed on (the routes' own, routes_slice.cpp). A toolpath without a job keeps its beads; one
// whose design cannot be read again (moved, changed) too, said.
void toolpath_design(const std::string& input, JobResult& out, Diagnostics& diag) {
  try {
    Job made;
    try {
      made = job_from_output(input);
    } catch (const ParseError& e) {
      // No job (a toolpath of another tool's, or planned in Python): the beads printed are its
      // geometry.
      if (std::string(e.what()).find("no Trellis job") != std::string::npos) return;
      throw;
    }
    const RouteSpec& spec = route_spec(made.route);
    if (spec.design) spec.design(made, made.settings.config(), out);
  } catch (const Error& e) {
    out.geometry = {};
    diag.warn("design_not_read",
              fmt::format("{}: the design of the job it embeds could not be read again ({}); the "
                          "3MF's build items are the beads printed",
                          input, e.what()));
  }
}

}  // namespace

void plan_design(const Job& job, const Config& c, JobResult& out) {
  plan_geometry(c, planned_lattice(job, c), out);
}

void write_plan_main(const Job& job, const Config& c, const Toolpath& tp, JobResult& out,
                     Diagnostics& diag, GcodeStats* stats) {
  if (job.gcode.empty()) return;
  if (c.onto.kind == OntoKind::Flat)
    note_planar_in_bath(c.machine, "plan " + to_string(c.planner), diag);
  const GcodeStats gs = write_gcode_out(job.gcode, tp, job, c.machine, out, diag);
  if (stats) *stats = gs;
}

void merge_plan_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out,
                     Diagnostics& diag) {
  PlanParams p = c.plan;
  p.layer_height = c.machine.layer_height;
  if (layers_carry_start(p)) {
    // The travel order the shards left to the merge (plan_lattice's defer_order), then the
    // surface, as the single run does after planning.
    order_deferred_layers(tp, p);
    if (c.onto.kind != OntoKind::Flat) {
      const std::string source = tp.source;
      tp = project_onto_surface(tp, onto_surface(c.onto), c.onto.project);
      tp.source = source;
    }
  }
  // The design as the single run's 3MF carries it.
  if (is_3mf_output(job.gcode) && !out.geometry.struts && !out.geometry.mesh)
    plan_geometry(c, c.onto.kind == OntoKind::Flat ? planned_lattice(job, c) : nullptr, out);
  write_plan_main(job, c, tp, out, diag);
}

JobResult lattice2d(const Job& job, const Config& c, const RunContext& context) {
  JobResult out;
  const AtlasParams a = atlas_of(c, job.settings);
  check_budget(estimate_lattice2d(a, 1), context.budget);
  const Graph g = make_lattice2d(a);
  if (!job.output.empty()) {
    write_file_atomic(job.output, with_job(lattice_to_json(g), job, job.output, false));
    out.files.push_back(job.output);
  }
  out.lattice = std::make_shared<Graph>(g);
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    RenderOptions ro;
    ro.travel = false, ro.starts = false, ro.size_px = c.output.image_size;
    out.files.push_back(preview_name(job.preview, "layer_0000.png"));
    render_layer_png(strut_picture(g), 0, out.files.back(), ro);
  }
  const PoreArea pores = pore_area(g, c.line_width);
  const double surface =
      surface_pore_percent(g, c.line_width, a.crop.empty() ? Regions{a.region.polygon()} : a.crop);
  const std::string tuned = a.pattern == Pattern::Voronoi
                                ? fmt::format("density {} seeds/mm²", fixed(a.voronoi_density, 4))
                                : fmt::format("cell {} mm", fixed(a.cell_size, 4));
  out.summary = fmt::format(
      "lattice: {}, {} nodes, {} edges, {} mm of struts, lower bound {} paths, pore area {}% ({} "
      "pores at {} mm lines), {}% of the region{}",
      to_string(a.pattern), g.nodes.size(), g.edges.size(), fixed(g.total_length(), 1),
      lower_bound_paths(g), fixed(pores.percent(), 1), pores.count, fixed(c.line_width, 2),
      fixed(surface, 1),
      c.target_porosity > 0
          ? fmt::format("; {} for {}% of the region", tuned, fixed(c.target_porosity, 1))
          : std::string());
  return out;
}

JobResult lattice3d(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult out;
  if (!c.lattice3d.foam.mesh.empty())
    check_budget(mesh_read_estimate(c.lattice3d.foam.mesh), context.budget);
  check_budget(estimate_lattice3d(c), context.budget);
  const Graph g = cells_or_foam(c, diag);
  if (fs::path(job.output).extension() == ".3mf") {
    // A 3MF beam lattice (no room for the job: it is not a file `rerun` can regenerate).
    write_lattice(job.output, g, c.lattice3d.radius);
    out.files.push_back(job.output);
  } else if (!job.output.empty()) {
    write_file_atomic(job.output, with_job(lattice_to_json(g), job, job.output, false));
    out.files.push_back(job.output);
  }
  out.lattice = std::make_shared<Graph>(g);
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    View3dOptions v;
    v.travel = false;
    v.size_px = c.output.image_size;
    v.title = std::to_string(g.edges.size()) + " struts";
    out.files.push_back(preview_name(job.preview, "3d.png"));
    render_3d_png(strut_picture(g), out.files.back(), v);
  }
  int materials = 0;
  for (const auto& e : g.edges) materials = std::max(materials, e.material + 1);
  const BBox3 b = g.bbox();
  out.summary =
      fmt::format("{}: {} nodes, {} struts, {} material(s), {} x {} x {} mm",
                  c.lattice3d.kind == Lattice3dKind::Cells ? to_string(c.lattice3d.cells.cell)
                                                           : to_string(c.lattice3d.kind),
                  g.nodes.size(), g.edges.size(), materials, fixed(b.max.x - b.min.x, 2),
                  fixed(b.max.y - b.min.y, 2), fixed(b.max.z - b.min.z, 2));
  return out;
}

JobResult plan(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  const Progress& progress = context.progress;
  const auto t0 = std::chrono::steady_clock::now();
  JobResult out;
  if (job.shards) check_plan_shard(job, c);
  Graph g;
  std::string input = job.input;
  // A shard of a made lattice (below): the layers that print (indices into layers.count), the
  // shard's range of them and the lattice's z; `made` empty otherwise.
  std::vector<int> made;
  std::size_t made_first = 0, made_end = 0;
  double made_z0 = 0;
  HeightField surface;
  if (c.onto.kind != OntoKind::Flat) surface = onto_surface(c.onto);
  if (!job.input.empty()) {
    g = read_lattice(job.input, c.clean_options(), diag);
    g = stacked_layers(std::move(g), job, c);
  } else if (c.planner == LatticePlanner::Aero) {
    if (!c.lattice3d.foam.mesh.empty())
      check_budget(mesh_read_estimate(c.lattice3d.foam.mesh), context.budget);
    check_budget(estimate_lattice3d(c), context.budget);
    g = cells_or_foam(c, diag);
    input = "lattice3d";
  } else {
    progress("lattice", 0);
    AtlasParams a = atlas_of(c, job.settings);
    if (c.onto.kind != OntoKind::Flat && !job.settings.has("lattice2d.center")) {
      const BBox2 b = surface.domain();
      a.region.center = {(b.min.x + b.max.x) / 2, (b.min.y + b.max.y) / 2};
    }
    const Estimate lattice = estimate_lattice2d(a, std::max(1, c.layers.count));
    check_budget(lattice, context.budget);
    // The planner's work too, before the lattice is made (about one edge per cell unit); the
    // exact check follows once the lattice is there.
    if (c.planner == LatticePlanner::Gippo)
      check_budget(estimate_gippo(static_cast<std::size_t>(lattice.bytes / 1e4),
                                  c.plan.gippo.iterations, c.gippo_seeds),
                   context.budget);
    if (job.shards && c.planner != LatticePlanner::Aero && c.plan.order != PathOrder::Travel) {
      // A shard of a made lattice makes only its own layers: which layers print comes from the
      // solid's sections alone (cheap), the work per layer from their areas. Every layer with
      // a section must hold struts for that count to be the plan's; each shard checks its own.
      std::vector<double> sections;
      layered_lattice(a, c, 0, 0, &sections);
      std::vector<double> work;
      for (std::size_t i = 0; i < sections.size(); ++i)
        if (sections[i] > 0) made.push_back(static_cast<int>(i)), work.push_back(sections[i]);
      if (made.empty()) throw GeometryError("the lattice has no edges to plan");
      std::tie(made_first, made_end) = shard_range(work, job.shard, job.shards);
      std::vector<std::size_t> edges;
      if (made_first < made_end)
        g = layered_lattice(a, c, made[made_first], made[made_end - 1] + 1, nullptr, &edges);
      for (std::size_t k = made_first; k < made_end; ++k)
        if (edges[static_cast<std::size_t>(made[k])] == 0)
          throw GeometryError(
              fmt::format("layer {} (z = {} mm) has a section of the solid but no struts of the {} "
                          "pattern in it, so a shard cannot count the plan's layers without making "
                          "them all: this job does not shard by layer (run it whole, or set "
                          "lattice2d.contour = true so every section prints)",
                          made[k], a.z + made[k] * c.machine.layer_height, to_string(a.pattern)),
              {c.layers.solid, 0, "layers.solid"});
      made_z0 = a.z;
    } else {
      g = layered_lattice(a, c);
    }
    input = "atlas:" + to_string(a.pattern);
  }
  if (!job.lattice.empty() && !job.shards) {
    write_lattice(job.lattice, g);
    out.files.push_back(job.lattice);
  }
  if (c.planner == LatticePlanner::Aero) {
    const int tries =
        c.aero.tries > 0 ? c.aero.tries : static_cast<int>(aero_auto_tries(g.edges.size()));
    check_budget(estimate_aero(g.edges.size(), tries), context.budget);
    return plan_aero_route(job, c, g, input, context, t0, out);
  }
  if (c.planner == LatticePlanner::Gippo)
    check_budget(estimate_gippo(g.edges.size(), c.plan.gippo.iterations, c.gippo_seeds),
                 context.budget);

  PlanParams p = c.plan;
  p.planner = c.planner == LatticePlanner::Euler ? Planner::Euler : Planner::Gippo;
  p.layer_height = c.machine.layer_height;
  // A shard (`--shard K/N`) plans the toolpath layers [a, b), balanced by their edges; the other
  // layers stay empty at their z (the surface projection offsets layer k by its index).
  std::size_t first = 0, end = 0, total = 0;
  if (!made.empty()) {
    // Only the shard's layers were made: planned whole, then put at their places.
    total = made.size(), first = made_first, end = made_end;
  } else if (job.shards) {
    const std::vector<double> work = plan_layer_work(g, p);
    total = work.size();
    std::tie(first, end) = shard_range(work, job.shard, job.shards);
    p.first_layer = first, p.end_layer = end;
    p.keep_worst = false;
    // The travel order starts where the layer below ended: the merge orders (and lays on the
    // surface) what the shards planned.
    p.defer_order = layers_carry_start(p);
  }
  PlanResult r;
  if (made.empty() || first < end) r = plan_lattice(g, p, diag, context);
  if (!made.empty()) {
    if (r.toolpath.layers.size() != end - first)
      throw Error(fmt::format("the shard's lattice has {} layers, it should have {}",
                              r.toolpath.layers.size(), end - first));
    // The layers below at their z (layer z = the lattice's z + the layer height, as planned), so
    // the surface projection offsets each layer as in the whole plan.
    std::vector<Layer> placed(first);
    for (std::size_t k = 0; k < first; ++k)
      placed[k].z = (made_z0 + made[k] * c.machine.layer_height) + p.layer_height;
    placed.insert(placed.end(), r.toolpath.layers.begin(), r.toolpath.layers.end());
    placed.resize(total);
    r.toolpath.layers = std::move(placed);
  }
  if (job.shards) {
    if (c.onto.kind != OntoKind::Flat && !p.defer_order)
      r.toolpath = project_onto_surface(r.toolpath, surface, c.onto.project);
    r.toolpath.source =
        "trellis " + to_string(c.planner) + " " + fs::path(input).filename().string();
    if (r.toolpath.layers.size() != total)
      throw Error(
          fmt::format("the plan has {} layers, its levels {}", r.toolpath.layers.size(), total));
    std::vector<Layer> mine(r.toolpath.layers.begin() + static_cast<std::ptrdiff_t>(first),
                            r.toolpath.layers.begin() + static_cast<std::ptrdiff_t>(end));
    std::size_t paths = 0;
    for (const auto& l : mine) paths += l.paths.size();
    Job named = job;
    named.output = job.gcode;  // the shard files are named after the G-code they make
    out.files.push_back(write_shard(named, mine, first, total, r.toolpath.source, {}));
    out.files.insert(out.files.begin(), out.files.back().substr(0, out.files.back().size() - 5));
    out.summary = fmt::format("shard {} of {}: layers {}..{} of {}, {} paths", job.shard,
                              job.shards, first, end, total, paths);
    return out;
  }
  std::string robustness;
  if (c.gippo_seeds > 0 && p.planner == Planner::Gippo) {
    // The paper's robustness run (Fig. 2 v-vi): the best score over many seeds.
    const GippoRobustness rob =
        gippo_robustness(g, p.gippo, c.gippo_seeds, p.long_path_nodes, context);
    robustness = gippo_robustness_json(rob, p.gippo);
    out.summary = fmt::format(
        "gippo robustness over {} seeds: best score mean {}, SD {} (CV {}%), min {}, max {}\n",
        c.gippo_seeds, fixed(rob.mean, 4), fixed(rob.sd, 4), fixed(rob.cv_percent(), 2),
        fixed(rob.min, 4), fixed(rob.max, 4));
  }
  if (c.onto.kind != OntoKind::Flat) {
    progress("surface", 0);
    r.toolpath = project_onto_surface(r.toolpath, surface, c.onto.project);
    r.travel = travel_stats(r.toolpath);
  }
  r.toolpath.source = "trellis " + to_string(c.planner) + " " + fs::path(input).filename().string();
  out.toolpath = std::make_shared<Toolpath>(r.toolpath);
  out.lattice = std::make_shared<Graph>(g);
  // A 3MF's build item: the struts as beams, or the surface they are laid on.
  if (is_3mf_output(job.gcode)) plan_geometry(c, out.lattice, out);
  const double secs = seconds_since(t0);
  GcodeStats gs;
  write_plan_main(job, c, r.toolpath, out, diag, &gs);
  if (!job.toolpath.empty()) {
    write_toolpath_with_job(job.toolpath, r.toolpath, job);
    out.files.push_back(job.toolpath);
  }
  // The lowest-score GIPPO solution beside the best (gippo.worst).
  const bool worst = p.keep_worst && !r.worst.layers.empty();
  if (worst && c.planner == LatticePlanner::Gippo && c.onto.kind != OntoKind::Flat)
    r.worst = project_onto_surface(r.worst, surface, c.onto.project);
  if (worst && !job.toolpath.empty()) {
    std::string name = job.toolpath;
    if (name.size() > 5 && name.compare(name.size() - 5, 5, ".json") == 0)
      name.resize(name.size() - 5);
    name += ".worst.json";
    r.worst.source = r.toolpath.source + " (lowest-score solution)";
    write_toolpath(name, r.worst);
    out.files.push_back(name);
  }
  if (!job.report.empty()) {
    std::string report = plan_report_json(r, p, diag, {input, g.nodes.size(), g.edges.size()});
    if (!robustness.empty()) report = with_field(report, "gippo_robustness", robustness);
    write_file_atomic(job.report, with_job(report, job, job.report, true, &diag));
    out.files.push_back(job.report);
  }
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    RenderOptions ro;
    ro.size_px = c.output.image_size;
    ro.bead_width = c.machine.nozzle_diameter;
    previews(r.toolpath, job.preview, c.output.preview_layers, ro, out);
    if (worst) previews(r.worst, job.preview, c.output.preview_layers, ro, out, "worst_layer_");
    if (c.onto.kind != OntoKind::Flat || !c.layers.solid.empty()) {
      View3dOptions v;
      v.size_px = c.output.image_size;
      v.title = job.name;
      out.files.push_back(preview_name(job.preview, "3d.png"));
      render_3d_png(r.toolpath, out.files.back(), v);
    }
    if (!r.layers.empty() && !r.layers.front().scores.empty()) {
      out.files.push_back(preview_name(job.preview, "scores.png"));
      render_scores_png(r.layers.front().scores, r.layers.front().best_iteration,
                        job.name + ": GIPPO score per iteration (layer 0)", out.files.back());
    }
  }
  out.summary += fmt::format(
      "{}: {} edges, {} layer(s), {} paths (lower bound {}), score {}, LTS {}%, OE {}%, travel {} "
      "moves / {} mm, {} s",
      to_string(c.planner), g.edges.size(), r.toolpath.layers.size(), r.total.paths,
      r.total.lower_bound_paths, fixed(r.total.score, 4), fixed(r.total.lts, 1),
      fixed(r.total.oe, 2), r.travel.moves, fixed(r.travel.length, 1), fixed(secs, 3));
  if (!job.gcode.empty())
    out.summary += fmt::format("\n{}: {} mm printed, ~{} min", to_string(c.machine.flavor),
                               fixed(gs.print_length, 1), fixed(gs.print_time_s / 60, 1));
  return out;
}

JobResult gcode(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult out;
  if (job.input.empty())
    throw SettingError("gcode needs a toolpath JSON to read", {"", 0, "job.input"});
  check_budget(estimate_gcode_of(job.input), context.budget);
  const Toolpath tp = read_toolpath(job.input);
  // The toolpath's bead heights were set when it was planned; say so when they are not the
  // machine's layer height (E follows the path's own height).
  for (const auto& l : tp.layers) {
    const auto odd = std::find_if(l.paths.begin(), l.paths.end(), [&](const Path& p) {
      return p.height > 0 &&
             std::abs(p.height - c.machine.layer_height) > 0.01 * c.machine.layer_height;
    });
    if (odd == l.paths.end()) continue;
    diag.warn(
        "layer_height_differs",
        fmt::format("the toolpath's bead height is {} mm but extrusion.layer_height is {} mm; E "
                    "follows the toolpath (plan with --machine to use the profile's)",
                    fixed(odd->height, 3), fixed(c.machine.layer_height, 3)));
    break;
  }
  if (is_3mf_output(job.output)) toolpath_design(job.input, out, diag);
  GcodeStats s;
  s = write_gcode_out(job.output, tp, job, c.machine, out, diag);
  out.toolpath = std::make_shared<Toolpath>(tp);
  out.summary = fmt::format(
      "{}: {} paths, {} mm printed, {} travel moves ({} mm), {} retractions, {}{} mm filament, "
      "~{} min, {} bytes",
      to_string(c.machine.flavor), s.paths, fixed(s.print_length, 1), s.travel_moves,
      fixed(s.travel_length, 1), s.retractions,
      s.tool_changes ? std::to_string(s.tool_changes) + " tool changes, " : "",
      fixed(s.filament, 2), fixed(s.print_time_s / 60, 1), s.bytes);
  return out;
}

}  // namespace trellis::routes
