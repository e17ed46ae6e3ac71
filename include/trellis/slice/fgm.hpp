// Gradient-informed slicing of functionally graded designs (FGM paper, §3.2.3 and §3.5): the
// first material's volume fraction f ∈ [0, 1] is cut into a palette of N colours (bands of
// width α = 1/N, each printed at its mid value); every layer's outline is cut into colour faces
// along iso-contours of f; Strategy 2 offsets each face inward by half a bead and fills it
// completely (a ring, then 100 % rectilinear inside it, or concentric rings), colour by colour in palette order, reversed
// every other layer, each path carrying its mixture (written as M165 by the G-code writer).
//
// This release: two-material designs (`fgrade` with two fractions) and Strategy 2 only.
#pragma once
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/slice/slice.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct Palette {
  int colors = 8;
  double band() const { return 1.0 / colors; }
  double mid(int k) const { return (k + 0.5) / colors; }
  int color_of(double f) const;  // band of a fraction (clamped to 0..colors-1)
};

// One colour's part of a layer: where the first material's fraction lies in band `color`.
struct ColorFace {
  int color = 0;
  Regions region;
};

// The faces of the outline at z: face k = {outline, k/N <= f < (k+1)/N}, from the contours of
// max(sdf, f - level) at the band edges (closed by construction, whatever the iso-lines of f do).
// Throws GeometryError if the design has fewer than two materials.
std::vector<ColorFace> color_faces(const Field& field, Evaluator& evaluator, double z,
                                   const Regions& outline, const Palette& palette,
                                   double resolution);

struct FgmOptions {
  Palette palette;
  double bead_width = 0.4;
  double layer_height = 0.2;
  double resolution = 0.1;    // XY grid of the iso-contours (mm)
  bool concentric = false;    // concentric fill instead of 100 % rectilinear
  double angle_deg = 45;      // rectilinear angle, +90° every layer
};

struct FgmStats {
  std::size_t faces = 0, paths = 0, colour_changes = 0;
  double shortest_path = 0;  // mm
};

// Strategy 2 over the layer outlines (from slice_field). Paths carry mixture {m, 1-m} with m the
// band's mid value of the first material.
Toolpath plan_fgm_strategy2(const Field& field, const std::vector<LayerOutline>& layers,
                            const FgmOptions& options, FgmStats* stats = nullptr);

}  // namespace trellis
