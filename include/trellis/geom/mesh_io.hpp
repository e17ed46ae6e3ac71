// Reading triangle meshes (STL binary/ASCII, OBJ, 3MF), checking they are closed, and slicing
// them with horizontal planes into the same polygons the field route produces.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/geom/mesh.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

// By extension (.stl, .obj, .3mf; case-insensitive). Vertices are welded once, here (exact
// match, as STL repeats them); the result needs no second weld. Throws ParseError naming file and
// line (or triangle) on malformed input.
TriangleMesh read_mesh(const std::string& path);
TriangleMesh read_stl(const std::string& path);
TriangleMesh read_obj(const std::string& path);
TriangleMesh read_3mf(const std::string& path);
// 3MF with one mesh object and one build item (lib3mf), written atomically. `unit` is the 3MF
// model unit (micron, millimeter, centimeter, inch, foot, meter); the mesh is in mm and scaled to
// it. read_3mf honours the unit of the file it reads and returns millimetres.
void write_3mf(const std::string& path, const TriangleMesh& mesh,
               const std::string& unit = "millimeter");
// Wavefront OBJ text: `o name`, one `v x y z` line per vertex (mm, shortest round-trip
// numbers) and one `f a b c` line per triangle (1-based, counter-clockwise).
std::string mesh_to_obj(const TriangleMesh& mesh, const std::string& name = "trellis");
// By extension (.stl binary, .obj, .3mf; case-insensitive), written atomically; `name` goes in
// the STL header or the OBJ object; a stream (/dev/null, /dev/stdout: is_stream_output) gets STL.
// Any other name: SettingError naming `what` (the flag or key of the output) and the extensions a
// mesh is written as; nothing is written.
void write_mesh(const std::string& path, const TriangleMesh& mesh, const std::string& name,
                const std::string& what);
// Whether write_mesh writes `path` (its extension is .stl, .obj or .3mf).
bool is_mesh_output(const std::string& path);
// STL from memory (for tests and fuzzing); `name` appears in errors. A large ASCII STL or OBJ is
// read in pieces of about `piece` bytes (0: 1 MB) in parallel, split at line starts; the mesh
// and the errors are those of reading it line after line (tests give small pieces).
TriangleMesh parse_stl(const std::string& bytes, const std::string& name);
TriangleMesh parse_obj(const std::string& text, const std::string& name);
TriangleMesh parse_stl(const std::string& bytes, const std::string& name, std::size_t piece);
TriangleMesh parse_obj(const std::string& text, const std::string& name, std::size_t piece);

// Merges vertices with identical coordinates (-0 == +0) and drops degenerate triangles. Vertices
// are numbered in order of first use; the result does not depend on the thread count.
TriangleMesh weld(const TriangleMesh& mesh);
// The same from a triangle soup: corners[3t], [3t+1], [3t+2] are triangle t (counter-clockwise).
TriangleMesh weld_corners(const std::vector<Vec3>& corners);

struct MeshCheck {
  std::size_t triangles = 0;
  std::size_t open_edges = 0;         // used by one triangle
  std::size_t nonmanifold_edges = 0;  // used by more than two, or twice in the same direction
  std::string first_problem;          // where, for the error message
  bool closed() const { return open_edges == 0 && nonmanifold_edges == 0; }
};
MeshCheck check_mesh(const TriangleMesh& mesh);
// Throws GeometryError naming the mesh and the first problem if it is not closed and manifold.
void require_closed(const TriangleMesh& mesh, const std::string& name);

BBox3 bounds(const TriangleMesh& mesh);
double volume(const TriangleMesh& mesh);

// Cross-section at height z: closed, oriented, nested polygons. The mesh must be closed.
Regions slice_mesh(const TriangleMesh& mesh, double z, double stitch_tolerance = 1e-6);
// The same over only the listed triangles (e.g. those triangles_by_plane gives for z).
// `overlapping`: shells may intersect (repaired meshes): the union of their sections (positive
// winding) instead of the faster nesting of rings that do not cross.
Regions slice_mesh(const TriangleMesh& mesh, double z, const std::vector<std::uint32_t>& triangles,
                   double stitch_tolerance = 1e-6, bool overlapping = false);
// For each plane zs[i], the triangles slice_mesh cuts there (lowest vertex <= z < highest), so
// slicing many layers visits each triangle only at the planes it spans.
std::vector<std::vector<std::uint32_t>> triangles_by_plane(const TriangleMesh& mesh,
                                                           const std::vector<double>& zs);

}  // namespace trellis
