// Laser powder-bed fusion: the machine profile (laser power and speed per region, scan
// parameters) and the Common Layer Interface (.cli, ASCII) writer.
#pragma once
#include <string>
#include <vector>

#include "trellis/toolpath/scan_defaults.hpp"
#include "trellis/toolpath/scan_time.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct LaserProfile {
  std::string name = "PBF-LB";
  double spot_diameter = 0.025;                                           // mm
  double melt_pool_width = kScanMeltPoolWidth;                            // D (mm), PBF paper Eq. 8
  double contour_power = 60, contour_speed = ScanTiming{}.contour_speed;  // W, mm/s
  double hatch_power = 100, hatch_speed = ScanTiming{}.hatch_speed;       // W, mm/s
  // Solid parts' own parameter sets (slice/pbf_skin.hpp): per contour offset, outermost first
  // (empty: all at the contour power and speed), and the core, up-skin and down-skin hatch
  // (0: the hatch power or speed).
  std::vector<double> contour_powers, contour_speeds;  // W, mm/s
  double core_power = 0, core_speed = 0;
  double upskin_power = 0, upskin_speed = 0;
  double downskin_power = 0, downskin_speed = 0;
  double layer = kScanLayer;                         // mm
  double hatch_distance = kScanHatchDistance;        // mm
  double beam_compensation = kScanBeamCompensation;  // mm
  double segment_length = kScanSegmentLength;        // SL (mm)
  double segment_gap = kScanSegmentGap;              // LHD (mm)
  // Capabilities: what the machine can do (machine/machine_check.hpp checks against them).
  double max_power = 1000;                             // W
  double max_speed = 10000;                            // mm/s
  double build_x = 250, build_y = 250, build_z = 300;  // build plate and height (mm)
  // Multi-laser machines (slice/pbf_lasers.hpp): the lasers that scan a layer at once, and
  // each one's field (x0, y0, x1, y1 per laser, in stripe order; empty = the whole plate).
  int lasers = 1;
  std::vector<double> fields;
  // Lasers that differ ([lasers]): one value per laser in the same order, each list empty (every
  // laser at the [laser] or [timing] value) or as long as `lasers`.
  struct PerLaser {
    std::vector<double> contour_power, contour_speed, hatch_power, hatch_speed;  // W, mm/s
    std::vector<double> spot_diameter;                                           // mm
    std::vector<double> jump_speed;                                              // mm/s
    std::vector<double> jump_delay, mark_delay, polygon_delay;                   // µs
    std::vector<double> laser_on_delay, laser_off_delay;                         // µs
    std::vector<double> skywriting;       // 1 = the laser skywrites, 0 = it waits the mark delay
    std::vector<double> skywriting_time;  // µs
  } each;
  // Scanner timing ([timing]), for the scan-time model (ScanClock).
  // Their defaults are the scan-time model's (toolpath/scan_time.hpp ScanTiming).
  double jump_speed = ScanTiming{}.jump_speed;            // mm/s, positioning between vectors
  double jump_delay = ScanTiming{}.jump_delay;            // µs, after every jump
  double mark_delay = ScanTiming{}.mark_delay;            // µs, after every marked vector
  double polygon_delay = ScanTiming{}.polygon_delay;      // µs, at every corner of a polyline
  bool skywriting = ScanTiming{}.skywriting;              // run in/out instead of the mark delay
  double skywriting_time = ScanTiming{}.skywriting_time;  // µs, run-in + run-out per vector
  double laser_on_delay = ScanTiming{}.laser_on_delay;    // µs, before the laser fires
  double laser_off_delay = ScanTiming{}.laser_off_delay;  // µs, laser kept on after the end
};

// The profile's speeds and delays as the scan-time model's settings.
ScanTiming scan_timing(const LaserProfile& profile);

// The profile's own laser ([laser], [timing]), and each of its `lasers` with its [lasers] values
// where given. A [lasers] list of another length than `lasers` → SettingError naming its key.
LaserParameters profile_laser(const LaserProfile& profile);
std::vector<LaserParameters> laser_parameters(const LaserProfile& profile);
// Whether any [lasers] list is given (the lasers differ).
bool lasers_differ(const LaserProfile& profile);
// Each laser's scanner (laser_parameters' timings).
std::vector<ScanTiming> laser_timings(const LaserProfile& profile);
// The lasers a build file declares (Toolpath::lasers as the writers write it): the profile's when
// its lasers differ, else those the toolpath was read with (none: empty).
std::vector<LaserParameters> declared_lasers(const LaserProfile* profile, const Toolpath& toolpath);

// Laser profiles are TOML files of settings ([machine] name, [laser], [scan], [timing]), read
// through the one settings schema (settings/settings.hpp: Settings::load_toml_file, then
// config().laser), which declares every key with its unit, range and doc.

// ASCII CLI: $$HEADERSTART … $$HEADEREND, $$GEOMETRYSTART, per layer $$LAYER/z, contour paths as
// $$POLYLINE/1,2,n,… (id 1, open), hatch paths (two points) as one $$HATCHES/2,n,… record,
// $$GEOMETRYEND. Units 1 µm ($$UNITS/0.001). Laser power and speed per id are in the header as
// comments and in the toolpath JSON.
std::string write_cli(const Toolpath& toolpath, const LaserProfile& profile);
void write_cli_file(const std::string& path, const Toolpath& toolpath, const LaserProfile& profile);

}  // namespace trellis
