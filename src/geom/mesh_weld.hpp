// The binary STL reader's weld: straight from the file's 50-byte records (geom/mesh_weld.cpp).
#pragma once
#include <cstddef>

#include "trellis/geom/mesh.hpp"

namespace trellis {

// `count` records (after the 84-byte header) of a binary STL, welded like weld_corners. Checks
// the coordinates as it reads them: `first_invalid` is the lowest triangle with a coordinate
// not finite or beyond ±limit, `count` if there is none (then the caller must throw).
TriangleMesh weld_binary_stl(const char* records, std::size_t count, std::size_t& first_invalid,
                             double limit);

}  // namespace trellis
