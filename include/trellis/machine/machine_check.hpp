// Checks a toolpath against the machine it is written for, before any file is written: the
// capabilities of the profile (build volume, tools, mixing inputs, bath, temperature and speed
// limits; laser power, speed and build area) against what the paths ask for. What cannot print
// as meant is a MachineError (exit 2, no file); what may print but looks wrong is a warning.
#pragma once
#include <string>
#include <string_view>
#include <vector>

#include "trellis/core/error.hpp"
#include "trellis/core/vec.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// The toolpath asks for something the machine cannot do (message names what, where and the
// setting).
class MachineError : public Error {
  using Error::Error;
};

struct MachineWarning {
  std::string kind;  // e.g. "bath_route_in_air", "temperature_unset"
  std::string message;
};

// The XY shift the G-code writer applies to design coordinates: to the bed centre when
// placement.center, then placement.offset_x/y (tool offsets come on top, per tool).
Vec2 placement_offset(const Toolpath& toolpath, const MachineProfile& profile);
// The Z lift the writer applies: with placement.lift, how far the lowest point is below Z 0; a
// bath machine adds embedded.floor_z (the design's Z 0 is on the bath's floor).
double placement_lift(const Toolpath& toolpath, const MachineProfile& profile);
// The same from the extent of every point (streamed layers: the extent gathered as they come).
Vec2 placement_offset(const BBox3& points_box, const MachineProfile& profile);
double placement_lift(const BBox3& points_box, const MachineProfile& profile);

// Undoes what our writer did to place a toolpath on the machine: the header's "; placement
// offset = dx, dy" and "; placement lift = dz" (which includes a bath's floor_z), so that G-code
// read back is in design coordinates again. Each nozzle's offset is the reader's to undo
// (GcodeReadOptions::tool_offsets, or the file's header): it reads nozzle positions.
void to_design_coordinates(Toolpath& toolpath, const std::string& gcode_text);
// What to_design_coordinates subtracts from every point, from those header lines (the header
// alone will do: read_gcode_header).
Vec3 design_shift(std::string_view gcode_text);
void to_design_coordinates(Layer& layer, Vec3 shift);

// Every error found, in one MachineError (the first few named, with counts); returns warnings.
// Checks: each point after placement (and its tool's offset) inside the build area and between
// Z 0 and machine.bed_z; tools < machine.tools; mixtures only on a mixing hotend with enough
// inputs (or in tools / temperature mode with enough tools); temperatures and feeds within the
// machine's limits.
std::vector<MachineWarning> check_for_machine(const Toolpath& toolpath,
                                              const MachineProfile& profile);
// The same over streamed layers, whose points span `points_box`. `path_extents` (optional):
// each path's extent, paths in layer order, as path_extent() gives it; a path on a rectangular
// bed is then checked by its extent, not point by point (the same verdict and message).
std::vector<MachineWarning> check_for_machine(const LayerSource& layers, const BBox3& points_box,
                                              const MachineProfile& profile,
                                              const std::vector<BBox3>* path_extents = nullptr);
// The extent of a path's points, or a box whose min.x is NaN when a coordinate is NaN (an
// extent would not show it).
BBox3 path_extent(const std::vector<Vec3>& points);

// Laser: power and speed per vector and of the profile within the laser's limits, the part
// within the build area (centred on the plate) and height.
std::vector<MachineWarning> check_for_laser(const Toolpath& toolpath, const LaserProfile& profile);
// The same for a piece of a toolpath whose first layer is layer `first_layer` of the whole (a
// file written layer by layer): messages name the whole's layer numbers.
std::vector<MachineWarning> check_for_laser(const Toolpath& toolpath, const LaserProfile& profile,
                                            std::size_t first_layer);

}  // namespace trellis
