// Measures a laser build file (any tool's, read into the toolpath IR) against the design it
// should build: per layer, the design's section at the layer's height, the scan vectors that
// leave the part, the filling ratio FR_a = D·ΣL/A (PBF paper Eq. 8) and the scan time.
#pragma once
#include <limits>
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/toolpath/scan_defaults.hpp"
#include "trellis/toolpath/scan_time.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct LaserAnalysisOptions {
  double melt_pool = kScanMeltPoolWidth;  // D (mm)
  double resolution = 0.01;               // mm, grid of the design's section (crossings refined)
  double sample = 0.005;                  // mm between points tested along each vector
  double tolerance = 0.001;               // mm a point may lie outside the part before it counts
  // Design z of the build file's z = 0 (CLI z is the top of a layer, cut at its middle); NaN =
  // the design's lowest z.
  double z0 = std::numeric_limits<double>::quiet_NaN();
  ScanTiming timing;
};

struct LaserLayerAnalysis {
  double z = 0;                                 // build-file z (mm)
  double design_z = 0;                          // where the design was cut
  double area = 0;                              // mm², the design's section
  double contour_length = 0, hatch_length = 0;  // mm
  double fr = 0;                                // D·ΣL/A (0 where A = 0)
  std::size_t vectors = 0, outside_vectors = 0;
  double outside_length = 0;  // mm of vectors outside the part (by more than the tolerance)
  double max_outside = 0;     // mm, farthest point outside (first-order distance Φ/|∇Φ|)
  double scan_time = 0;       // s
};

struct LaserAnalysis {
  std::vector<LaserLayerAnalysis> layers;
  std::size_t vectors = 0, outside_vectors = 0;
  double scan_length = 0, outside_length = 0, max_outside = 0, scan_time = 0;
  double fr_mean = 0, fr_cv = 0;  // over layers with area > 0
};

LaserAnalysis analyze_laser_toolpath(const Toolpath& toolpath, const Field& part,
                                     const LaserAnalysisOptions& options = {});

}  // namespace trellis
