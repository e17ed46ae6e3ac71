// One PBF layer's plan, as named steps: its section S, the joints' or thin walls' region, the
// thin-wall contours, the hatch vectors, then its scan times and FR numbers.
#include <cmath>
#include <memory>

#include "pbf_internal.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/scan_strategy.hpp"

namespace trellis::pbf_detail {

ContourSet counted(ContourSet c, PbfLayer& L) {
  L.blocks += c.blocks;
  L.tiled_blocks += c.tiled_blocks;
  return c;
}

MarchOptions tiled(const MarchOptions& base, const ClassTiles* ct,
                   const PeriodTiles ClassTiles::*which) {
  MarchOptions m = base;
  m.tiles_in = ct ? &(*ct.*which) : nullptr;
  return m;
}

namespace {

// A point the layer's hatch lines pass through (HatchPhase).
Vec2 hatch_origin(const PbfOptions& o, double hatch_angle, std::size_t i) {
  Vec2 ho{0, 0};
  if (o.hatch_phase == HatchPhase::Origin) {
    ho = o.machine_origin;
  } else if (o.hatch_phase == HatchPhase::Random) {
    ho = random_hatch_shift(hatch_angle, o.hatch_seed, i, o.hatch_distance);
  }
  return ho;
}

// The regions inside f's zero level over the layer's grid, marched with mo.
Regions march_region(PlaneFunction& f, const Plan& p, const MarchOptions& mo, PbfLayer& L) {
  return nest_oriented_rings(counted(march_squares(f, p.lo, p.hi, 0.0, mo), L).lines.loops);
}

// The sheet's cross-section S: the STL route's mesh cut by the plane, else the section march.
Regions section(const Plan& p, Ctx& ctx, const ClassTiles* ct, std::size_t i, double z,
                PbfLayer& L) {
  if (p.o.stl_route)
    return p.o.test.stl_scan_all ? slice_mesh(p.mesh, z) : slice_mesh(p.mesh, z, p.buckets[i]);
  return nest_oriented_rings(
      counted(march_section(p, ctx, z, p.lo, p.hi, tiled(p.mo_section, ct, &ClassTiles::section)),
              L)
          .lines.loops);
}

void scan_statistics(const PbfOptions& o, const std::vector<Segment2>& S_hatch, PbfLayer& L) {
  // Scan time of this path (contours, then hatches, in order) and of the R67 baseline on the
  // same layer: the whole sheet hatched with the same compensation.
  ScanClock clock(o.timing);
  for (const auto& c : L.contours) clock.mark(c.data(), c.size(), o.timing.contour_speed);
  for (const auto& h : L.hatches) clock.mark(h.a, h.b, o.timing.hatch_speed);
  L.scan_time = clock.seconds();
  if (o.hybrid) {
    ScanClock r67(o.timing);
    for (const auto& s : S_hatch) {
      L.r67_length += std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
      r67.mark(s.a, s.b, o.timing.hatch_speed);
    }
    L.scan_time_r67 = r67.seconds();
  } else {
    L.r67_length = L.hatch_length;
    L.scan_time_r67 = L.scan_time;
  }
  L.fr = o.melt_pool * (L.contour_length + L.hatch_length) / L.area;
  L.fr_r67 = o.melt_pool * L.r67_length / L.area;
  const double cap = equivalent_length(0, o.melt_pool);
  const double n_vec = static_cast<double>(L.contours.size() + L.hatches.size());
  const double n_r67 = static_cast<double>(o.hybrid ? S_hatch.size() : L.hatches.size());
  L.fr_eq = o.melt_pool * (L.contour_length + L.hatch_length + n_vec * cap) / L.area;
  L.fr_eq_r67 = o.melt_pool * (L.r67_length + n_r67 * cap) / L.area;
}

}  // namespace

void plan_layer(const Plan& p, ZTiles& tiles, Ctx& ctx, std::size_t i, PbfLayer& L) {
  const PbfOptions& o = p.o;
  const double z = p.zs[i];
  L.z = z;
  L.hatch_angle = std::fmod(o.hatch_angle + o.hatch_rotation * static_cast<double>(i), 180.0);
  const Vec2 ho = hatch_origin(o, L.hatch_angle, i);
  const std::shared_ptr<const ClassTiles> ct = tiles.get(i);
  ctx.grid.reset(p.lo, p.Hs, p.nx, p.ny);
  ctx.bounds.reset(z);
  const Regions S = section(p, ctx, ct.get(), i, z, L);
  L.area = area(S);
  if (S.empty()) return;
  // With beam compensation every hatch vector keeps it from the section's outline (its chords
  // halved onto the field by the march on the direct route) and from the thin walls' outline.
  const double bc = o.beam_compensation;
  Regions T;  // thin walls, when compensating
  JointSection joint(ctx, p.design, o, p.c_const, z);
  JointSection thin(ctx, p.design, o, p.c_const, z, true);
  use_grid(p, ctx, joint, thin);
  Regions hatch_region = S;
  if (o.hybrid) {
    // Joints are contoured from their own field (a Boolean of S and J would spend its time on
    // their shared edges); thin walls are the pieces of the mid-curve φ = 0 where the
    // inverted joint measure is negative, split where it changes sign.
    if (bc > 0) {
      // Joints = the section minus the thin walls, so the joints' outline along the sheet is
      // the section's (refined) one, not the coarse grid's; slivers between the two outlines
      // are narrower than a cell and within the compensation of both.
      if (p.thin_walls_possible)
        T = march_region(thin, p, tiled(p.mo_joint, ct.get(), &ClassTiles::thin), L);
    } else {
      hatch_region = march_region(joint, p, tiled(p.mo_joint, ct.get(), &ClassTiles::joint), L);
    }
    thin_wall_contours(p, ctx, thin, ct.get(), i, z, L);
  }
  const std::vector<Segment2> S_hatch = hatch_layer(p, ctx, joint, S, T, hatch_region, ho, z, L);
  scan_statistics(o, S_hatch, L);
}

void add_layer_totals(PbfResult& result, const PbfLayer& L) {
  result.contour_vectors += L.contours.size();
  result.hatch_vectors += L.hatches.size();
  result.contour_length += L.contour_length;
  result.hatch_length += L.hatch_length;
  result.scan_time += L.scan_time;
  result.scan_time_r67 += L.scan_time_r67;
  result.blocks += L.blocks;
  result.tiled_blocks += L.tiled_blocks;
}

}  // namespace trellis::pbf_detail
