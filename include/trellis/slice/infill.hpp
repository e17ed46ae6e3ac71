// Sparse infill patterns for a layer's infill region: rectilinear, grid, triangles, honeycomb,
// gyroid, concentric, and any 2D atlas lattice (lattice/atlas.hpp) planned by the Euler planner
// into the fewest trails. Each pattern's spacing or cell follows from the asked density, so that
// deposited length × bead width / region area ≈ density. Open pieces whose ends were cut end on
// the region's boundary, for the linking stage to join into serpentines. Deterministic: the
// same inputs give the same output bytes.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

enum class InfillPattern {
  Rectilinear,  // parallel lines at w/density, turned 90° on odd layers
  Grid,         // two directions 90° apart every layer, each at 2w/density
  Triangles,    // three directions 60° apart every layer, each at 3w/density, meeting in points
  Honeycomb,    // zig-zags mirrored in pairs: hexagons whose shared sides are two beads side
                // by side; turned 60° per layer about a hexagon centre (the same cells)
  Gyroid,       // the section of a gyroid at the layer's height, turned by `angle`
  Concentric,   // inward offsets of the region at w/density, as closed rings
  Lattice,      // a 2D atlas pattern, cropped to the region, in Euler trails
};

const std::vector<std::string>& infill_pattern_names();
const char* to_string(InfillPattern pattern);
InfillPattern infill_pattern_from_string(const std::string& name);  // SettingError listing names

struct InfillSpec {
  InfillPattern pattern = InfillPattern::Rectilinear;
  double density = 0.2;     // fraction of solid, (0, 1]: deposited length × bead width / area
  double bead_width = 0.4;  // mm
  double angle = 45;        // deg, base direction of the lines, zig-zags, gyroid and lattice
  // Open pieces shorter than this (mm) are dropped, and rings shorter than it (as the planar
  // slicer's min_path). Lattice trails are all kept, so that their count is the planner's.
  double min_length = 0.05;
  std::string lattice = "honeycomb";  // Lattice: an atlas pattern name (pattern_names())
  std::uint64_t seed = 1;             // Lattice: the Voronoi seeds, reproducible for a seed
  // Lattice: degrees added to `angle` per layer (0: every layer alike, so the cells stack into
  // walls). The "lines" pattern alternates 90° when this is 0 (a woodpile).
  double lattice_layer_rotation = 0;
  // Lattice: the box the pattern is generated over, the same for every layer of a part (its XY
  // box) so that cells stack; Voronoi seeds and Penrose tilings depend on it. Empty (zero
  // width or height): the region's own box, so layers of different outline are unaligned.
  BBox2 frame{};
};

struct InfillPaths {
  std::vector<std::vector<Vec2>> open;   // open polylines; ends that were cut lie on the boundary
  std::vector<std::vector<Vec2>> loops;  // closed rings, first point not repeated
  // Parallel to loops: Concentric, the ring's step inward (0: the outermost, k: k spacings in
  // from it); Gyroid (closed curves inside the region) 0.
  std::vector<std::uint32_t> loop_level;
  // Lattice: the Euler planner's trails and the proven minimum, Σ max(1, odd nodes / 2) over
  // the cropped lattice's connected components.
  std::size_t trails = 0, trail_lower_bound = 0;
  // The length the density gave (mm): the line spacing of each direction, the hexagon side, the
  // gyroid's period, the ring spacing or the lattice's cell size (Voronoi: 1/√(seeds per mm²)).
  // 0 when the region is empty.
  double scale = 0;
};

// The infill of `region` (polygons with holes, outer rings counter-clockwise) for the layer
// `layer_index` at height `z`. Patterns are anchored to the origin (Lattice: to the frame), not
// to the region, so that layers line up. Throws SettingError for a density outside (0, 1], a
// bead width <= 0, a non-finite angle or an unknown lattice name.
InfillPaths make_infill(const Regions& region, const InfillSpec& spec, std::size_t layer_index,
                        double z);

}  // namespace trellis
