// Non-planar slicing for printing inside a support bath (non-planar embedded bioprinting paper,
// §2.1, §3.1) and lattices laid on curved surfaces (GIPPO's non-planar feature).
//
// A surface is a height field z = f(x, y) over a footprint: an open triangle mesh with no point
// above another, or a function. Layer paths are the surface's sections by vertical planes spaced
// by the path width, joined end to end by nearest neighbour into one continuous serpentine per
// layer, and the layers are copies of the surface lifted by the layer height (vertically, as in
// the paper, or along the surface normal for an even thickness). Everything ends in the toolpath
// IR, so the embedded writer, the G-code reader and the previews work unchanged.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "trellis/core/run_context.hpp"
#include "trellis/core/vec.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct TriangleMesh;

// z = f(x, y) over a footprint inside `domain`. Cheap to copy, safe to share between threads.
class HeightField {
 public:
  // Any function; NaN (or ±inf) where the surface does not exist. `make` is called once per
  // thread and returns that thread's evaluator (so stateful evaluators such as muparser work).
  using Eval = std::function<double(double, double)>;
  static HeightField from_function(std::function<Eval()> make, BBox2 domain, std::string name);
  // A muparser expression in x and y (with pi, e, sqrt, sin ...); NaN outside the footprint, so
  // e.g. sqrt(100-x^2-y^2) is a cap over a disc. Throws ParseError naming the column.
  static HeightField from_expression(const std::string& expr, BBox2 domain, std::string name);
  // An open (or closed: then not a height field) triangle mesh. Throws GeometryError naming the
  // triangle and the place if it is not a height field (a vertical facet, or two facets above
  // one another); the planes of a slice are checked again, exactly, as they are cut.
  static HeightField from_mesh(const TriangleMesh& mesh, std::string name);
  // A filleted profile z(x) (below) extruded along Y from y0 to y1.
  static HeightField from_profile(const struct Profile& profile, double y0, double y1,
                                  std::string name);

  const std::string& name() const;
  BBox2 domain() const;
  bool is_mesh() const;
  // z at (x, y); NaN outside the footprint. For meshes, the facet under the point.
  double height(Vec2 p) const;
  // Per-thread evaluator for many queries (functions only; meshes return height()).
  Eval evaluator() const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::shared_ptr<const Impl> impl_;
};

enum class OffsetMode { Vertical, Normal };
OffsetMode offset_mode_from_string(const std::string& name);  // vertical | normal
const char* to_string(OffsetMode m);

struct NonplanarParams {
  double width = 0.4;         // path width = plane spacing (mm)
  double layer_height = 0.3;  // mm
  int layers = 6;
  // Plane direction per layer in degrees from +X (0 = paths along X), cycled over the layers:
  // {0, 90} is the paper's cross-hatch, {0} keeps one direction.
  std::vector<double> angles{0, 90};
  OffsetMode offset = OffsetMode::Vertical;
  double chord_tolerance = 0.005;  // max distance of a path segment from the surface (mm)
  // Ends closer than this (XY) are joined by an extruded connector that follows the surface when
  // the connector stays over the footprint; otherwise the nozzle travels. 0 = 4 × width.
  double max_join = 0;
  // Tool per layer, cycled; e.g. {0,0,0,1,1,1,0,0,0} for the paper's black/clear/black M.
  std::vector<int> layer_tools{0};
  double speed = 0;  // mm/s on every path, 0 = profile default
  // false: lines `width` apart in the slicing direction (the paper's, and its stated limit:
  // on a 45° slope they lie 1.41 widths apart on the surface); true: `width` apart along the
  // surface (arc length across the lines, averaged along them; exact for extruded profiles).
  bool spacing_along_surface = false;
};

struct NonplanarLayerReport {
  double offset = 0;  // mm above (or along the normal from) the surface
  double angle = 0;
  int tool = 0;
  std::size_t lines = 0;         // plane sections (major paths)
  std::size_t paths = 0;         // continuous paths after joining
  std::size_t travel_moves = 0;  // within the layer
  double length = 0;             // extruded path length (mm)
  double connector_length = 0;   // of it, joining lines (mm)
  std::size_t jumps = 0;         // places where the surface jumps: paths split there, no bridge
  std::size_t hole_joins = 0;    // connectors that go around a hole along its edge
};

struct NonplanarResult {
  Toolpath toolpath;
  std::vector<NonplanarLayerReport> layers;
  double max_descent_deg = 0;  // steepest downward segment
};

// Where the lines of a layer at `angle_deg` lie: their offsets v along the direction across them
// (n = (-sin, cos) of the angle), in increasing order.
std::vector<double> nonplanar_line_positions(const HeightField& surface, double angle_deg,
                                             const NonplanarParams& params);

// Plans every layer (layers in parallel). Throws GeometryError when a plane meets the surface
// twice above one point (not a height field), naming the place.
// `context` (core/run_context.hpp): stage "layers" from the calling thread; cancel checked per
// layer; the layers' sections on its threads.
NonplanarResult slice_nonplanar(const HeightField& surface, const NonplanarParams& params,
                                const RunContext& context = {});

// The planar control of a non-planar print (the non-planar paper's Fig. 3C/E, its Cura slice):
// the solid the non-planar layers fill (vertical offsets: from the surface up to layers × layer
// height above it) cut by flat planes at the layer height, each piece printed by the tool of the
// non-planar layer group it lies in (params.layer_tools: a group is a run of layers with one
// tool, and its band of the solid is sliced as a part of its own). Every band gets one wall and
// solid fill at params.width, the fill along params.angles[0], turning 90° every layer. In each
// flat layer the tool the layer below ended with prints first. Layer i's nozzle is at
// (i + 1) · layer_height above the solid's lowest point. Throws SettingError for normal offsets
// (the bands are vertical offsets of the surface).
struct PlanarControlResult {
  Toolpath toolpath;
  std::size_t layers_with_several_tools = 0;  // flat layers that need a tool change to finish
  std::size_t tool_changes = 0;               // between consecutive paths, over the whole print
};
PlanarControlResult slice_planar_control(const HeightField& surface, const NonplanarParams& params,
                                         const RunContext& context = {});

// Independent check: every path point's distance from the surface offset of its layer, and the
// distance of segment midpoints (chords) from it. Vertical mode: |z − f(x,y) − k·h|; normal
// mode: the distance to the surface found by minimisation, minus k·h.
struct SurfaceDeviation {
  double max_point = 0, max_chord = 0;
  Vec3 worst;        // where max_point occurs
  Vec3 worst_chord;  // the midpoint of the segment where max_chord occurs
};
SurfaceDeviation surface_deviation(const Toolpath& toolpath, const HeightField& surface,
                                   const NonplanarParams& params);

// Fraction of the footprint (rasterised at `pixel` mm) covered by the XY projection of layer
// `layer`'s beads (width params.width).
double footprint_coverage(const Toolpath& toolpath, std::size_t layer, const HeightField& surface,
                          double width, double pixel = 0.02);

// --- test surfaces (the paper's) ---
// 2D profiles z(x) made of straight pieces with tangent circular fillets at the corners.
struct Profile {
  std::vector<Vec2> corners;  // (x, z), x increasing
  double fillet_radius = 0;   // mm, at every interior corner
};
// z(x) of a filleted profile (x clamped to the ends). Throws GeometryError unless x increases.
std::function<double(double)> profile_function(const Profile& p);
// The x values where the profile's pieces meet, plus points along the arcs so that straight
// pieces between them stay within `tol` of it (for exact meshes of extruded profiles).
std::vector<double> profile_breaks(const Profile& p, double tol = 1e-3);

struct CorrugationParams {
  double length = 44, width = 16;  // mm (paper §2.6)
  double periods = 5;              // full periods of the wave (0, 2.5, 5, 10 in the paper)
  double angle_deg = 45;           // slope of the wave
  double amplitude_scale = 1;      // 1, 0.5, 0.25, 0 (flat) in the paper
  double fillet_diameter = 0.5;    // at peaks and valleys (0, 0.5, 1, 2 mm)
  double flat_length = 7;          // flat clamping end at each side (mm)
};
Profile corrugation_profile(const CorrugationParams& p);
HeightField corrugation(const CorrugationParams& p);

struct MiuraParams {
  double length = 44, width = 16;
  double depth = 4;         // fold depth (0, 2, 4, 6 mm in the paper)
  double periods_x = 4;     // zig-zag periods of the creases along the length
  double periods_y = 2;     // fold periods across the width
  double shift = 2;         // sideways zig-zag of the folds (mm)
  double taper_length = 0;  // fold depth ramps up from 0 over this length at both ends (mm)
};
HeightField miura(const MiuraParams& p);

struct MCurveParams {
  double length = 30, width = 10, height = 8;  // an "M" profile (paper Fig. 3)
  double fillet_diameter = 2;
};
HeightField m_curve(const MCurveParams& p);

// A spherical cap of `radius` over a disc of `diameter` (footprint), its rim at z = 0.
HeightField sphere_cap(double radius, double diameter);

// A grid mesh of a surface (two triangles per cell of `resolution` mm, cells over the footprint
// only); profiles extruded along Y use their own x breakpoints (exact).
TriangleMesh surface_mesh(const HeightField& surface, double resolution);

// The print-angle test (paper §2.5, Fig. 2): one line per angle, spaced `spacing` apart in Y; each
// cycle is horizontal, a move at the angle (positive up) by `rise`, horizontal, and back at the
// opposite angle, until `length` is spanned.
struct AngleTestParams {
  std::vector<double> angles{0, 22.5, 45, 67.5, 90, -22.5, -45, -67.5, -80};
  double length = 40, spacing = 4, rise = 2, flat = 2;
  double base_z = 5;  // height of the horizontal runs (mm), inside the bath
};
Toolpath angle_test(const AngleTestParams& p);

// --- lattices on surfaces (GIPPO non-planar) ---
struct ProjectParams {
  Vec3 direction{0, 0, -1};  // projection direction (towards the surface)
  double layer_height = 0;   // mm between the planar toolpath's layers; 0 = from its z values
  OffsetMode offset = OffsetMode::Normal;
  double chord_tolerance = 0.005;
};
// Lays a planned planar toolpath (e.g. a GIPPO lattice, layers stacked) on the surface: every
// point is projected along `direction`, segments densified to follow the surface within the
// chord tolerance, layer k offset by k·layer height (vertically or along the normal). Throws
// GeometryError naming the point when a path leaves the footprint.
Toolpath project_onto_surface(const Toolpath& planar, const HeightField& surface,
                              const ProjectParams& params);

}  // namespace trellis
