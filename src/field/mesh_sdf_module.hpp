// The OpenVDB module's table (src/core/module.hpp): mesh -> distance field and back.
#pragma once
#include "../core/module.hpp"
#include "trellis/core/progress.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/mesh.hpp"

namespace trellis {

struct MeshSdfModule {
  detail::ModuleHeader header;
  Field (*mesh_field)(const TriangleMesh&, const MeshSdfOptions&, std::string);
  TriangleMesh (*field_to_mesh)(const Field&, const BBox3&, double, MeshingStats*, const Progress*);
  // The unsigned distance to any mesh, closed or not (3MF unsignedmesh nodes).
  Field (*unsigned_mesh_field)(const TriangleMesh&, const MeshSdfOptions&, std::string);
};

}  // namespace trellis
