// Strategy 1 in path order (FgmOptions::order = Paths, include/trellis/slice/fgm.hpp): each
// planar path cut where it crosses an edge of a colour zone (an iso-line of a material fraction
// at a band edge), the runs between crossings coloured by the design at their middle, the pieces
// after a path's first joined into its bead; short runs merged along their bead where the
// gradient bound allows; a tool changer's pieces grouped by tool and chained nearest first.
#pragma once
#include <functional>
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/slice/fgm.hpp"

namespace trellis::fgm {

// The edges of closed rings bucketed in a uniform grid, for the crossings of segments with them.
class EdgeGrid {
 public:
  // Edges lying along the border of [lo, hi] (where contours of a set over that box close) are
  // left out: the paths cut by them lie inside the box.
  EdgeGrid(const std::vector<std::vector<Vec2>>& rings, Vec2 lo, Vec2 hi);
  // Parameters t in [0, 1] along a-b where it meets an edge, appended unsorted.
  void crossings(Vec2 a, Vec2 b, std::vector<double>& ts);
  bool empty() const { return edges_.empty(); }

 private:
  struct Edge {
    Vec2 a, b;
  };
  template <class Visit>
  void visit_cells(Vec2 a, Vec2 b, const Visit& visit) const;
  std::vector<Edge> edges_;
  Vec2 origin_{0, 0};
  double cell_ = 1;
  long nx_ = 0, ny_ = 0;
  std::vector<std::size_t> first_;  // CSR: cell c's edges are ids_[first_[c] .. first_[c + 1])
  std::vector<std::size_t> ids_;
  std::vector<std::size_t> stamp_;  // per edge: the query that saw it last
  std::size_t query_ = 0;
};

struct Piece {
  Path path;
  int color = 0;
};

// A layer's paths in their order, each cut where it crosses an edge in `edges`: the runs between
// crossings take the zone of the design at their middle (zones_at: the zones of a path's run
// middles, out[k] for point k, asked once per path), consecutive runs of one zone
// make one piece, whose colour colour_of(zone) gives (asked once per piece, in print order) and
// whose mixture is that colour's. A path's pieces together are the path (its points and the cut
// points, in order); the pieces after the first are joined.
std::vector<Piece> split_paths(
    const std::vector<Path>& paths, EdgeGrid& edges,
    const std::function<void(const std::vector<Vec2>&, std::vector<int>&)>& zones_at,
    const std::function<int(int)>& colour_of, const Palette& palette);

// The design's fractions along a path at z: every vertex and every 0.1 mm between.
std::vector<std::vector<double>> design_along(Evaluator& evaluator, double z, const Path& path);
// |design - mixture| over the materials: the largest over the samples (worst) or their mean.
double mixture_error(const std::vector<std::vector<double>>& samples,
                     const std::vector<double>& mixture, bool worst);

// Pieces of one bead (a piece and the joined ones after it) shorter than `min` printed in the
// colour of a neighbouring piece of that bead (the one nearest the design along it), where the
// design along the piece stays within the palette's error bound of that colour (to `tolerance`,
// the iso-lines' own); neighbours of one colour then become one piece. Counts merges in
// stats.short_merged and refusals in stats.short_kept_bound.
void merge_short_runs(std::vector<Piece>& pieces, Evaluator& evaluator, double z,
                      const Palette& palette, double min, double tolerance, FgmStats& stats);

// A tool changer's pieces of one layer: grouped by colour in palette order (reversed with
// `reverse`), each colour's pieces chained nearest first from `cursor` (updated; a piece may be
// printed backwards, a closed one from its nearest vertex), joined only where one ends where the
// next of its tool begins.
void group_by_tool(std::vector<Piece>& pieces, bool reverse, Vec2& cursor);

}  // namespace trellis::fgm
