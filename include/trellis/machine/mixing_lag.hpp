// What a mixing hotend deposits, read back from its G-code. The writer issues each mixture change
// gradient.lookahead mm of printed path before the region it is for, so the mixing chamber's dead
// volume has been pushed out by the time the nozzle gets there (FGM paper, Strategy 2); our files
// record that distance in their header ("; mixture lookahead = L mm"). Read back, each path
// carries the mixture *commanded* while it was printed; the mixture *deposited* there is the one
// commanded L mm of printed path earlier. The first mixture of a print is taken as deposited from
// where it was commanded (the chamber starts primed with it: nothing else was commanded before).
#pragma once
#include <vector>

#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// Sets each path's mixture to the deposited one, `lookahead_mm` of printed path after it was
// commanded: a path is split where the deposited mixture changes inside it (the pieces after the
// first are `joined`, one bead; a change within 0.05 mm of a point falls on that point). Returns
// the commanded mixture of every path afterwards, in print order. lookahead_mm <= 0 changes
// nothing.
std::vector<std::vector<double>> deposit_mixtures(Toolpath& toolpath, double lookahead_mm);

// Joins each `joined` path to the path before it (same layer, starting where it ends) when
// nothing a path carries differs (role, tool, mixture, width, height, temperature, power, flow,
// fan, part): after deposit_mixtures, a path the reader cut only where a commanded mixture
// changed is one path again, as it was planned.
void merge_joined_pieces(Toolpath& toolpath);

}  // namespace trellis
