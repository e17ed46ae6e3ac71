// Triangle meshes and STL output. Used to hand a lattice to other slicers as "wall structures"
// (the control-slicer comparison of the GIPPO paper).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis {

struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside

  // Appends a closed prism: the polygon `ring` (counter-clockwise, in XY) from z0 to z1.
  void add_prism(const std::vector<Vec2>& ring, double z0, double z1);
};

// Binary STL (little-endian float32), with facet normals from the vertex order.
std::string mesh_to_stl(const TriangleMesh& mesh, const std::string& header = "trellis");
void write_stl(const std::string& path, const TriangleMesh& mesh);

}  // namespace trellis
