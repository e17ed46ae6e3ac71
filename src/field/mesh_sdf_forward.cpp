// mesh_field and field_to_mesh run in the OpenVDB module, loaded on first use.
#include "mesh_sdf_module.hpp"

namespace trellis {

Field mesh_field(const TriangleMesh& mesh, const MeshSdfOptions& options, std::string name) {
  return detail::module_table<MeshSdfModule>("vdb").mesh_field(mesh, options, std::move(name));
}

TriangleMesh field_to_mesh(const Field& field, const BBox3& box, double voxel,
                           MeshingStats* stats) {
  return detail::module_table<MeshSdfModule>("vdb").field_to_mesh(field, box, voxel, stats);
}

}  // namespace trellis
