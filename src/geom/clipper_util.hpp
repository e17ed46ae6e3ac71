// Internal: conversions between Trellis points (mm, double) and Clipper's integer points
// (kClipperScale units per mm), shared by the geom sources that call Clipper.
#pragma once
#include <clipper.hpp>
#include <cmath>
#include <vector>

#include "trellis/geom/polygon.hpp"

namespace trellis::clipper_util {

// std::llround inline, the same numbers for |x| < 2^52 (halves away from zero; x − i is exact):
// the library call was 2 % of slicing the Vase.
inline long long round_ll(double x) {
  const auto i = static_cast<long long>(x);
  const double f = x - static_cast<double>(i);
  return i + (f >= 0.5) - (f <= -0.5);
}
inline ClipperLib::IntPoint to_int(Vec2 p) {
  return {static_cast<ClipperLib::cInt>(round_ll(p.x * kClipperScale)),
          static_cast<ClipperLib::cInt>(round_ll(p.y * kClipperScale))};
}
inline Vec2 from_int(const ClipperLib::IntPoint& p) {
  return {static_cast<double>(p.X) / kClipperScale, static_cast<double>(p.Y) / kClipperScale};
}
inline ClipperLib::Path to_path(const std::vector<Vec2>& ring) {
  ClipperLib::Path path;
  path.reserve(ring.size());
  for (auto p : ring) path.push_back(to_int(p));
  return path;
}

// Clipper's closed output (rings that do not cross; outer rings of positive area) as polygons
// with holes, in the order Clipper's PolyTree gives them (clipper_nest.cpp).
std::vector<Polygon2> nest_paths(const ClipperLib::Paths& paths);

// Closed rings (outer counter-clockwise, holes clockwise) offset by `delta` units with mitred
// corners as ClipperOffset would, without its clean-up union: false (out unspecified) where the
// offset rings would cross, fold or change nesting, which that union must resolve
// (offset_direct.cpp).
bool offset_directly(const ClipperLib::Paths& rings, double delta, double miter_limit,
                     ClipperLib::Paths& out);

// Whether any two edges of the closed rings meet, other than neighbours in one ring at their
// shared point (offset_directly's check). Edges were bucketed in a uniform grid of cells
// 2 sqrt(area / edges) wide; where that grid would hold more than 16 entries an edge plus 64 the
// search gives up (true, `gave_up` set). The answer does not depend on how the pairs are found,
// giving up does, so that rule stays; otherwise (`sweep`) the pairs are found by a sweep along x
// while it tests fewer than 8 boxes an edge plus 256, by the grid after that (a slice's rings
// are curves of some hundred short edges: the grid's cells held some sqrt(edges) of them each,
// every pair of them tested, a tenth of slicing the Vase). `sweep` false: the grid alone.
bool rings_meet(const ClipperLib::Paths& rings, bool& gave_up, bool sweep = true);

}  // namespace trellis::clipper_util
