// Closed polygons (with holes) and open segments in the plane, and the clipping of open
// segments by a closed region, done by Clipper on integer coordinates.
#pragma once
#include <utility>
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis {

// A closed region: one outer ring (counter-clockwise) and holes. The closing edge is implicit.
struct Polygon2 {
  std::vector<Vec2> outer;
  std::vector<std::vector<Vec2>> holes;
};

struct Segment2 {
  Vec2 a, b;
};

Polygon2 make_rectangle(Vec2 center, double width, double height);
// Regular polygon inscribed in the circle with chords no farther than `max_error` mm from it.
Polygon2 make_circle(Vec2 center, double diameter, double max_error = 1e-3);

// Clipper works on 64-bit integers: 1 unit = 1 nm (kClipperScale units per mm). Coordinates up to
// ±9e6 m fit; results are exact to 1 nm. Segment ends that were not cut keep their exact input
// coordinates (matched back after clipping).
inline constexpr double kClipperScale = 1e6;

// Pieces of `segments` inside `region` (boundary included).
std::vector<Segment2> clip_segments(const std::vector<Segment2>& segments, const Polygon2& region);

// Whether p lies inside the region or on its boundary (within `tol`).
bool contains(const Polygon2& region, Vec2 p, double tol = 1e-9);
// Even-odd crossing test of one ring (no tolerance: a point on the edge may go either way).
bool inside_ring(const std::vector<Vec2>& ring, Vec2 p);

// A pixel grid over a box in which round beads are painted along segments (what a set of paths
// covers), for coverage checks and gap finding. Hand-written: a union of thousands of
// overlapping bead polygons costs far more than painting pixels.
class BeadRaster {
 public:
  BeadRaster(BBox2 box, double pixel);
  // Pixels whose centre lies within `radius` of the segment a-b.
  void paint(Vec2 a, Vec2 b, double radius);
  bool covered(long ix, long iy) const {
    return cells_[static_cast<std::size_t>(iy * nx_ + ix)] != 0;
  }
  void set(long ix, long iy) { cells_[static_cast<std::size_t>(iy * nx_ + ix)] = 1; }
  // Whether the pixel holding p is painted (false outside the raster).
  bool covered_at(Vec2 p) const {
    const double fx = (p.x - box_.min.x) / pixel_, fy = (p.y - box_.min.y) / pixel_;
    if (!(fx >= 0) || !(fy >= 0) || fx >= static_cast<double>(nx_) ||
        fy >= static_cast<double>(ny_))
      return false;
    return covered(static_cast<long>(fx), static_cast<long>(fy));
  }
  Vec2 centre(long ix, long iy) const {
    return {box_.min.x + (static_cast<double>(ix) + 0.5) * pixel_,
            box_.min.y + (static_cast<double>(iy) + 0.5) * pixel_};
  }
  long nx() const { return nx_; }
  long ny() const { return ny_; }
  double pixel() const { return pixel_; }

 private:
  BBox2 box_;
  double pixel_;
  long nx_, ny_;
  std::vector<char> cells_;
};

// Points on the boundary of `region`, each inserted into the ring edge it lies on: returns the
// rings (outer first) as closed point loops including those points, ordered along each edge.
std::vector<std::vector<Vec2>> rings_with_points(const Polygon2& region,
                                                 const std::vector<Vec2>& points, double tol);

}  // namespace trellis
