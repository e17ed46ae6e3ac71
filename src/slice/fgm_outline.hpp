// Strategy 2 in path order on a machine that changes the mixture along a bead (a mixing hotend,
// a temperature-graded filament; FgmOptions::order = Paths, not a tool changer): each island of
// a layer is filled as one piece, not face by face: fgm.perimeters rings around its outline and
// 100 % lines along the material iso-lines inside them (one direction where the island's
// iso-lines keep one, else lanes through sectors of directions), the lines joined into
// serpentines along the fill's edge (connect_fill), rings and serpentines chained into few beads.
// src/slice/fgm.cpp then cuts the beads at the colour zones' edges into joined pieces (Strategy
// 1's cutter, fgm_order.hpp), so a bead's mixture changes where it crosses a band edge.
#pragma once
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "fgm_fill.hpp"
#include "fgm_order.hpp"
#include "fgm_potential.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/fgm.hpp"
#include "trellis/slice/slice.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis::fgm {

struct OutlineStats {
  std::size_t islands = 0, rings = 0, lines = 0, serpentines = 0, beads = 0;
};

// The flow of the fill's lines: where the level lines of the potential lie further apart than a
// bead (|∇g| < 1) the bead is made wider by extruding more per millimetre, where they bunch
// narrower (flow = 1/|∇g|, clamped to [kMinFlow, kMaxFlow]), so the lines cover the fill and
// extrude its area. Looked up by position: a segment that lies on a fill line (a whole segment
// of one, or a piece of one cut at a colour edge) has that segment's flow; any other (rings,
// connectors) 1.
class LineFlow {
 public:
  static constexpr double kMinFlow = 0.5, kMaxFlow = 2.0;
  // A line's segments at factor / |∇g| (the level lines' spacing there, times `factor`).
  void add(const std::vector<Vec2>& line, const IsoPotential& potential, double factor);
  double at(Vec2 a, Vec2 b) const;
  bool empty() const { return segments_.empty(); }

 private:
  struct Segment {
    Vec2 a, b;
    double flow;
  };
  std::vector<Segment> segments_;
  // Segment indices by cell (a millimetre square), filled on the first lookup.
  mutable std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
  mutable bool indexed_ = false;
};

struct OutlineBeads {
  std::vector<Path> paths;  // uncut, no mixture
  LineFlow flow;
  OutlineStats stats;
};

// One layer's beads at height z, island by island nearest first from `cursor` (updated): per
// island its fgm.perimeters rings outside in, the first entered at its aligned seam, then the
// fill's serpentines and loops, chained by connectors inside the island that stay short or run
// over what is not printed yet. `potential` null or flat: lines at `angle` (fgm.fixed_angle);
// `phase`: the level lines at g = bead·(k + phase) (staggered every other layer). Travel between
// beads is routed inside the part (Path::via).
OutlineBeads outline_beads(const Regions& outline, const IsoPotential* potential, double angle,
                           double phase, const FgmOptions& options, double z, Vec2& cursor);

// One layer's beads as Strategy 2 plans them in path order: the potential over the outline's box
// (on the material grid), the lines staggered half a bead every other layer (part layer g),
// fixed_angle: lines at angle_deg, +90° every other layer. What plan_fgm_strategy2 then cuts.
OutlineBeads layer_beads(Evaluator& evaluator, const LayerOutline& layer, std::size_t g,
                         const FgmOptions& options);

// The parts of `fill` further than r from every line that hold a disk of radius r: the fill minus
// the lines stroked 2r wide, opened by r (inward then outward offsets of r). Computed only near
// the cells of a grid (r/2) whose centre lies in the fill and more than r - r/(2√2) from every
// line, with the stretches of lines that reach them: the same regions as the whole computation
// (src/slice/fgm_gap.cpp says why; tests/slice/test_fgm_gap.cpp compares them).
Regions fill_gaps(const Regions& fill, const std::vector<std::vector<Vec2>>& lines, double r);

// Pieces (cut by colour, in print order) split further where the fill's flow changes (quantised
// to 1/20; runs under 2 mm take the flow before them): the parts after a piece's first are joined
// to it, each with its flow (Path::flow, 0 where 1) and width (bead × flow).
void apply_flow(std::vector<Piece>& pieces, const LineFlow& flow, double bead);

}  // namespace trellis::fgm
