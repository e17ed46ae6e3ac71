// The toolpath IR: the one path model of Trellis. Planners and slicers produce it, writers,
// metrics and previews read it, the G-code reader will produce it too.
// A Toolpath is layers of paths; a Path is an open polyline of 3D nozzle positions (mm) with the
// attributes a writer needs. Travel between paths is implicit: from one path's last point to the
// next path's first point, in order.
#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/toolpath/laser_parameters.hpp"

namespace trellis {

// Hatch: a laser's fill vectors (PBF); Nonplanar: a path that rises and falls with a surface.
enum class PathRole {
  Strut,
  Contour,
  Handle,
  Perimeter,
  Infill,
  Other,
  Skin,
  Purge,
  Hatch,
  Nonplanar
};
inline constexpr std::size_t kPathRoleCount = 10;

const char* to_string(PathRole role);
PathRole path_role_from_string(const std::string& name);  // throws ParseError

struct Path {
  std::vector<Vec3> points;  // at least 2
  PathRole role = PathRole::Strut;
  int tool = 0;                 // tool / material index
  std::vector<double> mixture;  // optional mixing fractions, empty if none
  double width = 0;             // bead width (mm), 0 = profile default
  double height = 0;            // bead height (mm), 0 = profile default
  double speed = 0;             // feed (mm/s), 0 = profile default
  double power = 0;             // laser power (W), 0 if not a laser path
  double filament = 0;          // filament (mm of E) as read from G-code, 0 if not known
  double temperature = 0;       // nozzle temperature (°C) while printing it, 0 = not set
  double flow = 0;              // extrusion multiplier on top of the machine's, 0 = 1
  double fan = -1;              // part-cooling fan (%) while printing it, < 0 = not set
  // Continues the previous path's bead: split there because a process value (temperature,
  // speed, flow, fan) changes; no travel, priming or short-path slow-down between the two.
  bool joined = false;
  // The travel into this path from the previous path's end, as the linking stage planned it
  // (slice/link.hpp): through the points of `via` in order (empty: straight), and whether it
  // stays inside the part (crosses no outer wall), so a writer need not retract for it.
  std::vector<Vec3> via;
  bool inside = false;
  int part = 0;  // build plates: index + 1 into Toolpath::part_labels, 0 = none
  std::size_t segments() const { return points.size() < 2 ? 0 : points.size() - 1; }
  double length() const;
};

struct Layer {
  double z = 0;  // nominal layer height of the nozzle (mm); points carry their own z
  std::vector<Path> paths;
};

// A laser parameter set by name, as build processors name their exposure types ("contour 2",
// "core hatch", "downskin hatch"): the paths of `role` marked at `power` W and `speed` mm/s. A
// machine knows a set by its power and speed, so a path belongs to the first set with its role,
// power and speed (parameter_set_of).
struct ParameterSet {
  std::string name;
  PathRole role = PathRole::Hatch;
  double power = 0, speed = 0;
  bool operator==(const ParameterSet&) const = default;
};

struct Toolpath {
  std::vector<Layer> layers;
  std::string source;  // what produced it (planner, input file), written into outputs
  // The job that made it (TOML text, job/job.hpp), embedded in every output so that
  // `trellis rerun` can regenerate it; empty when it was not made by a job.
  std::string job;
  // Build plates: the parts' labels (Path::part - 1 indexes them); empty for one part.
  std::vector<std::string> part_labels;
  // Laser parameter sets by name (PBF solid parts, or read from a build file); empty otherwise.
  std::vector<ParameterSet> parameter_sets;
  // A multi-laser machine's lasers that differ, as a build file declares them (.cli comments, 3MF
  // toolpath data): each one's exposure, spot and scanner, by laser index; empty when not said.
  std::vector<LaserParameters> lasers;

  std::size_t path_count() const;
  double extrusion_length() const;
};

// The index in `toolpath.parameter_sets` of the set `path` (or a path of `role`, `power` and
// `speed`) belongs to, or -1.
int parameter_set_of(const Toolpath& toolpath, PathRole role, double power, double speed);
inline int parameter_set_of(const Toolpath& toolpath, const Path& path) {
  return parameter_set_of(toolpath, path.role, path.power, path.speed);
}

// Moves a path's first and last point `length` further out along its end segments (a strut
// printed past its end nodes, the embedded writer's node overlap).
void extend_path_ends(Path& path, double length);

// Travel between consecutive paths, in print order, across layers (first path has no travel in),
// through each path's `via` points.
struct TravelStats {
  std::size_t moves = 0;
  double length = 0;
};
TravelStats travel_stats(const Toolpath& toolpath, double min_move = 1e-9);
// The length of the travel from `from` into `path` (through its via points).
double travel_into(Vec3 from, const Path& path);

// The box around every point of every path.
BBox3 points_box(const Toolpath& toolpath);

// Layers visited in print order, one at a time: a toolpath held whole (layers_of) or layers
// streamed from a temporary file (toolpath/layer_spill.hpp). A source can be visited again; each
// visit starts at layer 0.
using LayerVisitor = std::function<void(std::size_t index, const Layer& layer)>;
using LayerSource = std::function<void(const LayerVisitor& visit)>;
LayerSource layers_of(const Toolpath& toolpath);  // refers to `toolpath`: keep it alive

}  // namespace trellis
