// Pore area of a planar lattice as printed (GIPPO paper, Table 1: designs tuned to a pore
// share): the struts, projected on XY, drawn as lines `width` wide (round ends, Clipper); the
// pores are the holes those lines enclose, measured against the area inside the lattice's outer
// contours (lines included).
#pragma once
#include <cstddef>
#include <vector>

#include "trellis/lattice/atlas.hpp"
#include "trellis/lattice/graph.hpp"

namespace trellis {

struct PoreArea {
  double enclosed = 0;        // mm², inside the outer contours of the printed lines
  double material = 0;        // mm², covered by the lines
  double pores = 0;           // mm², the enclosed holes
  std::size_t count = 0;      // number of pores
  std::vector<double> areas;  // mm², each pore
  double percent() const { return enclosed > 0 ? 100 * pores / enclosed : 0; }
};

// Throws SettingError for a width that is not positive.
PoreArea pore_area(const Graph& g, double width);

// The cell size at which the 2D lattice `params` (pattern, region, ...) printed with lines
// `width` wide has `target_percent` pore area (GIPPO Table 1 tunes each design to a pore share):
// bracketed, then bisected until within 0.1 % (points) or 40 steps. Pore area grows with the
// cell. Throws SettingError for Voronoi (its density, not a cell size, sets the pores) and for
// targets no cell size in 1.05 width .. 1000 width reaches.
double cell_for_porosity(const AtlasParams& params, double target_percent, double width);

}  // namespace trellis
