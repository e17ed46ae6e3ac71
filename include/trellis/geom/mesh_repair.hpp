// Repairing real meshes before slicing (CGAL Polygon Mesh Processing, in the run-time module
// `cgal`): meshes exported by CAD tools and scanners often have open seams, duplicate or
// degenerate faces, flipped faces, small holes and non-manifold edges. The repair fixes what it
// can, counts every fix, and the caller refuses what is still not a closed solid.
#pragma once
#include <cstddef>
#include <string>

#include "trellis/geom/mesh.hpp"

namespace trellis {

struct MeshRepairOptions {
  // A hole (a loop of open edges left after stitching) is closed when it has at most this many
  // edges; larger ones are reported and the mesh refused.
  std::size_t max_hole_edges = 500;
};

// What the repair changed; all zero for a mesh that was already a closed, consistently oriented
// 2-manifold.
struct MeshRepairReport {
  std::size_t degenerate_faces = 0;      // zero-area triangles removed
  std::size_t duplicate_faces = 0;       // triangles on the same three vertices removed
  std::size_t nonmanifold_edges = 0;     // edges of more than two faces, split apart
  std::size_t flipped_faces = 0;         // faces reversed to agree with their neighbours
  std::size_t stitched_edges = 0;        // pairs of open edges at the same place joined
  std::size_t snapped_vertices = 0;      // seam vertices snapped onto the edge facing them
  std::size_t holes_filled = 0;          // small holes triangulated
  std::size_t hole_faces = 0;            // triangles added to fill them
  std::size_t nonmanifold_vertices = 0;  // pinched vertices split
  std::size_t inverted_faces = 0;        // faces reversed so every shell faces outwards
  std::size_t holes_left = 0;            // holes too large to close (the mesh stays open)
  bool changed() const;
  // "12 duplicate faces removed, 3 holes filled (18 faces), ..." or "nothing to repair".
  std::string summary() const;
};

// Its memory and time (core/budget.hpp) for a mesh of `triangles` with `open_edges` (check_mesh):
// a mesh with a few open seams costs in proportion to its size, a soup of loose triangles (every
// edge open: stitching, snapping and a hole per triangle) more than that.
struct Estimate;
Estimate mesh_repair_estimate(std::size_t triangles, std::size_t open_edges);

// The repaired mesh (vertex coordinates are the input's; split vertices are duplicated).
TriangleMesh repair_mesh(const TriangleMesh& mesh, const MeshRepairOptions& options,
                         MeshRepairReport& report);

}  // namespace trellis
