// Estimates before work for the routes (core/budget.hpp). The constants are measured on one core
// of the development machine (the bench/ programs and `trellis … --report`), rounded up: an
// estimate is an order of magnitude, enough to refuse a run that would take hours or more memory
// than the machine has, never a promise.
#include <fmt/format.h>

#include <filesystem>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>

#include "routes.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis::routes {

Budget budget_of(const Job& job, const Config& c) {
  Budget b;
  b.memory = job.settings.has("run.max_memory") ? c.budget.max_memory_mb * 1e6 : 0;
  b.seconds = c.budget.max_time;
  b.force = c.budget.force;
  return b;
}

double threads_of_run() {
  return std::max(1, tbb::this_task_arena::max_concurrency());
}

Estimate estimate_lattice2d(const AtlasParams& a, int layers) {
  const Region& r = a.region;
  const double area = r.shape == RegionShape::Circle ? M_PI / 4 * r.diameter * r.diameter
                                                     : r.width * r.height;
  const double spacing = a.strand_distance > 0 ? std::min(a.cell_size, a.strand_distance) : a.cell_size;
  // The pattern fills twice the region before the crop. Honeycomb 200 × 200 mm at 1 mm: 4.6 s,
  // 400 MB for 40,000 cell² units; Voronoi costs more per seed.
  const bool voronoi = a.pattern == Pattern::Voronoi;
  const double units = std::max(1.0, double(layers)) * (voronoi ? a.voronoi_density * area : area / (spacing * spacing));
  Estimate e;
  e.bytes = units * (voronoi ? 25e3 : 1e4);
  e.seconds = units * (voronoi ? 2e-3 : 1.2e-4);
  e.what = voronoi ? fmt::format("a Voronoi lattice of {:.3g} seeds", units)
                   : fmt::format("a {} lattice of {:.3g} cells", to_string(a.pattern), units);
  e.change = "the region (--size, --diameter), the cell (--cell, --density) or layers.count";
  return e;
}

Estimate estimate_lattice3d(const Config& c) {
  const auto& l = c.lattice3d;
  double struts = 0;
  std::string what;
  if (l.kind == "foam" && l.foam.mesh.empty()) {
    // A Voronoi cell has about 13 struts of its own; the box is mirrored in its faces.
    struts = 4 * 13 * l.foam.density * l.foam.width * l.foam.depth * l.foam.height;
    what = fmt::format("a Voronoi foam of about {:.3g} struts", struts);
  } else if (l.kind == "cells") {
    struts = 36.0 * l.cells.nx * l.cells.ny * l.cells.nz;
    what = fmt::format("{} x {} x {} unit cells", l.cells.nx, l.cells.ny, l.cells.nz);
  } else if (!l.foam.mesh.empty()) {
    // A foam in a mesh or a conformal lattice: the mesh's box bounds the struts (the mesh is
    // read here for its box; its reading was estimated from the file size before).
    const BBox3 b = bounds(read_mesh(l.foam.mesh));
    const Vec3 s = b.max - b.min;
    const double volume = std::max(0.0, s.x * s.y * s.z);
    if (l.kind == "foam") {
      struts = 13 * l.foam.density * volume;
    } else {
      const double cell = l.cells.size;
      struts = 36 * volume / (cell * cell * cell) +
               (l.conformal.skin > 0 ? 13 * l.conformal.skin_density * volume : 0);
    }
    what = fmt::format("a {} lattice of about {:.3g} struts in {}", l.kind, struts, l.foam.mesh);
  } else {
    return {};
  }
  Estimate e;
  e.bytes = struts * 300;
  e.seconds = struts * 2e-6;
  e.what = what;
  e.change = "--count (lattice3d.count), --box, --density or --cell (lattice3d.cell)";
  return e;
}

Estimate estimate_gippo(std::size_t edges, int iterations, int seeds) {
  // 20 iterations over 47,000 edges: 0.93 s on one core; each iteration keeps its score.
  const double work = double(iterations) * double(std::max<std::size_t>(edges, 1)) * std::max(1, seeds + 1);
  Estimate e;
  e.bytes = double(edges) * 400 + double(iterations) * 64 * std::max(1, seeds + 1);
  e.seconds = work * 1e-6 / threads_of_run();
  e.what = fmt::format("GIPPO planning of {} iterations over {} edges", iterations, edges);
  e.change = "--iterations (gippo.iterations) or gippo.seeds";
  return e;
}

Estimate estimate_aero(std::size_t edges, int tries) {
  // Collision-aware groups are quadratic in the struts: 8 tries over 1,500 struts take 0.17 s.
  const double E = double(std::max<std::size_t>(edges, 1));
  Estimate e;
  e.bytes = E * E * 0.5 + E * 2000 + double(std::max(tries, 1)) * E * 100;  // every try's plan is kept
  e.seconds = double(std::max(tries, 1)) * E * E * 1e-8;
  e.what = fmt::format("AERO planning of {} tries over {} struts", std::max(tries, 1), edges);
  e.change = "--tries (aero.tries)";
  return e;
}

Estimate estimate_nonplanar(const BBox2& domain, const NonplanarParams& p) {
  const double wx = domain.max.x - domain.min.x, wy = domain.max.y - domain.min.y;
  const double span = std::max(wx, wy);
  // Each layer: span / width plane sections, each sampled along the surface at about the chord
  // tolerance's square root (sagitta) or 0.05 mm, whichever is finer.
  const double lines = span / p.width + 1;
  const double step = std::max(1e-4, std::min(0.05, std::sqrt(8 * p.chord_tolerance * 0.5)));
  const double points = double(p.layers) * lines * (span / step + 1);
  Estimate e;
  e.bytes = points * 64;
  e.seconds = points * 2e-7;
  e.what = fmt::format("{} non-planar layers of {:.3g} lines over {:.0f} x {:.0f} mm", p.layers,
                       lines, wx, wy);
  e.change = "--bead-width (nonplanar.bead_width), --layers (nonplanar.layers) or the domain";
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

Estimate estimate_pbf_time(const BBox3& box, double resolution, double layer, double threads) {
  const double nx = (box.max.x - box.min.x) / (2 * resolution) + 3;
  const double ny = (box.max.y - box.min.y) / (2 * resolution) + 3;
  const double layers = (box.max.z - box.min.z) / layer + 1;
  Estimate e;
  e.bytes = 0;  // plan_pbf's own estimate (pbf_memory_estimate) covers memory
  // The default gyroid cube (10 mm, 334 layers of 203 x 203 samples) takes 18 s on two cores.
  e.seconds = layers * nx * ny * 2.5e-6 / threads;
  e.what = fmt::format("{:.3g} layers of {:.3g} x {:.3g} samples", layers, nx, ny);
  e.change = "--resolution (pbf.resolution), --layer-height (scan.layer) or --size (pbf.size)";
  return e;
}

}  // namespace trellis::routes
