// Multi-laser PBF: one layer's scan vectors shared among the machine's lasers (docs/laser.md).
// The plate is split into stripes across X or Y (LaserAxis), one per laser in the order the
// lasers are declared (laser 0 at the low end); the stripe boundaries move per layer so that the
// lasers' scan times
// (toolpath/scan_time.hpp: scan_time) come out as equal as their fields allow. A vector crossing
// a boundary goes whole to one laser when it stays within `overlap` / 2 of the boundary on the
// other side (the stripes overlap by `overlap`); a longer one is cut at the boundary, each piece
// to its stripe's laser. A laser only gets vectors inside its field.
#pragma once
#include <cstddef>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/toolpath/scan_time.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// The axis the stripes follow one another along: X (boundaries are lines x = const), Y, or auto:
// per layer the axis whose split builds the layer sooner (its slowest laser), X on a tie; an
// axis the fields cannot serve is skipped.
enum class LaserAxis { X, Y, Auto };
const char* to_string(LaserAxis axis);

struct LaserSetup {
  // One field per laser (what its scanner reaches, in the toolpath's coordinates, mm), in stripe
  // order. Its size is the laser count.
  std::vector<BBox2> fields;
  double overlap = 0;  // mm: neighbouring stripes overlap by this
  LaserAxis axis = LaserAxis::X;
  ScanTiming timing;  // every laser's scanner (when `lasers` is empty)
  // Lasers that differ: one per field. A path at the profile's contour or hatch power and speed
  // (`profile`) takes its laser's on that laser, and each laser's time is reckoned with its own
  // speeds and delays (its ScanTiming); other paths (a solid part's parameter sets) keep theirs.
  // Empty: every laser is `timing` and paths keep their values.
  LaserParameters profile;
  std::vector<LaserParameters> lasers;
};

// `path` as laser `laser` exposes it: its power and speed that laser's if they are the profile's
// contour or hatch parameters, else its own.
void expose_on(Path& path, const LaserParameters& laser, const LaserParameters& profile);

// The whole plane: a laser that reaches everywhere.
BBox2 whole_plate();

// A setup of `lasers` lasers from the profile's flat list of fields (x0, y0, x1, y1 per laser;
// empty = each reaches the whole plate). A list of the wrong length or an empty field →
// SettingError naming laser.fields.
LaserSetup laser_setup(int lasers, const std::vector<double>& fields, double overlap,
                       const ScanTiming& timing);
// The same for lasers that differ (`each`: one per laser, `profile`: the profile's own laser).
LaserSetup laser_setup(const std::vector<double>& fields, double overlap,
                       const LaserParameters& profile, const std::vector<LaserParameters>& each);

struct LaserSplit {
  std::vector<double> seconds;     // scan time per laser (s)
  LaserAxis axis = LaserAxis::X;   // the axis the layer was split along (X or Y)
  std::vector<double> boundaries;  // the stripe boundaries along it (mm), lasers - 1 of them
  std::size_t cut = 0;             // vectors cut at a boundary
  // For each path of the layer after the split, the index of the path it came from (pieces of
  // a cut path share it, in order along the path).
  std::vector<std::size_t> source;
  double build_seconds() const;  // the slowest laser's time: the layer's scan time
};

// Splits `layer` among the setup's lasers along setup.axis: every path's `tool` becomes its
// laser index and its power and speed that laser's (expose_on), a path
// cut at a boundary becomes its pieces in place (same values, its points cut). One laser: the
// layer is left as it is (tool 0), its time reported. A vector no laser's field holds →
// GeometryError naming the layer (`layer_index`), the vector and laser.fields.
LaserSplit split_among_lasers(Layer& layer, const LaserSetup& setup, std::size_t layer_index);

// Every laser's time per layer and in total, and the build time (per layer the slowest laser,
// summed), as a route reports them.
struct LaserTimes {
  std::vector<std::vector<double>> per_layer;  // [layer][laser] (s)
  std::size_t cut = 0;
  std::size_t along_y = 0;  // layers split along Y
  void add(const LaserSplit& split);
  std::vector<double> totals() const;  // per laser (s)
  double build_seconds() const;
};

// The times of a toolpath whose paths carry their laser in `tool` (a .cli or 3MF read back):
// every laser with `timing`, or each with its own (`each[tool]`; a path of a laser beyond them
// → SettingError naming laser.lasers).
LaserTimes laser_times(const Toolpath& toolpath, const ScanTiming& timing);
LaserTimes laser_times(const Toolpath& toolpath, const std::vector<ScanTiming>& each);

}  // namespace trellis
