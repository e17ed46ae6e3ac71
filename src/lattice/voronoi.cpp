// Voronoi edges via CGAL's Delaunay triangulation (its dual). CGAL stays inside this file.
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "trellis/core/rng.hpp"
#include "trellis/lattice/atlas.hpp"

namespace trellis {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel>;

std::vector<Segment2> voronoi_segments(double half, double density, std::uint64_t seed) {
  // Seeds over a margin beyond the square so cells near its border are closed.
  const double h = half * 1.25;
  const auto count = static_cast<std::size_t>(std::llround(density * (2 * h) * (2 * h)));
  Rng rng(seed);
  std::vector<Kernel::Point_2> pts;
  pts.reserve(count);
  for (std::size_t i = 0; i < count; ++i)
    pts.emplace_back(-h + 2 * h * rng.uniform01(), -h + 2 * h * rng.uniform01());
  Delaunay dt(pts.begin(), pts.end());
  std::vector<Segment2> out;
  for (auto e = dt.finite_edges_begin(); e != dt.finite_edges_end(); ++e) {
    const auto f1 = e->first, f2 = e->first->neighbor(e->second);
    if (dt.is_infinite(f1) || dt.is_infinite(f2)) continue;
    const auto a = dt.dual(f1), b = dt.dual(f2);
    Segment2 s{{a.x(), a.y()}, {b.x(), b.y()}};
    if (std::tie(s.b.x, s.b.y) < std::tie(s.a.x, s.a.y)) std::swap(s.a, s.b);
    out.push_back(s);
  }
  // CGAL's bulk insertion shuffles with a global random state, so the edge order varies from
  // call to call; sort for output that depends only on the seed.
  std::sort(out.begin(), out.end(), [](const Segment2& p, const Segment2& q) {
    return std::tie(p.a.x, p.a.y, p.b.x, p.b.y) < std::tie(q.a.x, q.a.y, q.b.x, q.b.y);
  });
  return out;
}

}  // namespace trellis
