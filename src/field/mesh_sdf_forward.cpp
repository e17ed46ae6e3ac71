// mesh_field and field_to_mesh run in the OpenVDB module, loaded on first use.
#include <cstdio>

#include "mesh_sdf_module.hpp"
#include "trellis/field/meshing.hpp"

namespace trellis {

namespace {
std::string fmt_voxels(double voxels) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "meshing a field: %.3g voxels", voxels);
  return buf;
}
}  // namespace

Field mesh_field(const TriangleMesh& mesh, const MeshSdfOptions& options, std::string name) {
  return detail::module_table<MeshSdfModule>("vdb").mesh_field(mesh, options, std::move(name));
}

TriangleMesh field_to_mesh(const Field& field, const BBox3& box, double voxel,
                           MeshingStats* stats) {
  return detail::module_table<MeshSdfModule>("vdb").field_to_mesh(field, box, voxel, stats,
                                                                  nullptr);
}

TriangleMesh field_to_mesh(const Field& field, const BBox3& box, double voxel, MeshingStats* stats,
                           const RunContext& context) {
  const auto& module = detail::module_table<MeshSdfModule>("vdb");
  TriangleMesh mesh;
  context.run([&] { mesh = module.field_to_mesh(field, box, voxel, stats, &context.progress); });
  return mesh;
}

Estimate field_mesh_estimate(const BBox3& box, double voxel) {
  const Vec3 n = (box.max - box.min) * (1 / voxel) + Vec3{3, 3, 3};
  const double voxels = n.x * n.y * n.z;
  const double faces = 2 * (n.x * n.y + n.y * n.z + n.x * n.z);
  Estimate e;
  // A float per voxel of the box (OpenVDB keeps only the blocks near the surface, so at most
  // this), and a vertex (24 B) and two triangles (24 B) per voxel of the box's faces: a surface
  // as large as the box's (a TPMS has more).
  e.bytes = 4 * voxels + 48 * faces;
  e.what = fmt_voxels(voxels);
  e.change = "the step (coarser) or the box (smaller)";
  return e;
}

}  // namespace trellis
