// Build plates in G-code (private to the writer): each part's moves between the firmware's start
// and end of an "object", so that the printer can cancel one part and go on with the others
// (machine setting gcode.label_objects). Marlin, Prusa and RepRapFirmware: "M486 T<count>" in
// the header, "M486 S<id> A"<label>"" before a part's moves and "M486 S-1" after (ids from 0,
// in the order of Toolpath::part_labels); Klipper: "EXCLUDE_OBJECT_DEFINE NAME=<label>
// CENTER=x,y POLYGON=[[x,y],...]" (the convex hull of the part's moves, as placed on the bed) in
// the header, "EXCLUDE_OBJECT_START NAME=<label>" / "EXCLUDE_OBJECT_END NAME=<label>" around its
// moves. Labels are written with letters, digits, '_', '-' and '.' only (Klipper splits words at
// blanks, M486 ends a label at a quote): any other character becomes '_', with a warning.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

enum class ObjectStyle { None, M486, Klipper };

struct GcodeObjects {
  ObjectStyle style = ObjectStyle::None;
  std::vector<std::string> names;  // per part: Path::part - 1
  std::string definitions;         // header lines (each ends in '\n')
  // The lines that open and close part `part` (>= 1).
  std::string start(int part) const;
  std::string end(int part) const;
};

// The objects of a plate (`labels`: Toolpath::part_labels) for the profile's flavour; none
// without labels, for the pneumatic and embedded flavours, or with gcode.label_objects = false.
// `shift` is the writer's XY placement; Klipper's polygons come from one pass over `layers`, a
// layer at a time (memory bounded by a layer and the hulls). Two labels written alike are a
// MachineError.
GcodeObjects gcode_objects(const std::vector<std::string>& labels, const LayerSource& layers,
                           const MachineProfile& profile, Vec2 shift,
                           std::vector<std::pair<std::string, std::string>>& warnings);

}  // namespace trellis
