// Mesh repair with CGAL Polygon Mesh Processing, built into the run-time module trellis_cgal:
// the triangles as a polygon soup lose their duplicates and are oriented consistently (the soup
// functions split non-manifold edges and vertices while doing so), become a halfedge mesh whose
// open seams are stitched, whose zero-area faces are collapsed and whose small holes are
// triangulated; finally every shell is oriented outwards.
#include "trellis/geom/mesh_repair.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/bbox.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/internal/Snapping/snap.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Polygon_mesh_processing/stitch_borders.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/exceptions.h>
#include <CGAL/property_map.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "../core/cgal_module.hpp"
#include "trellis/core/error.hpp"

namespace trellis::impl {

namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Face = Mesh::Face_index;
using Halfedge = Mesh::Halfedge_index;

// Edges used by more than two faces (any direction), counted over the soup.
std::size_t nonmanifold_edge_count(const std::vector<std::vector<std::size_t>>& polygons) {
  std::map<std::pair<std::size_t, std::size_t>, int> use;
  for (const auto& p : polygons)
    for (std::size_t k = 0; k < p.size(); ++k) {
      const std::size_t a = p[k], b = p[(k + 1) % p.size()];
      ++use[{std::min(a, b), std::max(a, b)}];
    }
  std::size_t n = 0;
  for (const auto& [e, c] : use) n += c > 2 ? 1 : 0;
  return n;
}

// A face's vertices starting at its smallest index: equal for the same face, different when
// its orientation is reversed.
std::array<std::size_t, 3> canonical(std::array<std::size_t, 3> v) {
  std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
  return v;
}

std::array<std::size_t, 3> face_vertices(const Mesh& m, Face f) {
  std::array<std::size_t, 3> v{};
  int k = 0;
  for (auto vd : CGAL::vertices_around_face(m.halfedge(f), m)) {
    if (k < 3) v[static_cast<std::size_t>(k)] = vd;
    ++k;
  }
  return canonical(v);
}

TriangleMesh repair(const TriangleMesh& input, const MeshRepairOptions& options,
                    MeshRepairReport& report) {
  report = {};
  std::vector<Point> points;
  points.reserve(input.vertices.size());
  for (const auto& v : input.vertices) points.emplace_back(v.x, v.y, v.z);
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(input.triangles.size());
  for (const auto& t : input.triangles) polygons.push_back({t[0], t[1], t[2]});

  // Soup: same three vertices (either orientation) once; faces whose corners coincide dropped.
  const std::size_t before = polygons.size();
  PMP::merge_duplicate_points_in_polygon_soup(points, polygons);
  report.duplicate_faces = PMP::merge_duplicate_polygons_in_polygon_soup(points, polygons);
  PMP::repair_polygon_soup(points, polygons);
  report.degenerate_faces = before - report.duplicate_faces - polygons.size();
  report.nonmanifold_edges = nonmanifold_edge_count(polygons);

  // Consistent orientation; non-manifold edges and vertices are split (points duplicated).
  std::map<std::array<std::size_t, 3>, int> as_read;
  for (const auto& p : polygons) as_read[canonical({p[0], p[1], p[2]})] = 1;
  const std::size_t points_before = points.size();
  PMP::orient_polygon_soup(points, polygons);
  // Split points are copies appended at the end; map them back to count flips.
  std::map<Point, std::size_t> first;
  for (std::size_t i = 0; i < points_before; ++i) first.emplace(points[i], i);
  for (const auto& p : polygons) {
    std::array<std::size_t, 3> o{};
    for (int k = 0; k < 3; ++k) {
      const std::size_t i = p[static_cast<std::size_t>(k)];
      o[static_cast<std::size_t>(k)] = i < points_before ? i : first.at(points[i]);
    }
    if (!as_read.count(canonical(o))) ++report.flipped_faces;
  }

  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  report.stitched_edges = PMP::stitch_borders(mesh);
  // Seams whose two sides have different vertices (T-junctions: one long edge facing a chain of
  // short ones) do not stitch: border vertices are snapped onto the border edges facing them
  // (which splits those edges), then stitched. The tolerance is far below a printer's resolution.
  if (!CGAL::is_closed(mesh)) {
    const CGAL::Bbox_3 box = PMP::bbox(mesh);
    const double diagonal =
        std::sqrt(CGAL::square(box.xmax() - box.xmin()) + CGAL::square(box.ymax() - box.ymin()) +
                  CGAL::square(box.zmax() - box.zmin()));
    const CGAL::Constant_property_map<Mesh::Vertex_index, double> tolerance(1e-5 * diagonal);
    report.snapped_vertices = PMP::experimental::snap_borders(mesh, tolerance);
    if (report.snapped_vertices) report.stitched_edges += PMP::stitch_borders(mesh);
  }

  // Zero-area faces (three distinct but collinear corners) are collapsed with their edges.
  for (Face f : mesh.faces())
    if (PMP::is_degenerate_triangle_face(f, mesh)) ++report.degenerate_faces;
  PMP::remove_degenerate_faces(mesh);
  mesh.collect_garbage();

  // Small holes: triangulated (no refinement: the slicer needs only the surface closed).
  std::vector<Halfedge> cycles;
  PMP::extract_boundary_cycles(mesh, std::back_inserter(cycles));
  for (Halfedge h : cycles) {
    std::size_t edges = 0;
    for (auto hh : CGAL::halfedges_around_face(h, mesh)) {
      (void)hh;
      ++edges;
    }
    if (edges > options.max_hole_edges) {
      ++report.holes_left;
      continue;
    }
    std::vector<Face> patch;
    PMP::triangulate_hole(mesh, h, std::back_inserter(patch));
    if (patch.empty()) {
      ++report.holes_left;
      continue;
    }
    ++report.holes_filled;
    report.hole_faces += patch.size();
  }
  report.nonmanifold_vertices = PMP::duplicate_non_manifold_vertices(mesh);

  // Every shell outwards, as other slicers take them: CAD assemblies overlap shells (motor.stl);
  // nesting them as cavities (orient_to_bound_a_volume) loses parts PrusaSlicer prints.
  if (CGAL::is_closed(mesh)) {
    std::map<Face, std::array<std::size_t, 3>> was;
    for (Face f : mesh.faces()) was[f] = face_vertices(mesh, f);
    PMP::orient(mesh);  // every shell outwards: a solid each, united when sliced
    for (Face f : mesh.faces())
      if (face_vertices(mesh, f) != was[f]) ++report.inverted_faces;
  }

  mesh.collect_garbage();
  TriangleMesh out;
  out.vertices.reserve(mesh.number_of_vertices());
  for (auto v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    out.vertices.push_back({p.x(), p.y(), p.z()});
  }
  for (Face f : mesh.faces()) {
    std::array<std::uint32_t, 3> t{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      if (k < 3) t[static_cast<std::size_t>(k++)] = static_cast<std::uint32_t>(v.idx());
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace

// CGAL checks its preconditions where they are compiled in (builds without NDEBUG: the sanitizer
// build): a degenerate soup (faces that are coplanar where a shell is oriented, overlapping
// faces) fails one by throwing. That is the input's fault, said as such, never an abort or an
// internal error.
TriangleMesh repair_mesh(const TriangleMesh& input, const MeshRepairOptions& options,
                         MeshRepairReport& report) {
  try {
    return repair(input, options, report);
  } catch (const CGAL::Failure_exception& e) {
    throw GeometryError(
        "mesh repair cannot handle this mesh: it has degenerate geometry "
        "(overlapping or coplanar faces that meet where a shell is oriented; "
        "CGAL: " +
        e.expression() + " failed in " + e.library() +
        "). Fix the mesh in a mesh editor (remove self-intersections and "
        "duplicate shells) and slice that");
  }
}

}  // namespace trellis::impl
