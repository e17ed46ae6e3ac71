// Contour scan vectors as the PBF paper draws them (Fig. 2(a-iv)): straight chords of length SL
// with both ends on the mid-curve φ = 0, consecutive chords LHD apart (the straight distance
// from one chord's end to the next one's start, also on the curve), the pattern moved along the
// curve from layer to layer. A chord cuts across a bend (its sagitta is SL²/8R on a curve of
// radius R): the paper's "inaccuracies in representing curved contours" at large SL.
#pragma once
#include <functional>
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis::pbf_detail {

// The curve φ = 0 in the layer's plane: `field` gives φ at a point and its gradient in the
// plane (into *grad). A point the chords' Newton steps would move further than `reach` from
// where it started (a near-zero gradient, another branch of the curve) keeps its place.
struct Curve {
  std::function<double(Vec2, Vec2* grad)> field;
  double reach = 0;
};

// The point moved onto the curve by Newton steps along the gradient (at most two; a step under
// 1e-7 mm is the last: Newton converges quadratically, so the next would move it by ~1e-14 mm).
Vec2 project(const Curve& curve, Vec2 q);

// line: a polyline whose points lie on the curve; closed: its first and last points coincide
// (a loop). phase in [0, sl + gap): open lines start their pattern `phase` before their first
// point (so the first chord can be short); loops start `phase` along the loop and end `gap`
// before that start. The last chord of a line can be short. Chords are appended to `out` as
// two-point polylines.
void chord_vectors(const std::vector<Vec2>& line, bool closed, double sl, double gap, double phase,
                   const Curve& curve, std::vector<std::vector<Vec2>>& out);

// The polyline without its first (from_start) or last arc length `cut`; empty if nothing is left.
std::vector<Vec2> trim_arc(const std::vector<Vec2>& line, double cut, bool from_start);

}  // namespace trellis::pbf_detail
