// Closed loops joined into one by bridges: where two loops run side by side about a line
// spacing apart, a short span of each is left out and two short cross connectors join them, so
// the path runs round one loop, crosses, round the other, and crosses back (the loops of a
// concentric fill joined into one path this way are the "connected" fills of Zhao et al.,
// Connected Fermat Spirals, SIGGRAPH 2016). Each bridge joins two loops into one, so a spanning
// tree of bridges makes a set of side-by-side loops one closed path, which can start anywhere:
// no ends, no extrusion starts. An open chain can take loops in the same way and keeps its two
// ends; two open chains are never bridged (that only swaps their ends).
//
// A bridge's spans are about a spacing long (each connector about a spacing, so the two
// connectors' beads cover what the two left-out spans would have), the two strands within
// max_turn of parallel along it, nothing else between them.
#pragma once
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis {

struct Strand {
  std::vector<Vec2> points;  // closed: first == last
  bool closed = true;
  // Its tree stays closed: no open strand joins it (e.g. the walls, which the outer wall's
  // seam reaches).
  bool stay_closed = false;
};

struct BridgeOptions {
  double spacing = 0.4;  // mm between neighbouring lines (a bead)
  // Strands are bridged where they are between `near` and `far` spacings apart.
  double near = 0.4, far = 1.6;
  double max_turn = 20;  // degrees between the two strands along a bridge
};

struct BridgeStats {
  std::size_t strands = 0, bridges = 0, results = 0;
};

// The strands joined by bridges into as few as the bridges allow (a spanning forest, cheapest
// bridges first: those nearest a spacing apart), each result a closed strand or, where it took
// an open one, open from that one's first point to its last; in the order of their first strand.
std::vector<Strand> bridge_strands(const std::vector<Strand>& strands, const BridgeOptions& options,
                                   BridgeStats* stats = nullptr);

}  // namespace trellis
