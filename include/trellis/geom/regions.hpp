// Region operations on sets of polygons with holes: offsets and Booleans (Clipper), areas,
// simplification, and parallel hatch lines clipped exactly to a region (a scan-line sweep).
#pragma once
#include <vector>

#include "trellis/geom/polygon.hpp"

namespace trellis {

using Regions = std::vector<Polygon2>;

double signed_area(const std::vector<Vec2>& ring);  // counter-clockwise positive
double area(const Polygon2& polygon);               // outer minus holes
double area(const Regions& regions);

// Closed rings (any orientation) → polygons with holes, nested by even-odd (Clipper PolyTree).
Regions nest_rings(const std::vector<std::vector<Vec2>>& rings);

// The same for rings that are already oriented (outer counter-clockwise, holes clockwise) and
// do not cross, as marching squares and closed-mesh slices give: each hole goes to the smallest
// outer ring containing it. Linear-ish instead of Clipper's quadratic nesting. If the total
// area is negative (an inside-out mesh) all rings are flipped first.
Regions nest_oriented_rings(std::vector<std::vector<Vec2>> rings);
// Oriented rings that may overlap (a repaired mesh's shells often intersect one another): the
// points of positive winding number, i.e. the union of the solids, as a slicer must print them.
Regions unite_oriented_rings(const std::vector<std::vector<Vec2>>& rings);

// Inward (delta < 0) or outward offset. Corners: mitred up to 2× delta, rounded beyond, with
// arcs no farther than `arc_tolerance` from the true offset.
// Corners are mitred up to `miter_limit` times |delta| from the offset edges (then squared off).
Regions offset(const Regions& regions, double delta, double arc_tolerance = 0.002,
               double miter_limit = 2.0);
// The area round beads of `width` cover along polylines (closed when first == last).
Regions stroke(const std::vector<std::vector<Vec2>>& lines, double width,
               double arc_tolerance = 0.002);
Regions unite(const Regions& a, const Regions& b);
Regions difference(const Regions& a, const Regions& b);
Regions intersection(const Regions& a, const Regions& b);

// Douglas–Peucker on each ring, keeping every point within `tolerance` of the original outline.
Regions simplify(const Regions& regions, double tolerance);
// Douglas–Peucker on an open polyline in 3D: keeps both ends and every point needed for the
// result to stay within `tolerance` of the original.
std::vector<Vec3> simplify_polyline(const std::vector<Vec3>& points, double tolerance);

// Closed loops of a region set, as rings (outer counter-clockwise, holes clockwise).
std::vector<std::vector<Vec2>> rings_of(const Regions& regions);

// Pieces of open polylines inside the region (boundary included), or with inside = false the
// pieces outside it, as polylines; cut points lie on the input polylines (to Clipper's 1 nm grid).
std::vector<std::vector<Vec2>> clip_polylines(const std::vector<std::vector<Vec2>>& lines,
                                              const Regions& region, bool inside = true);

// Lines at `angle_deg` spaced `spacing` apart, phase fixed by `origin` (a line passes through it),
// cut by the region (even-odd over all rings). Returned in sweep order, each from low to high
// along the line direction.
std::vector<Segment2> hatch(const Regions& regions, double angle_deg, double spacing,
                            Vec2 origin = {0, 0});

// The hatch of `keep` minus `cut`, each vector kept at least `inset` from both regions' outlines
// (as hatching the inward offset of keep − cut by `inset`, without building that polygon): laser
// beam compensation. Same lines, order and direction as hatch().
std::vector<Segment2> hatch_inset(const Regions& keep, const Regions& cut, double angle_deg,
                                  double spacing, double inset, Vec2 origin = {0, 0});
// The step behind it: hatch segments (from hatch() with the same angle, spacing and origin) with
// the stretches within `inset` of the region's outline taken out, and with remove_inside the
// region's own stretches too.
std::vector<Segment2> trim_hatch(const std::vector<Segment2>& segments, const Regions& region,
                                 double angle_deg, double spacing, double inset, bool remove_inside,
                                 Vec2 origin = {0, 0});

}  // namespace trellis
