// Iso-contours of a scalar function on a plane (marching squares with root refinement) and the
// stitching of unordered segments into polylines. Used for layer outlines straight from an
// implicit field, for material iso-lines, and (stitching) for mesh slices.
#pragma once
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/geom/polygon.hpp"

namespace trellis {

// A scalar function of (x, y) on some plane.
class PlaneFunction {
 public:
  virtual ~PlaneFunction() = default;
  virtual void sample(const Vec2* points, double* out, std::size_t n) = 0;
  // The same for the nodes origin + (i, j)·step, i < w, j < rows, row by row (`points` holds
  // them), as marching squares samples its blocks: functions that cache values on a grid
  // override it to index their cache directly.
  virtual void sample_grid(Vec2 origin, double step, std::size_t w, std::size_t rows,
                           const Vec2* points, double* out) {
    (void)origin, (void)step;
    sample(points, out, w * rows);
  }
  // A hint that bound() is about to be asked for these n rectangles (a cache of bounds can start
  // loading them all at once). Default: nothing.
  virtual void prefetch_bounds(const Vec2* lo, const Vec2* hi, std::size_t n) {
    (void)lo, (void)hi, (void)n;
  }
  // Conservative range of values over the rectangle; (-inf, inf) when unknown.
  virtual Interval bound(Vec2 lo, Vec2 hi) {
    return {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  }
  // A crossing of the level on the grid edge from node (i, j) (lo + (i, j)·resolution) to its
  // +x neighbour (vertical: +y), values fa and fb on opposite sides, that the function already
  // knows to within the march's refinement tolerance, as the parameter t in (0, 1) along the
  // edge (e.g. a finer march's crossing of a function that decides this one there); −1 when it
  // knows none. Such candidates are checked all together with `confirm_crossings` and taken
  // without refinement where confirmed. Default: none.
  virtual double known_crossing(std::size_t i, std::size_t j, bool vertical, double fa, double fb) {
    (void)i, (void)j, (void)vertical, (void)fa, (void)fb;
    return -1;
  }
  // ok[k] = 1 if points[k], a candidate from known_crossing, is a crossing of this function
  // to within the tolerance, else 0 (the crossing is then refined as usual).
  virtual void confirm_crossings(const Vec2* points, std::size_t n, unsigned char* ok) {
    (void)points;
    for (std::size_t k = 0; k < n; ++k) ok[k] = 0;
  }
  // A function that repeats across the plane: its period along x and y (mm; 0: none), and
  // whether it equals that repeating function on the rectangle [lo, hi] — the same sign at every
  // point, the same level set, the same answers from bound() and known_crossing() up to the
  // translation (e.g. a TPMS sheet where the part's envelope is negative throughout). The march
  // then contours one period's blocks and translates their crossings to the others.
  virtual Vec2 period() const { return {0, 0}; }
  virtual bool periodic(Vec2 lo, Vec2 hi) {
    (void)lo, (void)hi;
    return false;
  }
};

struct StitchedLines {
  std::vector<std::vector<Vec2>> loops;  // closed, first point not repeated
  std::vector<std::vector<Vec2>> open;   // open polylines
};

// Joins directed segments end to start. Ends closer than `tolerance` are the same point
// (the FGM paper's fuzzy comparison, 1e-6 mm for desktop printers). Zero-length segments drop.
StitchedLines stitch_segments(const std::vector<Segment2>& segments, double tolerance = 1e-6);

// The lines of one period's tiles (see MarchOptions::tiles_out), for other marches to translate.
struct PeriodTileData;
struct PeriodTiles {
  std::shared_ptr<const PeriodTileData> data;  // none: the march made no tiles
  std::size_t bytes = 0;                       // the memory they hold
};

// The tiles of the function g(p) = ±f(2c − p) (f's point reflection about a centre c), made from
// f's tiles: grid node k of f's tiles (in cells from their origin) is node s − k of g's, modulo
// the period; s must be a multiple of the tile side along each axis (else no tiles are made).
// `reverse`: g = −f(2c − p) (inside and outside swap, the lines run the other way); h: the
// tiles' grid step. Crossings keep their places to a float's precision (6e-8 of an edge).
PeriodTiles point_reflected_tiles(const PeriodTiles& tiles, double h, std::size_t sx,
                                  std::size_t sy, bool reverse);
// A period as a whole number of grid cells of side h (within 1e-6 of one), else 0 (not tiled).
std::size_t period_cells(double period, double h);
// The side (in cells) of the tiles of a period of `period_cells` cells that a march with
// `tile_block` wanted makes (MarchOptions::tile_block); 0: that period is not tiled.
std::size_t period_tile_side(std::size_t period_cells, std::size_t tile_block);

struct MarchOptions {
  double resolution = 0.1;  // grid step (mm)
  // Crossings are refined on the function until the bracket is below this fraction of the
  // resolution (1e-4: within 0.01% of a cell of the true crossing).
  double refine_fraction = 1e-4;
  int max_refine_iterations = 60;
  // Also stop refining a crossing once |f - level| <= this (0: position only).
  double value_tolerance = 0;
  std::size_t block = 16;  // cells per block side for bound-based skipping
  // Start each crossing's refinement at the root of the cubic through the grid values on the
  // edge's line (two nodes either side, where the block has them) instead of the straight
  // line's: fewer refinement samples for smooth functions, the same tolerance.
  bool cubic_guess = false;
  // Where the function declares a period that is a whole number of grid cells (see
  // PlaneFunction::period), blocks where it is periodic are contoured once per period and
  // translated; false: every block is contoured on its own (the crossings move within the
  // refinement tolerance, nothing else).
  bool periodic_tiles = true;
  // The tiles' side in cells: the divisor of the period closest to this (by ratio). Blocks across
  // the edge of the periodic region are split, their periodic quarters taken from the tiles cell
  // by cell; each block costs a little on its own.
  std::size_t tile_block = 8;
  // Also put a point in the middle of every segment (between two crossings), moved onto the
  // level by one Newton step along the segment's normal from a forward difference, at most a
  // quarter of the segment: the outline's chords halved onto the curve (as translated with the
  // periodic tiles).
  bool segment_midpoints = false;
  // Midpoints closer than this to their segment are left out (the segment is then that close
  // to the curve where it bulges most).
  double midpoint_min_offset = 0;
  // If set, filled with every crossing by its grid edge (after refinement).
  std::vector<struct EdgeCrossing>* edge_crossings = nullptr;
  // Every periodic block takes its lines from these tiles, made by a march with tiles_out of the
  // same periodic function (translated along the plane or a period along another axis, e.g. the
  // layer a period below) on a grid that is the same modulo the period: none is marched here.
  // Ignored unless they have this march's period and tile side and every place's tile.
  const PeriodTiles* tiles_in = nullptr;
  // Instead of contouring: the rectangle is one period of a function periodic throughout,
  // starting at a node of the grid of the marches that take these tiles; every place's tile is
  // marched and put here, and no lines are returned.
  PeriodTiles* tiles_out = nullptr;
};

// A crossing on the grid edge from node (i, j) (lo + (i, j)·resolution) to (i + 1, j), or to
// (i, j + 1) when vertical, at the parameter t in (0, 1) along it.
struct EdgeCrossing {
  std::size_t i, j;
  bool vertical;
  double t;
};

// The root in (0, 1) of the polynomial through (−1, before), (0, fa), (1, fb), (2, after)
// (fa, fb of opposite signs; a neighbour NaN when missing: a quadratic through the other three),
// by Newton steps from the straight line's root; −1 when there is none to trust (no neighbour,
// or a step leaves the edge).
double crossing_guess(double before, double fa, double fb, double after);

struct ContourSet {
  // Loops are oriented with the region where f < level on their left: outer rings
  // counter-clockwise, holes clockwise. Open lines end on the domain's border.
  StitchedLines lines;
  std::size_t samples = 0;         // function evaluations (grid + refinement)
  std::size_t skipped_blocks = 0;  // blocks skipped by bounds
  std::size_t blocks = 0;
  std::size_t tiled_blocks = 0;  // top blocks translated from another period's (no samples)
  std::size_t tiled_parts = 0;   // smaller blocks (along a boundary) translated by cells
};

// Contours f = level over the rectangle [lo, hi]. The grid covers the rectangle with whole cells
// of `resolution` starting at lo.
ContourSet march_squares(PlaneFunction& f, Vec2 lo, Vec2 hi, double level,
                         const MarchOptions& options = {});

}  // namespace trellis
