// The 3MF module's table (src/core/module.hpp): read_3mf returns the stored triangles with build
// transforms and the model unit applied (millimetres), not yet welded or checked.
#pragma once
#include "../core/module.hpp"
#include "trellis/geom/mesh.hpp"

namespace trellis {

struct Mesh3mfModule {
  detail::ModuleHeader header;
  TriangleMesh (*read_3mf)(const std::string&);
  void (*write_3mf)(const std::string&, const TriangleMesh&, const std::string& unit);
};

}  // namespace trellis
