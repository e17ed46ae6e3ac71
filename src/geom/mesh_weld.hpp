// The binary STL reader's weld: straight from the file's 50-byte records (geom/mesh_weld.cpp).
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "trellis/geom/mesh.hpp"

namespace trellis {

// Triangles given as corners' indices into `points` (corners[3t..3t+2] is triangle t; OBJ
// faces): the mesh weld_corners makes from the same corners' coordinates, with the points welded
// (not the three times as many corners).
TriangleMesh weld_indexed(const std::vector<Vec3>& points,
                          const std::vector<std::uint32_t>& corners);

// `records(first, n, scratch)`: the binary STL's records of triangles first .. first + n (50
// bytes each, after the 84-byte header), read into `scratch` (room for n records) or found
// elsewhere; called from several threads at once, never for more than 16,384 records.
using StlRecords = std::function<const char*(std::size_t first, std::size_t n, char* scratch)>;

// `count` records of a binary STL, welded like weld_corners. Checks the coordinates as it reads
// them: `first_invalid` is the lowest triangle with a coordinate not finite or beyond ±limit,
// `count` if there is none (then the caller must throw).
TriangleMesh weld_binary_stl(const StlRecords& records, std::size_t count,
                             std::size_t& first_invalid, double limit);

// A run of a triangle soup (the ASCII STL reader's piece of text) welded on its own: its points
// in order of first use, its triangles as indices into them (degenerate ones kept).
struct WeldedRun {
  std::vector<Vec3> points;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};
// A thread's hash table for weld_run (kept between runs, emptied after each).
struct WeldTable {
  std::vector<std::uint32_t> slots;
  std::vector<std::uint32_t> used;
};
// corners[0 .. n), 3 per triangle, welded into `run`.
void weld_run(const Vec3* corners, std::size_t n, WeldedRun& run, WeldTable& table);
// The runs one after the other welded: the mesh weld_corners makes from all their corners in
// order (the runs' points welded with one another, the triangles renumbered). Empties `runs`.
TriangleMesh join_runs(std::vector<WeldedRun>& runs);

}  // namespace trellis
