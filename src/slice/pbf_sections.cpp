// How a PBF layer's sections are marched: the grids (coarse for the joints and the mid-curve,
// finer for the section when the coarse one is over 25 µm), each march's crossing tolerance and
// tiles, and the section march's crossings handed to the thin-wall march.
#include <algorithm>
#include <cmath>

#include "pbf_internal.hpp"

namespace trellis::pbf_detail {

void plan_grids(Plan& p) {
  const PbfOptions& o = p.o;
  const BBox3& e = p.extent;
  // The joints and the mid-curve, smooth at the scale of a cell, are contoured on a grid
  // `coarse` times the resolution; the sheet section S (it gives the layer's area for FR_a and
  // the R67 baseline, not paths) on the same grid while that is at most 25 µm (two nodes across
  // the paper's thinnest, 65 µm walls), else on the resolution grid. Crossings are refined on
  // the field, so S at 20 µm is closer to the true section than the STL route's mesh at 10 µm
  // (tests/slice/test_pbf.cpp measures both). The node cache is on the finer of the two grids.
  const double H = std::max(1, o.coarse) * o.resolution;
  const double Hs = H <= 0.025 + 1e-9 ? H : o.resolution;
  const double pad = 2 * H;
  Vec2 lo{std::floor((e.min.x - pad) / H) * H, std::floor((e.min.y - pad) / H) * H};
  const Vec2 hi{std::ceil((e.max.x + pad) / H) * H, std::ceil((e.max.y + pad) / H) * H};
  // Crossings: the section to 2 µm (an area), the mid-curve to 0.5 µm (contour vectors must lie
  // within 1 µm of φ = 0), the joints to 1 µm (each hatch end is refined again on the field).
  MarchOptions mo_section, mo_mid, mo_joint;
  mo_section.resolution = Hs;
  mo_mid.resolution = mo_joint.resolution = H;
  // With beam compensation the section is also the boundary hatch vectors keep their distance
  // from: refined to 0.25 µm (and its chords halved onto the field, below).
  mo_section.refine_fraction = std::min(0.1, (o.beam_compensation > 0 ? 2.5e-4 : 2e-3) / Hs);
  // The section's crossings start from the cubic through the grid values along their edge:
  // about one refinement sample each instead of three (the same tolerance).
  mo_section.cubic_guess = true;
  // With beam compensation every hatch vector keeps it from the section's outline: its chords
  // are halved onto the field (a Newton step from each chord's middle), except where the outline
  // is within 0.25 µm of straight, the crossings' own tolerance (a point more there only costs
  // the hatching: 0.1 µm took 8% more time on 3 cells; the gyroid test's worst hatch end is
  // 0.24 µm inside the compensation, 0.20 µm with 0.1 µm).
  mo_section.segment_midpoints = o.beam_compensation > 0;
  mo_section.midpoint_min_offset = 2.5e-4;
  mo_mid.refine_fraction = std::min(0.1, 5e-4 / H);
  // Periodic tiles about 0.5 mm a side (measured on the 2–4-cell cubes at 25 µm: 2–3% faster
  // than 0.25 mm, which cost more per block, and than 1.25 mm, whose blocks along the envelope
  // are marched further in before their periodic quarters are taken from the tiles).
  auto tile_cells = [](double h) {
    return static_cast<std::size_t>(std::max(4.0, std::round(0.5 / h)));
  };
  mo_section.tile_block = tile_cells(Hs);
  mo_mid.tile_block = mo_joint.tile_block = tile_cells(H);
  mo_joint.refine_fraction = std::min(0.1, 1e-3 / H);
  // The thin-wall march (direct route, with compensation) takes the section's crossings where
  // the part decides its measure, when they are refined at least as tightly as its own.
  const auto stride = static_cast<std::size_t>(std::llround(H / Hs));
  const bool section_crossings = o.test.reuse_section_crossings && !o.stl_route && o.hybrid &&
                                 o.beam_compensation > 0 &&
                                 mo_section.refine_fraction * Hs <= mo_joint.refine_fraction * H &&
                                 std::abs(H - static_cast<double>(stride) * Hs) < 1e-12;

  p.H = H;
  p.Hs = Hs;
  p.pad = pad;
  p.lo = lo;
  p.hi = hi;
  p.mo_section = mo_section;
  p.mo_mid = mo_mid;
  p.mo_joint = mo_joint;
  p.stride = stride;
  p.section_crossings = section_crossings;
}

ContourSet march_section(const Plan& p, Ctx& c, double z, Vec2 a, Vec2 b, MarchOptions mo) {
  PartSection fs(c, c.grid, z);
  // The coarse marches' smallest blocks are 4 of their cells (MarchOptions::block's leaves).
  if (p.Hs < p.H) fs.share_bounds_from(4 * p.H - 1e-9);
  mo.edge_crossings = p.section_crossings ? &c.edge_crossings : nullptr;
  ContourSet r = march_squares(fs, a, b, 0.0, mo);
  if (p.section_crossings) c.grid.set_crossings(c.edge_crossings);
  return r;
}

void use_grid(const Plan& p, Ctx& c, JointSection& joint, JointSection& thin) {
  joint.use_grid(&c.grid, p.o.beam_compensation <= 0);
  thin.use_grid(&c.grid, p.o.beam_compensation > 0);
  thin.use_section_crossings(p.section_crossings ? p.stride : 0);
}

}  // namespace trellis::pbf_detail
