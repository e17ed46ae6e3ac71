// Pore area of a planar lattice as printed (GIPPO paper, Table 1: designs tuned to a pore
// share): the struts, projected on XY, drawn as lines `width` wide (round ends, Clipper); the
// pores are the holes those lines enclose, measured against the area inside the lattice's outer
// contours (lines included).
#pragma once
#include <cstddef>
#include <vector>

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

}  // namespace trellis
