// The beam3mf module's table (src/core/module.hpp): 3MF beam lattices through lib3mf 1.8
// (lattice/beam3mf.cpp), in a module so that lib3mf, libzip and libcrypto (about 4,700 symbol
// relocations) load only when a 3MF file is read or written. Its own module, not the 3mf one's
// table: the mesh module (geom) cannot name the lattice's types.
#pragma once
#include <string>

#include "../core/module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/io.hpp"

namespace trellis {

namespace impl {
LatticeInput read_beam_lattice_3mf(const std::string& path, Diagnostics& diag);
void write_beam_lattice_3mf(const std::string& path, const Graph& g, double default_radius);
}  // namespace impl

struct Beam3mfModule {
  detail::ModuleHeader header;
  LatticeInput (*read_beam_lattice)(const std::string&, Diagnostics&);
  void (*write_beam_lattice)(const std::string&, const Graph&, double);
};

}  // namespace trellis
