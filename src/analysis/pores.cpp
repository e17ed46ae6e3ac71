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

}  // namespace trellis
