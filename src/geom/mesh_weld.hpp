// The binary STL reader's weld: straight from the file's 50-byte records (geom/mesh_weld.cpp).
#pragma once
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

}  // namespace trellis
