// Estimates before work for the routes (core/budget.hpp). The constants are measured on one core
// of the development machine (the bench/ programs and `trellis … --report`), rounded up: an
// estimate is an order of magnitude, enough to refuse a run that would take hours or more memory
// than the machine has, never a promise.
#include <fmt/format.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "routes.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis::routes {

RunContext run_context(const Settings& settings, const Config& c, const RunContext& given) {
  RunContext context = given;
  if (c.threads > 0) context.threads = c.threads;
  context.budget = budget_of(settings, c, given.progress);
  return context;
}

Budget budget_of(const Settings& settings, const Config& c, const Progress& progress) {
  Budget b;
  b.seen = progress.estimate;
  b.memory = settings.has("run.max_memory") ? c.budget.max_memory_mb * 1e6 : 0;
  b.seconds = c.budget.max_time;
  b.force = c.budget.force;
  return b;
}

// The threads a run's parallel loops get: the arena's, bounded by run.threads (a global_control).
double threads_of_run() {
  const auto allowed =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  return static_cast<double>(std::max<std::size_t>(
      1, std::min<std::size_t>(allowed,
                               static_cast<std::size_t>(tbb::this_task_arena::max_concurrency()))));
}

Estimate estimate_lattice2d(const AtlasParams& a, int layers) {
  const Region& r = a.region;
  const double area =
      r.shape == RegionShape::Circle ? M_PI / 4 * r.diameter * r.diameter : r.width * r.height;
  const double spacing =
      a.strand_distance > 0 ? std::min(a.cell_size, a.strand_distance) : a.cell_size;
  // The pattern fills twice the region before the crop. Honeycomb 200 × 200 mm at 1 mm: 4.6 s,
  // 400 MB for 40,000 cell² units; 100 × 100 mm: 0.53 s of CPU. A Voronoi layer of n seeds
  // costs more than linearly: 450 seeds 0.2 s, 7,200 seeds 25 s (one thread, CPU time).
  const bool voronoi = a.pattern == Pattern::Voronoi;
  const double n = std::max(1.0, double(layers));
  const double per_layer = voronoi ? a.voronoi_density * area : area / (spacing * spacing);
  const double units = n * per_layer;
  Estimate e;
  e.bytes = units * (voronoi ? 25e3 : 1e4);
  e.seconds = voronoi ? n * 4.5e-6 * std::pow(per_layer, 1.75) : units * 1.2e-4;
  e.what = voronoi ? fmt::format("a Voronoi lattice of {:.3g} seeds", units)
                   : fmt::format("a {} lattice of {:.3g} cells", to_string(a.pattern), units);
  e.change =
      "the region (lattice2d.size, lattice2d.diameter), the cell (lattice2d.cell, "
      "lattice2d.density) or layers.count";
  return e;
}

Estimate estimate_lattice3d(const Config& c) {
  const auto& l = c.lattice3d;
  double struts = 0;
  std::string what;
  if (l.kind == Lattice3dKind::Foam && l.foam.mesh.empty()) {
    // A Voronoi cell has about 13 struts of its own; the box is mirrored in its faces.
    struts = 4 * 13 * l.foam.density * l.foam.width * l.foam.depth * l.foam.height;
    what = fmt::format("a Voronoi foam of about {:.3g} struts", struts);
  } else if (l.kind == Lattice3dKind::Cells) {
    struts = 36.0 * l.cells.nx * l.cells.ny * l.cells.nz;
    what = fmt::format("{} x {} x {} unit cells", l.cells.nx, l.cells.ny, l.cells.nz);
  } else if (!l.foam.mesh.empty()) {
    // A foam in a mesh or a conformal lattice: the mesh's box bounds the struts (the mesh is
    // read here for its box; its reading was estimated from the file size before).
    const BBox3 b = bounds(read_mesh(l.foam.mesh));
    const Vec3 s = b.max - b.min;
    const double volume = std::max(0.0, s.x * s.y * s.z);
    if (l.kind == Lattice3dKind::Foam) {
      struts = 13 * l.foam.density * volume;
    } else {
      const double cell = l.cells.size;
      struts = 36 * volume / (cell * cell * cell) +
               (l.conformal.skin > 0 ? 13 * l.conformal.skin_density * volume : 0);
    }
    what = fmt::format("a {} lattice of about {:.3g} struts in {}", to_string(l.kind), struts,
                       l.foam.mesh);
  } else {
    return {};
  }
  Estimate e;
  e.bytes = struts * 300;
  e.seconds = struts * 2e-6;
  e.what = what;
  e.change = "lattice3d.count, lattice3d.box, lattice3d.density or lattice3d.cell";
  return e;
}

Estimate estimate_gippo(std::size_t edges, int iterations, int seeds) {
  // 20 iterations over 47,000 edges: 0.93 s on one core; 100 over the 11,508 edges of a 100 mm
  // honeycomb: 0.2 s of CPU (one thread). Each iteration keeps its score.
  const double work =
      double(iterations) * double(std::max<std::size_t>(edges, 1)) * std::max(1, seeds + 1);
  Estimate e;
  e.bytes = double(edges) * 400 + double(iterations) * 64 * std::max(1, seeds + 1);
  e.seconds = work * 4e-7 / threads_of_run();
  e.what = fmt::format("GIPPO planning of {} iterations over {} edges", iterations, edges);
  e.change = "gippo.iterations or gippo.seeds";
  return e;
}

Estimate estimate_aero(std::size_t edges, int tries) {
  // Collision-aware groups are quadratic in the struts. Measured (one thread, CPU time): 100 and
  // 1,000 tries over the 516 struts of a 3 × 3 × 2 octet take 0.16 s and 1.5 s, about
  // 5.5e-9 s × struts² a try. Only the best plan so far is kept, one try in flight per thread.
  const double E = double(std::max<std::size_t>(edges, 1));
  const double runs = double(std::max(tries, 1));
  Estimate e;
  e.bytes = E * E * 0.5 + E * 2000 + threads_of_run() * E * 400;
  e.seconds = runs * E * E * 5.5e-9 / std::min(runs, threads_of_run()) + E * E * 2e-8;
  e.what = fmt::format("AERO planning of {} tries over {} struts", std::max(tries, 1), edges);
  e.change = "aero.tries";
  return e;
}

Estimate estimate_nonplanar(const BBox2& domain, const NonplanarParams& p) {
  const double wx = domain.max.x - domain.min.x, wy = domain.max.y - domain.min.y;
  // A layer's lines cover the domain `width` apart, sampled about every 0.05 mm after the
  // refinement to the chord tolerance: its points.
  const double lines = std::max(wx, wy) / p.width + 1;
  const double points = wx * wy / (p.width * 0.05) + lines;
  // Vertical offsets slice each direction once and lift it; normal offsets (every layer above
  // the first) search the ball envelope at each point: about a hundred surface evaluations.
  // Measured (one thread, CPU time): the 45° corrugation, 6 layers, 44 × 16 mm at 0.4 mm,
  // 0.03 s vertical and 5.8 s normal.
  std::size_t directions = 0;
  for (std::size_t k = 0; k < p.angles.size() && k < static_cast<std::size_t>(p.layers); ++k)
    directions +=
        std::find(p.angles.begin(), p.angles.begin() + k, p.angles[k]) == p.angles.begin() + k;
  const bool normal = p.offset == OffsetMode::Normal;
  const double sliced = normal ? 1 : double(directions);
  const double offset = normal ? std::max(0, p.layers - 1) : 0;
  Estimate e;
  e.bytes = double(p.layers) * points * 64;
  e.seconds = (sliced * points * 3e-7 + offset * points * 3.3e-5) / threads_of_run() +
              double(p.layers) * points * 1e-7;  // joining, in order
  e.what = fmt::format("{} non-planar layers ({} offsets) of {:.3g} lines over {:.0f} x {:.0f} mm",
                       p.layers, normal ? "normal" : "vertical", lines, wx, wy);
  e.change = "nonplanar.bead_width, nonplanar.layers, nonplanar.offset or the domain";
  return e;
}

Estimate estimate_gcode_of(const std::string& toolpath_json) {
  std::error_code ec;
  const double size = static_cast<double>(std::filesystem::file_size(toolpath_json, ec));
  Estimate e;
  if (ec) return e;  // the reader says what is wrong with the file
  // The JSON reader holds the whole toolpath (about 4 bytes per byte of JSON); reading and
  // writing run at roughly 50 MB/s together on one core.
  e.bytes = size * 4;
  e.seconds = size * 2e-8;
  e.what = fmt::format("writing G-code from a {:.3g} MB toolpath", size / 1e6);
  e.change = "the toolpath (plan or slice it in parts: trellis run --shard)";
  return e;
}

Estimate estimate_pbf_time(const PbfDesign& d, const PbfOptions& po, bool toolpath_json,
                           bool package_3mf) {
  const BBox3 box = d.part().extent();
  const double layers = (box.max.z - box.min.z) / po.layer + 1;
  Estimate e;
  e.bytes = 0;  // plan_pbf's own estimate (pbf_memory_estimate) covers the planning
  e.seconds = pbf_time_estimate(d, po, static_cast<int>(threads_of_run()));
  if (toolpath_json) {
    // The whole toolpath as JSON (--toolpath): its document is built in memory. Measured on a
    // 6 mm gyroid cube (118,000 vectors): 0.67 s of CPU and 280 MB more than streaming.
    const double vectors = pbf_vectors_estimate(d, po);
    e.seconds += vectors * 6e-6;
    e.bytes = 36e6 + vectors * 2500;
  }
  if (package_3mf) {
    // A 3MF toolpath holds the whole toolpath and its layer parts until the package is made.
    // Measured on a 10 x 10 x 5 mm gyroid (264,000 vectors): 150 MB and 0.4 s of CPU more
    // than streaming a .cli.
    const double vectors = pbf_vectors_estimate(d, po);
    e.seconds += vectors * 2e-6;
    e.bytes += vectors * 600;
  }
  e.what = fmt::format("PBF paths of {:.3g} layers of {:.3g} x {:.3g} mm at resolution {} mm",
                       layers, box.max.x - box.min.x, box.max.y - box.min.y, po.resolution);
  e.change = "pbf.resolution, scan.layer or pbf.size";
  return e;
}

}  // namespace trellis::routes
