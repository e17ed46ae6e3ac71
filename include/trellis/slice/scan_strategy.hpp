// Laser powder-bed scan strategies for a solid layer region: the hatch vectors that fill it
// (PySLM/libSLM's set). Every strategy hatches the region's inward offset by the beam
// compensation with lines `hatch_distance` apart through a given point (the hatch phase: the
// design's origin by default), turned by
// `rotation` degrees per layer; they differ in how the lines are cut and ordered:
//   rectilinear  whole lines, all scanned the same way;
//   meander      whole lines, scanned back and forth (the paper's R67 with rotation 67);
//   stripe       lines cut into stripes `stripe_width` wide (across the lines), neighbours
//                overlapping by `stripe_overlap`, scanned stripe by stripe, back and forth;
//   island       a square grid of islands `island_size` a side turned with the hatch, shifted
//                by `island_shift` along both axes per layer, each island grown by half the
//                overlap on every side; a checkerboard: islands with i + j even are hatched
//                along the layer's angle, odd ones at 90° to it; island by island.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "trellis/geom/regions.hpp"
#include "trellis/toolpath/scan_defaults.hpp"

namespace trellis {

enum class ScanStrategy { Rectilinear, Meander, Stripe, Island };

struct ScanPattern {
  ScanStrategy strategy = ScanStrategy::Meander;
  double hatch_distance = kScanHatchDistance;  // mm, between neighbouring hatch lines
  double angle = 0;                            // degrees, the first layer's hatch direction
  double rotation = 67;                        // degrees added per layer
  double stripe_width = 10;                    // mm, stripe: across the hatch lines
  double stripe_overlap = 0.1;                 // mm, stripe: neighbouring stripes overlap by this
  double island_size = 5;                      // mm, island: side of the square islands
  double island_overlap = 0.1;                 // mm, island: neighbouring islands overlap by this
  double island_shift = 0;  // mm, island: grid shift per layer along both island axes
};

// The hatch direction of layer `layer` (degrees, in [0, 360)).
double scan_angle(const ScanPattern& pattern, std::size_t layer);

// The hatch vectors of layer `layer` over `region`, every point at least `inset` (mm) inside it
// (the beam compensation, plus the contours' band when contours are scanned), in scan order,
// on lines through `origin` (the island and stripe grids stay on the design's origin).
std::vector<Segment2> scan_hatches(const Regions& region, double inset, const ScanPattern& pattern,
                                   std::size_t layer, Vec2 origin = {0, 0});

// The random hatch phase of layer `layer`: a point moved across lines at `angle_deg` by a
// uniform fraction of `spacing`, drawn from the layer's own stream of `seed` (so a layer range
// computed alone gives the same lines).
Vec2 random_hatch_shift(double angle_deg, std::uint64_t seed, std::size_t layer, double spacing);

}  // namespace trellis
