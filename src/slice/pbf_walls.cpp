// The PBF paper's thin-wall experiments (Fig. 3) as designs, and the memory and time estimates
// of a run.
#include <fmt/format.h>
#include <tbb/info.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/slice.hpp"

namespace trellis {

PbfDesign plane_wall(double thickness, double inclination_deg, double azimuth_deg, Vec3 size) {
  if (!(thickness > 0)) throw SettingError("wall thickness must be > 0 mm");
  if (!(inclination_deg > 0 && inclination_deg <= 90))
    throw SettingError("wall inclination must be within (0, 90] degrees from the horizontal");
  if (!(size.x > 0 && size.y > 0 && size.z > 0)) throw SettingError("wall box size must be > 0");
  const double deg = std::numbers::pi / 180, a = azimuth_deg * deg, t = inclination_deg * deg;
  // Unit normal of a plane containing the horizontal direction (cos a, sin a, 0), tilted t from
  // the horizontal: φ is the signed distance to it, so the sheet |φ| <= thickness/2 is the wall.
  const Vec3 n{-std::sin(a) * std::sin(t), std::cos(a) * std::sin(t), -std::cos(t)};
  PbfDesign d;
  d.phi = expression_field({fmt::format("({:.17g})*x + ({:.17g})*y + ({:.17g})*z", n.x, n.y, n.z)});
  d.c = {fmt::format("{:.17g}", 0.5 * thickness)};
  d.envelope = rectprism(size);
  return d;
}

PbfSections pbf_sample_sections(const PbfDesign& design, const PbfOptions& o) {
  PbfSections out;
  const BBox3 e = design.part().extent();
  if (e.empty() || !std::isfinite(e.min.x) || !std::isfinite(e.max.x)) return out;
  std::vector<double> zs;
  for (int k = 0; k < 5; ++k) zs.push_back(e.min.z + (k + 0.5) / 5 * (e.max.z - e.min.z));
  // Twice the run's grid step, or coarser on a large build (at most 200 steps a side), so the
  // estimate stays quick (well under a second) where the run would not be.
  FieldSliceOptions so;
  so.resolution = std::max(2 * o.resolution, std::max(e.max.x - e.min.x, e.max.y - e.min.y) / 200);
  for (const auto& l : slice_field(design.part(), zs, so)) {
    out.area += trellis::area(l.regions) / 5;
    for (const auto& ring : rings_of(l.regions))
      for (std::size_t i = 0; i < ring.size(); ++i)
        out.perimeter += std::hypot(ring[(i + 1) % ring.size()].x - ring[i].x,
                                    ring[(i + 1) % ring.size()].y - ring[i].y) /
                         5;
  }
  return out;
}

// The direct route's time: its layers are marched only near the sheet (bounds prune the rest),
// so a layer costs about its sections' outline length, and a finer grid somewhat more.
// Measured (one thread, CPU time, resolution 0.025): gyroid cubes of cell 1–5 mm and a 250 mm
// cell filling a 10 mm box (one wall, hatched throughout) take 0.8–1.1 × 1.4e-5 s per mm of
// outline a layer; halving the resolution costs 1.25 ×.
double pbf_time_estimate(const PbfDesign& design, const PbfOptions& o, int threads) {
  const BBox3 e = design.part().extent();
  if (e.empty() || !std::isfinite(e.min.z) || !std::isfinite(e.max.z) || !(o.layer > 0)) return 0;
  const PbfSections s = pbf_sample_sections(design, o);
  const double layers = std::ceil((e.max.z - e.min.z) / o.layer) + 1;
  const double grid = std::sqrt(0.025 / std::max(o.resolution, 1e-4));
  const double hatch = s.area / std::max(o.hatch_distance, 1e-3);  // mm of hatch a layer
  return 0.02 + layers * (s.perimeter * 1.4e-5 * grid + hatch * 2e-7) / std::max(1, threads);
}

double pbf_vectors_estimate(const PbfDesign& design, const PbfOptions& o) {
  const BBox3 e = design.part().extent();
  if (e.empty() || !std::isfinite(e.min.z) || !std::isfinite(e.max.z) || !(o.layer > 0)) return 0;
  const double length = pbf_sample_sections(design, o).area / o.melt_pool;  // mm a layer, FR_a ≈ 1
  return std::ceil((e.max.z - e.min.z) / o.layer) * length /
         std::max(std::min(o.segment_length, 4 * o.hatch_distance), 1e-3);
}

// The direct route's memory (the STL route's mesh is not modelled: it is the comparison).
double pbf_memory_estimate(const PbfDesign& design, const PbfOptions& o, int threads) {
  return pbf_memory_estimate(design, o, threads, false);
}

double pbf_memory_estimate(const PbfDesign& design, const PbfOptions& o, int threads,
                           bool streamed) {
  const BBox3 e = design.part().extent();
  if (e.empty() || !std::isfinite(e.min.x) || !std::isfinite(e.max.x)) return 0;
  const double H = std::max(1, o.coarse) * o.resolution;
  const double Hs = H <= 0.025 + 1e-9 ? H : o.resolution;
  const double wx = e.max.x - e.min.x + 4 * H + 2 * H, wy = e.max.y - e.min.y + 4 * H + 2 * H;
  const double nodes = (wx / Hs + 2) * (wy / Hs + 2);
  // Per thread: the node cache (24 B a node) and the march's scratch (edge table, crossings,
  // about 40 B a node of the coarse grid), the bound cache and the evaluators' sine memos
  // (about 4 MB: 64 k slots of 52 B for the largest layers, three memos of 384 KB).
  const double per_thread = nodes * 24 + (wx / H + 2) * (wy / H + 2) * 40 + (4 << 20);
  // The layers' vectors: the part's mean section area (five sample layers, on a grid of twice
  // the resolution) scanned with FR_a ≈ 1 (length A/D a layer) in vectors of SL (or 4 hatch
  // distances, the shorter); about 300 B a vector in the layers, the toolpath made from them and
  // the file's text. Plus the process itself (libraries, about 36 MB). Measured on gyroid cubes
  // of 1–4 cells: 0.96–1.3× the peak RSS.
  const double area = pbf_sample_sections(design, o).area;
  // Streamed: the pipeline's layers in flight (two per thread) and the per-layer series.
  const double layers = streamed ? 2.0 * threads : std::ceil((e.max.z - e.min.z) / o.layer);
  const double length = area / o.melt_pool;  // mm a layer
  const double vectors = length / std::max(std::min(o.segment_length, 4 * o.hatch_distance), 1e-3);
  // Plus the tiles kept for the layers a period above (at most their budget).
  double bytes = 36e6 + threads * per_thread + layers * vectors * 300 +
                 static_cast<double>(o.test.periodic_tiles ? o.test.z_tiles_budget : 0);
  return bytes;
}

}  // namespace trellis
