// The binary STL reader's weld: straight from the file's 50-byte records (geom/mesh_weld.cpp).
#pragma once
#include <cstddef>

#include "trellis/geom/mesh.hpp"

namespace trellis {

// `count` records (after the 84-byte header) of a binary STL, welded like weld_corners.
TriangleMesh weld_binary_stl(const char* records, std::size_t count);

}  // namespace trellis
