// The 2D lattice atlas (GIPPO §Design generation): periodic and stochastic planar patterns,
// generated over at least twice the region, rotated, then cropped to the region with a new node
// wherever the crop cuts a strut. Optional outer contour and tensile-test handles.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/lattice/graph.hpp"

namespace trellis {

enum class Pattern {
  Honeycomb,           // regular hexagons; cell = hexagon side (= circumradius)
  Voronoi,             // seeded Voronoi of uniform random points; density = seeds per mm²
  Penrose,             // P3 rhombus tiling (Robinson-triangle deflation); cell = rhombus side
  SnubSquare,          // 3.3.4.3.4 tiling; cell = edge length
  Arrowhead,           // auxetic double arrowhead; cell = horizontal period
  ReentrantHoneycomb,  // auxetic bow-tie honeycomb; cell = horizontal period
  Square,              // square grid; strand distance = cell
  Triangle,            // triangular grid; strand distance = distance between parallel strands
  Lines,               // parallel strands (woodpile when rotated 90° per layer)
};

const std::vector<std::string>& pattern_names();
std::string to_string(Pattern p);
Pattern pattern_from_string(const std::string& name);  // throws SettingError

enum class RegionShape { Rectangle, Circle };

struct Region {
  RegionShape shape = RegionShape::Rectangle;
  Vec2 center{0, 0};
  double width = 10, height = 10;  // rectangle (mm)
  double diameter = 10;            // circle (mm)
  Polygon2 polygon() const;
};

struct AtlasParams {
  Pattern pattern = Pattern::Honeycomb;
  double cell_size = 1.0;           // pattern length scale (mm), see Pattern
  double strand_distance = 0;       // Square/Triangle/Lines spacing (mm); 0 = cell_size
  double rotation_deg = 0;          // pattern rotation about the region centre
  double voronoi_density = 1.0;     // Voronoi seeds per mm²
  double reentrant_angle_deg = 30;  // ReentrantHoneycomb strut angle below horizontal
  double arrowhead_outer_deg = 60;  // Arrowhead outer chevron angle
  double arrowhead_inner_deg = 30;  // Arrowhead inner chevron angle
  // The auxetic patterns' second length (GIPPO paper Table 1: "vertical and horizontal lengths
  // of the unit cell"; cell_size is the horizontal one): the unit cell's period in Y (mm). With
  // it, the arrowhead's inner angle and the re-entrant honeycomb's rib length follow from the
  // other settings; 0 = from the angles alone.
  double cell_height = 0;
  std::uint64_t seed = 1;  // Voronoi seeds
  Region region;
  double z = 0;          // height of the lattice plane (mm)
  bool contour = false;  // add the region outline as struts
  // Clamping rings (GIPPO paper: the Ø48 ball-burst discs carry "additional contours ... for
  // better adhesion with the testing hardware"): this many concentric outlines of the region,
  // `ring_spacing` apart inward from its outline, the pattern cropped to the innermost. 0 = none.
  int rings = 0;
  double ring_spacing = 0.4;    // mm: one bead apart, so the rim prints solid
  bool handles = false;         // tensile handles at the -x and +x ends (rectangle only)
  double handle_length = 3;     // along x (mm)
  double handle_width = 10;     // along y (mm), centred
  double handle_spacing = 0.4;  // fill strands inside each handle (mm)
  // Nodes closer than this merge (mm), so no strut is shorter: crops and Voronoi vertices can
  // otherwise make struts of a few nanometres that no printer can resolve.
  double min_feature = 0.005;
  // When not empty, the pattern is cropped to these polygons (e.g. a layer of a solid) instead of
  // the region, which then only sets where the pattern is generated.
  std::vector<Polygon2> crop;
};

// Throws SettingError for parameters out of range.
Graph make_lattice2d(const AtlasParams& params);

// The region centre that puts the lattice's lower-left corner (handles included) at (0, 0), so a
// lattice printed where its coordinates say lands on the bed. The CLI's default.
Vec2 corner_at_origin(const AtlasParams& params);

// Exposed for tests: the pattern's segments in its local frame, covering [-half, half]².
std::vector<Segment2> pattern_segments(const AtlasParams& params, double half);
std::vector<Segment2> voronoi_segments(double half, double density, std::uint64_t seed);

}  // namespace trellis
