// A laser's scanner timing and exposure, as the scan-time model (toolpath/scan_time.hpp), the
// multi-laser split (slice/pbf_lasers.hpp) and build files that declare their lasers
// (Toolpath::lasers) hold them. Their meaning is in scan_time.hpp.
#pragma once

namespace trellis {

struct ScanTiming {
  double contour_speed = 800;    // mm/s, mark speed of contour vectors
  double hatch_speed = 1000;     // mm/s, mark speed of hatch vectors
  double jump_speed = 5000;      // mm/s, positioning between vectors
  double jump_delay = 250;       // µs, after every jump
  double mark_delay = 100;       // µs, after every marked vector (without skywriting)
  double polygon_delay = 50;     // µs, at every corner inside a polyline
  bool skywriting = false;       // run in/out of each vector instead of the mark delay
  double skywriting_time = 150;  // µs, run-in + run-out per vector when skywriting
  double laser_on_delay = 0;     // µs, before the laser fires at every vector's start
  double laser_off_delay = 0;    // µs, the laser kept on after every vector's end
  bool operator==(const ScanTiming&) const = default;
};

// One laser of a machine as the planner and the time model see it: the power and speed it
// exposes a path at the profile's contour or hatch parameters with, its spot and its scanner
// (machine/laser.hpp: laser_parameters; several lasers that differ: slice/pbf_lasers.hpp).
struct LaserParameters {
  double contour_power = 0, contour_speed = 0;  // W, mm/s
  double hatch_power = 0, hatch_speed = 0;      // W, mm/s
  double spot_diameter = 0;                     // mm
  ScanTiming timing;
  bool operator==(const LaserParameters&) const = default;
};

}  // namespace trellis
