// The AERO paper's semi-manual baseline (aero.method = periodic): a print path designed by hand
// for one unit cell and repeated over a periodic lattice ("manually designing the path to
// traverse a single unit and extrapolating it to an arbitrary number of cells"). The paper gives
// its counts (18 steps for the octet cell, more travel than AERO on the 3 x 3 x 3 octet in
// Fig. S6) and describes the BCC Print Paths 1 and 2 (Fig. 3b), not the paths themselves: the
// cell paths here are ours, written to those descriptions (docs/lattices-and-collisions.md).
//
// Cells print in layers of cells, bottom-up; in a layer every step of the cell path is printed
// in every cell before the next step, so the lattice rises evenly (the paper's Fig. 1a). A strut
// an earlier cell printed (a shared face) is skipped; pieces of one step that meet end to start
// across cells print as one trace, so a diagonal runs on through its row of cells.
#pragma once
#include <cstddef>
#include <vector>

#include "trellis/lattice/cells3d.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/plan/paths.hpp"

namespace trellis {

struct PeriodicParams {
  UnitCell cell = UnitCell::Octet;  // the lattice's cell: octet, bcc and cubic have a path
  double size = 7.0;                // cell side (mm); the lattice's lowest corner is a corner
  int print_path = 1;               // bcc: Print Path 1 (nodes side by side) or 2 (crossing)
};

struct PeriodicTrails {
  PathSet trails;             // in print order
  std::vector<int> material;  // per trail (a piece is split where the material changes)
};

// Steps of one cell's path (the paper's count for the octet cell is 18). Throws SettingError for
// a cell without a hand-made path or a print path other than 1 or 2.
std::size_t periodic_cell_steps(UnitCell cell, int print_path);

// Throws SettingError as above, GeometryError naming the first strut no cell's path prints (the
// lattice is not a lattice of that cell and size).
PeriodicTrails periodic_trails(const Graph& g, const PeriodicParams& params);

}  // namespace trellis
