// The binary STL reader's weld: straight from the file's 50-byte records (geom/mesh_weld.cpp).
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "trellis/geom/mesh.hpp"

namespace trellis {

// Triangles given as corners' indices into `points` (corners[3t..3t+2] is triangle t; OBJ
// faces): the mesh weld_corners makes from the same corners' coordinates, with the points welded
// (not the three times as many corners).
TriangleMesh weld_indexed(const std::vector<Vec3>& points,
                          const std::vector<std::uint32_t>& corners);

// `count` records (after the 84-byte header) of a binary STL, welded like weld_corners. Checks
// the coordinates as it reads them: `first_invalid` is the lowest triangle with a coordinate
// not finite or beyond ±limit, `count` if there is none (then the caller must throw).
TriangleMesh weld_binary_stl(const char* records, std::size_t count, std::size_t& first_invalid,
                             double limit);

}  // namespace trellis
