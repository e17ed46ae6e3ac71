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

// Moves a point close to the curve onto it.
using CurveProjector = std::function<Vec2(Vec2)>;

// line: a polyline whose points lie on the curve; closed: its first and last points coincide
// (a loop). phase in [0, sl + gap): open lines start their pattern `phase` before their first
// point (so the first chord can be short); loops start `phase` along the loop and end `gap`
// before that start. The last chord of a line can be short. Chords are appended to `out` as
// two-point polylines.
void chord_vectors(const std::vector<Vec2>& line, bool closed, double sl, double gap, double phase,
                   const CurveProjector& project, std::vector<std::vector<Vec2>>& out);

// The polyline without its first (from_start) or last arc length `cut`; empty if nothing is left.
std::vector<Vec2> trim_arc(const std::vector<Vec2>& line, double cut, bool from_start);

}  // namespace trellis::pbf_detail
