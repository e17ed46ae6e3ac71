// JSON form of the toolpath IR (format "trellis.toolpath", version 1):
// {"format":"trellis.toolpath","version":1,"units":"mm","source":"...",
//  "layers":[{"z":0.148,"paths":[{"role":"strut","tool":0,"width":0,"height":0.148,
//             "speed":0,"points":[[x,y,z],...]}]}]}
#pragma once
#include <string>

#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

std::string toolpath_to_json(const Toolpath& toolpath);
// `origin` names the input in error messages.
Toolpath toolpath_from_json(const std::string& text, const std::string& origin);
Toolpath read_toolpath(const std::string& path);
void write_toolpath(const std::string& path, const Toolpath& toolpath);

}  // namespace trellis
