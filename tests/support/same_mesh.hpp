// Whether two meshes are the same: the same triangles and the same vertices, coordinate by
// coordinate (by value: -0 equals +0).
#pragma once
#include <cstddef>

#include "trellis/geom/mesh.hpp"

namespace trellis::test {

inline bool same_mesh(const TriangleMesh& a, const TriangleMesh& b) {
  if (a.vertices.size() != b.vertices.size() || a.triangles != b.triangles) return false;
  for (std::size_t i = 0; i < a.vertices.size(); ++i)
    if (a.vertices[i].x != b.vertices[i].x || a.vertices[i].y != b.vertices[i].y ||
        a.vertices[i].z != b.vertices[i].z)
      return false;
  return true;
}

}  // namespace trellis::test
