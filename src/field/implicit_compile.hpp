// Internal (implicit3mf module): compiles a function graph of the Implicit Extension (Part II
// ch. 3-5) into implicit_graph.hpp's program: references resolved and type-checked, function
// calls compiled in place, unsupported nodes refused by name with the part, line and column.
#pragma once
#include <functional>
#include <map>
#include <string>

#include "implicit_graph.hpp"
#include "implicit_xml.hpp"

namespace trellis::implicit {

// What a graph may refer to besides its functions' nodes: the package's function resources, the
// image of a <functionfromimage3d>, and the distance to a mesh object.
struct Resources {
  std::map<long long, const El*> functions;  // resource id → element
  // The sampler of a <functionfromimage3d> element (its image3d read from the package).
  std::function<ImageFunction(const El& function)> image;
  // The distance to mesh object `id` in its own coordinates (model units): signed (negative
  // inside; the mesh must be closed) or unsigned. `at`: the node, where problems are reported.
  std::function<Field(long long id, bool sign, const El& at)> mesh;
};

// Compiles function `fid` as a level set's (Part I §4.1.1): its one input the vector "pos"
// (program.pos), its scalar output `channel` (the first scalar output when empty: the 2022
// draft's boundary) as program.out. `at`: the referring element, where problems with the
// reference are reported. An implicit function, the 2022 draft's function or a
// <functionfromimage3d> (its outputs red, green, blue, alpha and the vector color).
void compile_level_set(const Ctx& c, const Resources& resources, long long fid, std::string channel,
                       const El& at, Program& program);

}  // namespace trellis::implicit
