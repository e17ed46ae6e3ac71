#include "trellis/slice/pbf.hpp"

#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numbers>

#include "pbf_internal.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/slice.hpp"

namespace trellis {

Field PbfDesign::part() const {
  if (phi.empty()) throw GeometryError("PBF design needs a mid-surface field");
  Field f = sheet(phi, c, thickness);
  if (!envelope.empty()) f = intersect({f, envelope});
  for (const BBox3& b : clip) f = clip_box(f, b.min, b.max);
  if (!solids.empty()) f = unite({f, solids});
  return f;
}

double pbf_split_c(double c, double inclination_deg, double min_inclination_deg) {
  const double w = std::clamp((inclination_deg - min_inclination_deg) / kSplitBand, 0.0, 1.0);
  return w * c;
}

double equivalent_length(double length, double melt_pool) {
  return length + 0.25 * std::numbers::pi * melt_pool;
}

namespace {

void check_options(const PbfOptions& o) {
  if (!(o.layer > 0)) throw SettingError("layer thickness must be > 0");
  if (!(o.resolution > 0)) throw SettingError("resolution must be > 0");
  if (o.coarse < 1 || o.coarse > 8) throw SettingError("coarse grid factor must be 1..8");
  if (!(o.segment_length > 0) || !std::isfinite(o.segment_length))
    throw SettingError("segment length SL must be > 0 mm");
  if (!(o.segment_gap >= 0) || !std::isfinite(o.segment_gap))
    throw SettingError("segment gap LHD must be >= 0 mm");
  if (!(o.hatch_distance > 0)) throw SettingError("hatch distance must be > 0");
  if (!(o.beam_compensation >= 0)) throw SettingError("beam compensation must be >= 0");
  if (!(o.melt_pool > 0)) throw SettingError("melt-pool width must be > 0");
}

// Settings outside the ranges the PBF paper tested, and a compensation that leaves joints
// without hatch.
void warn_untested(const PbfOptions& o, Diagnostics& d) {
  if (o.segment_length < 0.005 || o.segment_length > 0.4)
    d.warn("pbf.sl_untested", fmt::format("segment length SL = {} µm is outside the 5–400 µm the "
                                          "PBF paper tested",
                                          o.segment_length * 1e3));
  if (o.segment_gap > 0.12)
    d.warn("pbf.lhd_untested",
           fmt::format("segment gap LHD = {} µm is outside the 0–120 µm the PBF "
                       "paper tested",
                       o.segment_gap * 1e3));
  if (o.beam_compensation > 0 && o.beam_compensation >= 0.5 * o.thin_multiple * o.melt_pool)
    d.warn("pbf.beam_compensation_wide",
           fmt::format("beam compensation {} mm is at least half the widest thin "
                       "wall ({} mm): joints narrower than twice it get no hatch",
                       o.beam_compensation, o.thin_multiple * o.melt_pool));
}

// The run's memory estimate, reported to `progress` and refused over the budget.
void check_memory(const PbfDesign& design, const PbfOptions& o, std::size_t layers, bool sink,
                  const RunContext& context, PbfResult& result) {
  const Progress& progress = context.progress;
  // The threads the layers run on: the arena's, bounded by a global_control (run.threads).
  const int threads = static_cast<int>(std::min<std::size_t>(
      static_cast<std::size_t>(tbb::this_task_arena::max_concurrency()),
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
  result.memory_estimate = pbf_memory_estimate(design, o, threads, sink);
  if (progress.estimate)
    progress.estimate({result.memory_estimate, 0,
                       fmt::format("PBF paths of {} layers at resolution {} mm on {} thread(s)",
                                   layers, o.resolution, threads),
                       "pbf.resolution"});
  if (context.budget.force) return;
  const double budget = context.budget.memory > 0 ? context.budget.memory : default_memory_budget();
  if (budget > 0 && result.memory_estimate > budget)
    throw ResourceError(
        fmt::format(
            "refused before starting: this job needs about {:.0f} MB ({} threads at resolution "
            "{} "
            "mm, {} layers, estimate) but the memory budget is {:.0f} MB: raise the resolution "
            "(pbf.resolution), cut the part in build-height ranges, run fewer threads "
            "(run.threads) "
            "or raise the budget (run.max_memory in MB, or run.force)",
            result.memory_estimate / 1e6, threads, o.resolution, layers, budget / 1e6),
        {"", 0, "run.max_memory"});
}

// c as a constant or as its own field.
void sheet_parameter(pbf_detail::Plan& p) {
  const PbfDesign& design = p.design;
  const BBox3& e = p.extent;
  double& c_const = p.c_const;
  Field& c_field = p.c_field;
  if (design.thickness <= 0) {
    // c = 1/0 filled the box solid, sqrt(-1) sliced noise: a c that is not a finite number at
    // the part's centre is refused.
    const Vec3 centre = e.center();
    double at_centre = 0;
    if (!constant_expression(design.c.text, &c_const)) {
      c_field = expression_field(design.c);
      at_centre = Evaluator(c_field).value(centre);
    } else {
      at_centre = c_const;
    }
    if (!std::isfinite(at_centre))
      throw SettingError(
          fmt::format("the sheet parameter c = '{}' is {} at the part's centre "
                      "({:g}, {:g}, {:g}): it must be a finite number",
                      design.c.text, std::isnan(at_centre) ? "not a number" : "infinite", centre.x,
                      centre.y, centre.z),
          {"", 0, "pbf.c"});
  }
}

// A sheet nowhere as narrow as a thin wall has none: its horizontal width 2c / |∇xy φ| is at
// least 2c / max|∇φ| (φ's Lipschitz bound) with a constant c, and at least t with a uniform
// thickness t. Then the thin-wall measure is negative everywhere, and its march and the thin
// pieces of the mid-curve, which would find nothing, are skipped.
bool thin_walls_possible(const pbf_detail::Plan& p) {
  const PbfDesign& design = p.design;
  const PbfOptions& o = p.o;
  const double c_const = p.c_const;
  const Field& c_field = p.c_field;
  const double thin_width = o.thin_multiple * o.melt_pool;
  return o.split == PbfSplit::Inclination ? true
         : design.thickness > 0
             ? !(design.thickness > thin_width)
             : !c_field.empty() || !(thin_width * design.phi.lipschitz() < 2 * std::abs(c_const));
}

// The STL route: one marching-cubes mesh of the part, cut by planes.
void mesh_part(pbf_detail::Plan& p, PbfResult& result) {
  const PbfOptions& o = p.o;
  MeshingStats ms;
  BBox3 box = p.extent;
  p.mesh = field_to_mesh(p.part, box, o.resolution, &ms);
  result.mesh_triangles = p.mesh.triangles.size();
  if (!o.test.stl_scan_all)
    p.buckets = triangles_by_plane(p.mesh, p.zs);  // each layer: the triangles it cuts
  result.mesh_bytes = ms.mesh_bytes;
  result.grid_bytes = ms.grid_bytes;
}

bool finite_box(const BBox3& e) {
  return !e.empty() && std::isfinite(e.min.x) && std::isfinite(e.max.x) && std::isfinite(e.min.y) &&
         std::isfinite(e.max.y) && std::isfinite(e.min.z) && std::isfinite(e.max.z);
}

PbfResult plan_pbf_on(const PbfDesign& design, const PbfOptions& o, const PbfLayerSink& sink,
                      PbfLayerRange range, const RunContext& context);

}  // namespace

PbfResult plan_pbf(const PbfDesign& design, const PbfOptions& o, const RunContext& context) {
  return plan_pbf(design, o, PbfLayerSink{}, PbfLayerRange{}, context);
}

std::size_t pbf_layer_count(const PbfDesign& design, const PbfOptions& o) {
  if (!(o.layer > 0)) throw SettingError("layer thickness must be > 0");
  const BBox3 e = design.part().extent();
  if (e.empty() || !std::isfinite(e.min.z) || !std::isfinite(e.max.z)) return 0;
  return layer_planes(e.min.z, e.max.z, o.layer).size();
}

PbfResult plan_pbf(const PbfDesign& design, const PbfOptions& o, const PbfLayerSink& sink,
                   PbfLayerRange range, const RunContext& context) {
  PbfResult result;
  context.run([&] { result = plan_pbf_on(design, o, sink, range, context); });
  // Its warnings go to the context too (they stay in result.diagnostics for the caller).
  if (context.diagnostics) context.diagnostics->merge(result.diagnostics);
  return result;
}

namespace {

PbfResult plan_pbf_on(const PbfDesign& design, const PbfOptions& o, const PbfLayerSink& sink,
                      PbfLayerRange range, const RunContext& context) {
  const Progress& progress = context.progress;
  const auto t0 = std::chrono::steady_clock::now();
  check_options(o);
  pbf_detail::Plan plan{design, o, design.part()};
  PbfResult result;
  warn_untested(o, result.diagnostics);
  result.layer = o.layer;
  result.extent = plan.extent = plan.part.extent();
  const BBox3& e = result.extent;
  if (!finite_box(e))
    throw GeometryError("the lattice has no finite extent: give it an envelope (a box or a solid)");
  plan.zs = layer_planes(e.min.z, e.max.z, o.layer);
  const std::vector<double>& zs = plan.zs;
  if (zs.size() > 200000) throw SettingError("more than 200,000 layers: check the layer thickness");
  if (!o.stl_route) check_memory(design, o, zs.size(), static_cast<bool>(sink), context, result);
  sheet_parameter(plan);
  result.thin_walls_possible = plan.thin_walls_possible = thin_walls_possible(plan);
  if (o.stl_route) mesh_part(plan, result);
  pbf_detail::plan_grids(plan);

  const std::size_t first = std::min(range.first, zs.size());
  const std::size_t last = std::max(first, std::min(range.last, zs.size()));
  result.layers.resize(last - first);
  plan.sheet_period = pbf_detail::sheet_period(plan, result);
  pbf_detail::ZTiles tiles(plan, last, result);  // may move the grids' origin plan.lo
  plan.nx = static_cast<std::size_t>(std::llround((plan.hi.x - plan.lo.x) / plan.Hs));
  plan.ny = static_cast<std::size_t>(std::llround((plan.hi.y - plan.lo.y) / plan.Hs));
  tbb::enumerable_thread_specific<pbf_detail::Ctx> contexts(
      [&] { return pbf_detail::Ctx(plan.part, design, plan.c_field, plan.sheet_period); });

  // Layers computed in parallel, then summed up and handed to the sink in order; with a sink
  // the vectors are dropped once it has them.
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex;
  const std::size_t count = last - first;
  pbf_detail::run_layers_in_order(
      first, last,
      [&](std::size_t i) {
        progress.check("PBF planning");
        pbf_detail::plan_layer(plan, tiles, contexts.local(), i, result.layers[i - first]);
      },
      [&](std::size_t i) {
        tiles.release(i);
        PbfLayer& L = result.layers[i - first];
        pbf_detail::add_layer_totals(result, L);
        if (sink) {
          sink(i, L);
          std::vector<std::vector<Vec2>>().swap(L.contours);
          std::vector<Segment2>().swap(L.hatches);
        }
        const std::size_t d = ++done;
        if (progress.report && (d % 32 == 0 || d == count)) {
          std::lock_guard lock(progress_mutex);
          progress("layers", static_cast<double>(d) / static_cast<double>(count));
        }
      });
  result.turned_classes = tiles.turned_classes();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace

}  // namespace trellis
