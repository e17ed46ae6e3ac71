// Mesh repair runs in the CGAL module (src/geom/mesh_repair.cpp), loaded on first use.
#include <fmt/format.h>

#include "../core/cgal_module.hpp"
#include "trellis/geom/mesh_repair.hpp"

namespace trellis {

bool MeshRepairReport::changed() const {
  return degenerate_faces || duplicate_faces || nonmanifold_edges || flipped_faces ||
         stitched_edges || snapped_vertices || holes_filled || nonmanifold_vertices || inverted_faces;
}

std::string MeshRepairReport::summary() const {
  std::string s;
  auto add = [&](std::size_t n, const char* what) {
    if (!n) return;
    if (!s.empty()) s += ", ";
    s += fmt::format("{} {}", n, what);
  };
  add(degenerate_faces, "degenerate faces removed");
  add(duplicate_faces, "duplicate faces removed");
  add(nonmanifold_edges, "non-manifold edges split");
  add(flipped_faces, "faces flipped to match their neighbours");
  add(snapped_vertices, "seam vertices snapped onto open edges");
  add(stitched_edges, "open edges stitched");
  if (holes_filled)
    add(holes_filled, fmt::format("holes filled ({} faces)", hole_faces).c_str());
  add(nonmanifold_vertices, "non-manifold vertices split");
  add(inverted_faces, "faces turned outwards");
  add(holes_left, "holes too large to fill");
  return s.empty() ? "nothing to repair" : s;
}

TriangleMesh repair_mesh(const TriangleMesh& mesh, const MeshRepairOptions& options,
                         MeshRepairReport& report) {
  return detail::module_table<CgalModule>("cgal").repair_mesh(mesh, options, report);
}

}  // namespace trellis
