// Strategy 2's fill of one colour face (src/slice/fgm.cpp): lines along the iso-lines of the
// material fractions (one direction where the face's iso-lines keep one; elsewhere cut only
// where the iso-line direction leaves a sector of directions, not on a grid of squares, and
// continued across the sectors' edges into lanes), and the face's kept rings, lines and gap fill
// chained into few beads.
#pragma once
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/fgm.hpp"

namespace trellis::fgm {

// The direction of the iso-lines of the material fractions over a box at z: the structure tensor
// Σ ∇f ∇fᵀ (central differences of the fractions on a grid of `spacing` mm, one evaluation a
// node) interpolated bilinearly, its minor axis; `fallback` where the fractions are flat.
class IsoDirections {
 public:
  IsoDirections(Evaluator& evaluator, double z, Vec2 lo, Vec2 hi, double spacing, double fallback);
  double angle(Vec2 p) const;  // degrees in [0, 180)
  // The same where the iso-lines there have a direction (the tensor's anisotropy at least
  // `coherence`), else `fallback`.
  double angle_or(Vec2 p, double fallback, double coherence) const;
  // The mean iso-line direction over the region (sampled half a grid step apart, each sample's
  // direction with unit weight), in *spread the mean resultant length of the doubled angles (1
  // where every sample has that direction, 0 where they point every way), in *coherence the
  // samples' mean anisotropy (λ1 − λ2)/(λ1 + λ2) of the tensor (1 where the iso-lines of all
  // the fractions run one way, 0 where three materials' iso-lines cross at every angle).
  double mean_angle(const Regions& region, double* spread = nullptr,
                    double* coherence = nullptr) const;

 private:
  struct Tensor {
    double xx = 0, yy = 0, xy = 0;
  };
  Tensor at(Vec2 p) const;
  double angle_of(const Tensor& t) const;
  Vec2 lo_;
  double spacing_;
  double fallback_;
  long nx_ = 0, ny_ = 0;
  std::vector<Tensor> t_;
};

// Lines `spacing` apart filling `region` along the iso-lines: directions are cut into sectors of
// `sector` degrees (k·sector ± sector/2); where the local direction lies in sector k the region is
// hatched at k·sector, so a line is within half a sector of the iso-line and ends only where
// the direction leaves its sector (found by bisection) or at the region's edge. Pieces shorter
// than `min_length` are dropped. Where the iso-lines have no direction (three materials' crossing,
// IsoDirections::angle_or below 0.5) the direction is `fallback`. Each line is two points.
std::vector<std::vector<Vec2>> sector_lines(const Regions& region, const IsoDirections& directions,
                                            double sector, double spacing, double min_length,
                                            double fallback);

// Lines ending where a neighbouring sector's lines begin (sector_lines' cuts) joined into lanes
// along the iso-lines: ends within `reach` of each other that face each other (their lines
// continue one another, turning at most `max_turn` degrees) are paired nearest first, each end
// once. Lanes are open polylines, or closed (first == last) where they come round.
std::vector<std::vector<Vec2>> join_lanes(const std::vector<std::vector<Vec2>>& lines, double reach,
                                          double max_turn);

// How chain_pieces may join pieces.
struct ChainOptions {
  double max_connector = 1.2;  // mm: a connector this short joins whenever it stays inside
  // mm: a longer connector (a serpentine's turn along a boundary the lines meet at a shallow
  // angle) joins where at most half its centre line (away from its ends) is covered already
  double max_boundary_connector = 4;
  double bead = 0.4;             // mm
  BeadRaster* raster = nullptr;  // what is covered; connectors that join are painted into it
};

// A face's pieces (open polylines, or closed rings with first == last) chained into beads; a
// connector joins two pieces where ChainOptions allows it and it stays inside `inner` (the
// region the bead centres may occupy). A ring the material balance trimmed open is closed again
// across a gap a connector may bridge. Rings first, from `cursor`: each whole, entered at its
// point nearest where the last ended (ring to ring); then, from the last ring's end, the nearest
// open piece's nearer end next (lines into serpentines), a new bead where none may be joined;
// then beads whose ends may be joined are (a greedy matching, shortest connector first). The
// beads in print order, nearest first; `cursor` is updated to the last end.
std::vector<std::vector<Vec2>> chain_pieces(std::vector<std::vector<Vec2>> pieces,
                                            const Regions& inner, const ChainOptions& options,
                                            Vec2& cursor);

// A polygon of a face's inner region and the face's pieces that lie in it.
struct Island {
  Polygon2 region;
  int colour = 0;
  std::vector<std::vector<Vec2>> pieces;
};
// The faces' pieces (pieces[i] lie in inners[i]) by island (the polygon holding a piece's first
// point); islands without pieces are left out.
std::vector<Island> islands(const std::vector<ColorFace>& faces, const std::vector<Regions>& inners,
                            std::vector<std::vector<std::vector<Vec2>>> pieces);
// The distance from p to the nearest vertex of an island's pieces.
double island_distance(const Island& island, Vec2 p);

}  // namespace trellis::fgm
