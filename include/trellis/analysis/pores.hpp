// Pore area of a planar lattice as printed (GIPPO paper, Table 1: designs tuned to a pore
// share): the struts, projected on XY, drawn as lines `width` wide (round ends, Clipper). Two
// measures: the holes those lines enclose against the area inside the lattice's outer contours
// (`pore_area`), and the paper's own, the share of the layer surface (its 10 x 10 mm region) the
// lines leave uncovered, pores open at the border included (`surface_pore_percent`).
#pragma once
#include <cstddef>
#include <vector>

#include "trellis/geom/regions.hpp"
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

// The share (%) of `region` not covered by the struts of `g` drawn `width` wide: GIPPO Table 1's
// "pores area ... of the layer surface". Throws SettingError for a width that is not positive or
// an empty region.
double surface_pore_percent(const Graph& g, double width, const Regions& region);

// The 2D lattice `params` (pattern, region, ...) with its scale tuned so that, printed with lines
// `width` wide, `target_percent` of its region is pore (surface_pore_percent; GIPPO Table 1 tunes
// each design to a pore share): the cell size (and the strand distance of the spacing patterns),
// or for Voronoi the seed density (as 1 / scale²). The share grows with the scale: bracketed,
// then bisected until within 0.1 % (points) or 40 steps; the closest scale found is kept.
// Throws SettingError for targets no scale in 1.05 width .. 1000 width reaches.
AtlasParams tune_for_porosity(const AtlasParams& params, double target_percent, double width);

}  // namespace trellis
