// Internal (implicit3mf module): compiles a function graph of the Implicit Extension (Part II
// ch. 3-5) into implicit_graph.hpp's program: references resolved and type-checked, function
// calls compiled in place, unsupported nodes refused by name with the part, line and column.
#pragma once
#include <map>
#include <string>

#include "implicit_graph.hpp"
#include "implicit_xml.hpp"

namespace trellis::implicit {

// Compiles function `fid` of `functions` (resource id → element) as a level set's (Part I
// §4.1.1): its one input the vector "pos" (program.pos), its scalar output `channel` (the first
// scalar output when empty: the 2022 draft's boundary) as program.out. `at`: the referring
// element, where problems with the reference are reported.
void compile_level_set(const Ctx& c, const std::map<long long, const El*>& functions, long long fid,
                       std::string channel, const El& at, Program& program);

}  // namespace trellis::implicit
