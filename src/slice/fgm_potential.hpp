// The lines of Strategy 2's fill in path order (src/slice/fgm_outline.hpp): level lines of a
// potential g whose gradient is, in the least-squares sense, the unit normal n = ∇f/|∇f| of the
// material iso-lines. Where the iso-lines are evenly spaced g is f rescaled to millimetres, so
// its level lines a bead apart are the iso-lines a bead apart; where they spread or bunch
// (|∇f| changes along an iso-line, near saddles) no function has both (its level lines would
// have to be the iso-lines and a bead apart everywhere), and the least-squares g trades a few
// degrees of direction for spacing (|∇g| ≠ 1), which the fill makes up by extruding more or less
// per millimetre (flow = 1/|∇g|). Level lines never end inside the layer: they close or reach
// its edge, so paired along the edge into loops and bridged they make beads with no ends in the
// middle (lanes of hatch lines through sectors of directions end wherever the sectors do).
//
// g: bilinear over a grid of `spacing` mm, solved by conjugate gradients on the grid's edges
// (each edge's difference against n along it, weighted by |∇f|²/(|∇f|² + ε²) so the direction of
// nearly flat spots counts little), then again with each edge's target bent halfway towards g's
// own direction (three rounds: spacing kept better near saddles and folds). Two materials: f is
// the first fraction; three: the fraction that varies most over the layer (no direction follows
// all three: their iso-lines cross).
#pragma once
#include <cstdint>
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/geom/polygon.hpp"

namespace trellis::fgm {

// The material fractions at the nodes of a grid `spacing` apart from lo covering the box lo–hi:
// nx × ny nodes (at least 2 × 2), row by row.
std::vector<std::vector<double>> sample_fractions(Evaluator& evaluator, double z, Vec2 lo, Vec2 hi,
                                                  double spacing, long& nx, long& ny);

class IsoPotential {
 public:
  // Over the rectangle [lo, hi] at height z; where the fractions are flat everywhere (no
  // gradient), flat() is true and there are no level lines.
  IsoPotential(Evaluator& evaluator, double z, Vec2 lo, Vec2 hi, double spacing);
  bool flat() const { return flat_; }
  Vec2 gradient(Vec2 p) const;  // of the bilinear g (mm/mm)
  // The level lines g = step·(k + phase) for every integer k, as polylines (closed ones with
  // first == last), each directed with lower g on its left.
  // `only`: just level k = *only.
  std::vector<std::vector<Vec2>> level_lines(double step, double phase,
                                             const std::int64_t* only = nullptr) const;
  double value(Vec2 p) const;  // the bilinear g
  std::size_t iterations() const { return iterations_; }

 private:
  double node(long i, long j) const { return g_[static_cast<std::size_t>(j * nx_ + i)]; }
  // The grid cell holding p (clamped to the grid) and p's place in it (0..1 each way).
  struct Cell {
    long i, j;
    double u, v;
  };
  Cell cell(Vec2 p) const;
  Vec2 lo_;
  double h_;
  long nx_ = 0, ny_ = 0;
  std::vector<double> g_;
  bool flat_ = true;
  std::size_t iterations_ = 0;
};

}  // namespace trellis::fgm
