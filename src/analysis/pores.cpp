#include "trellis/analysis/pores.hpp"

#include <cmath>

#include "trellis/core/error.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

namespace {

Regions stroked(const Graph& g, double width) {
  if (!(width > 0) || !std::isfinite(width)) throw SettingError("the line width must be positive");
  std::vector<std::vector<Vec2>> lines;
  lines.reserve(g.edges.size());
  for (const auto& e : g.edges) {
    const Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
    lines.push_back({{a.x, a.y}, {b.x, b.y}});
  }
  // Arc tolerance 0.1 % of the width: the round ends' area is within ~1e-3 of a disc's.
  return stroke(lines, width, 1e-3 * width);
}

// The pattern's length scale: the cell size, or for Voronoi the mean seed spacing.
double scale_of(const AtlasParams& a) {
  return a.pattern == Pattern::Voronoi ? 1 / std::sqrt(a.voronoi_density) : a.cell_size;
}

AtlasParams with_scale(AtlasParams a, double scale) {
  if (a.pattern == Pattern::Voronoi) {
    a.voronoi_density = 1 / (scale * scale);
  } else {
    a.cell_size = scale;
    if (a.strand_distance > 0)
      a.strand_distance = scale;  // spacing patterns: the strand is the cell
  }
  return a;
}

}  // namespace

PoreArea pore_area(const Graph& g, double width) {
  const Regions printed = stroked(g, width);
  PoreArea r;
  for (const auto& p : printed) {
    r.enclosed += std::abs(signed_area(p.outer));
    for (const auto& h : p.holes) {
      r.areas.push_back(std::abs(signed_area(h)));
      r.pores += r.areas.back();
      ++r.count;
    }
  }
  r.material = r.enclosed - r.pores;
  return r;
}

double surface_pore_percent(const Graph& g, double width, const Regions& region) {
  const double total = area(region);
  if (!(total > 0)) throw SettingError("the region of a pore share must have an area");
  const double covered = area(intersection(stroked(g, width), region));
  return 100 * (total - covered) / total;
}

AtlasParams tune_for_porosity(const AtlasParams& params, double target, double width) {
  if (!(target > 0 && target < 100))
    throw SettingError("the target porosity is a percentage in (0, 100)",
                       {"", 0, "lattice2d.target_porosity"});
  const Regions region = params.crop.empty() ? Regions{params.region.polygon()} : params.crop;
  auto percent = [&](double scale) {
    return surface_pore_percent(make_lattice2d(with_scale(params, scale)), width, region);
  };
  double lo = 1.05 * width, hi = std::max(scale_of(params), 2 * width);
  while (percent(hi) < target) {
    lo = hi;
    hi *= 2;
    if (hi > 1000 * width)
      throw SettingError("no cell size up to 1000 line widths gives " + std::to_string(target) +
                             "% pores in this region (a larger region or thinner lines may)",
                         {"", 0, "lattice2d.target_porosity"});
  }
  if (percent(lo) > target)
    throw SettingError("even the smallest cell (1.05 line widths) has more than " +
                           std::to_string(target) + "% pores",
                       {"", 0, "lattice2d.target_porosity"});
  double best = hi, best_err = std::abs(percent(hi) - target);
  for (int k = 0; k < 40 && best_err > 0.1; ++k) {
    const double m = 0.5 * (lo + hi);
    const double p = percent(m);
    if (std::abs(p - target) < best_err) best = m, best_err = std::abs(p - target);
    (p < target ? lo : hi) = m;
  }
  return with_scale(params, best);
}

}  // namespace trellis
