// The laser scan parameters' defaults (the PBF paper's 316L at 20 µm layers), in one place: the
// laser profile (machine/laser.hpp) starts from them, and so do the planners' options that the
// routes fill from that profile (slice/pbf.hpp, pbf_mesh.hpp, scan_strategy.hpp,
// pbf_analysis.hpp), so a planner called without a profile plans what a default profile would.
#pragma once

namespace trellis {

inline constexpr double kScanLayer = 0.02;             // mm, powder layer thickness
inline constexpr double kScanHatchDistance = 0.04;     // mm, between hatch lines
inline constexpr double kScanBeamCompensation = 0.03;  // mm, hatch ends and contours pulled in
inline constexpr double kScanSegmentLength = 0.1;      // SL (mm), contour scan vector length
inline constexpr double kScanSegmentGap = 0.02;        // LHD (mm), gap between contour vectors
inline constexpr double kScanMeltPoolWidth = 0.0638;   // D (mm), PBF paper Eq. 8

}  // namespace trellis
