// Voronoi patterns and foams run in the CGAL module, loaded on first use.
#include "../core/cgal_module.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/lattice/cells3d.hpp"

namespace trellis {

std::vector<Segment2> voronoi_segments(double half, double density, std::uint64_t seed) {
  return detail::module_table<CgalModule>("cgal").voronoi_segments(half, density, seed);
}

Graph voronoi_foam(const FoamParams& params, Diagnostics& diag) {
  return detail::module_table<CgalModule>("cgal").voronoi_foam(params, diag);
}

}  // namespace trellis
