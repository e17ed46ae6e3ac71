#include "trellis/analysis/pores.hpp"

#include <cmath>

#include "trellis/core/error.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

PoreArea pore_area(const Graph& g, double width) {
  if (!(width > 0) || !std::isfinite(width)) throw SettingError("the line width must be positive");
  std::vector<std::vector<Vec2>> lines;
  lines.reserve(g.edges.size());
  for (const auto& e : g.edges) {
    const Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
    lines.push_back({{a.x, a.y}, {b.x, b.y}});
  }
  // Arc tolerance 0.1 % of the width: the round ends' area is within ~1e-3 of a disc's.
  const Regions printed = stroke(lines, width, 1e-3 * width);
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

double cell_for_porosity(const AtlasParams& params, double target, double width) {
  if (params.pattern == Pattern::Voronoi)
    throw SettingError("a target porosity tunes the cell size; a Voronoi lattice's pores follow "
                       "its density (lattice2d.density) instead",
                       {"", 0, "lattice2d.target_porosity"});
  if (!(target > 0 && target < 100))
    throw SettingError("the target porosity is a percentage in (0, 100)",
                       {"", 0, "lattice2d.target_porosity"});
  auto percent = [&](double cell) {
    AtlasParams a = params;
    a.cell_size = cell;
    if (a.strand_distance > 0) a.strand_distance = cell;  // spacing patterns: the strand is the cell
    return pore_area(make_lattice2d(a), width).percent();
  };
  double lo = 1.05 * width, hi = std::max(params.cell_size, 2 * width);
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
  return best;
}

}  // namespace trellis
