// 3MF beam lattices: the work is in the beam3mf module (lattice/beam3mf.cpp), loaded on first use,
// so that libtrellis does not link lib3mf and every program pays its relocations only when it reads
// or writes a 3MF file.
#include "beam3mf_module.hpp"
#include "trellis/lattice/io.hpp"

namespace trellis {

LatticeInput read_beam_lattice_3mf(const std::string& path, Diagnostics& diag) {
  return detail::module_table<Beam3mfModule>("beam3mf").read_beam_lattice(path, diag);
}

void write_beam_lattice_3mf(const std::string& path, const Graph& g, double default_radius) {
  detail::module_table<Beam3mfModule>("beam3mf").write_beam_lattice(path, g, default_radius);
}

}  // namespace trellis
