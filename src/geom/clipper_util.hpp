// Internal: conversions between Trellis points (mm, double) and Clipper's integer points
// (kClipperScale units per mm), shared by the geom sources that call Clipper.
#pragma once
#include <clipper.hpp>
#include <cmath>
#include <vector>

#include "trellis/geom/polygon.hpp"

namespace trellis::clipper_util {

inline ClipperLib::IntPoint to_int(Vec2 p) {
  return {static_cast<ClipperLib::cInt>(std::llround(p.x * kClipperScale)),
          static_cast<ClipperLib::cInt>(std::llround(p.y * kClipperScale))};
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

}  // namespace trellis::clipper_util
