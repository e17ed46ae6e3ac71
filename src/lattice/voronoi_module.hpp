// The CGAL module's table (src/core/module.hpp): Voronoi patterns and foams.
#pragma once
#include "../core/module.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/lattice/cells3d.hpp"

namespace trellis {

struct VoronoiModule {
  detail::ModuleHeader header;
  std::vector<Segment2> (*voronoi_segments)(double, double, std::uint64_t);
  Graph (*voronoi_foam)(const FoamParams&, Diagnostics&);
};

}  // namespace trellis
