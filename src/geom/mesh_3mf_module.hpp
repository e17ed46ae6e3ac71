// The 3MF module's table (src/core/module.hpp): read_3mf returns the stored triangles with build
// transforms and the model unit applied (millimetres), not yet welded or checked.
#pragma once
#include <string>
#include <vector>

#include "../core/module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/lattice/io.hpp"

namespace trellis {

// Where a package lib3mf refused is broken (src/geom/locate_3mf.cpp): `where` names the part and
// line/column ("3D/3dmodel.model line 12, column 40"), `what` the problem; `what` is empty when
// nothing could be placed.
struct Located3mf {
  std::string where, what;
};

namespace impl {
Located3mf locate_3mf_problem(const std::string& path);
std::vector<unsigned char> package_without_dangling_relationships(const std::string& path);
LatticeInput read_beam_lattice_3mf(const std::string& path, Diagnostics& diag);
void write_beam_lattice_3mf(const std::string& path, const Graph& g, double default_radius);
}  // namespace impl

struct Mesh3mfModule {
  detail::ModuleHeader header;
  TriangleMesh (*read_3mf)(const std::string&);
  void (*write_3mf)(const std::string&, const TriangleMesh&, const std::string& unit);
  Located3mf (*locate)(const std::string&);
  // 3MF beam lattices (lattice/beam3mf.cpp): in the module so that lib3mf, libzip and libcrypto
  // (about 4,700 symbol relocations) load only when a 3MF file is read or written.
  LatticeInput (*read_beam_lattice)(const std::string&, Diagnostics&);
  void (*write_beam_lattice)(const std::string&, const Graph&, double);
};

}  // namespace trellis
