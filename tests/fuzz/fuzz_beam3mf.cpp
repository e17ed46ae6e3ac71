// Fuzzes the 3MF readers (the file is written to a temporary path first, lib3mf reads files):
// beam lattices (read_beam_lattice_3mf) and meshes (read_mesh). Any input reads or throws
// trellis::Error; bad_alloc from a hostile size is the CLI's clean refusal, not a crash.
#include <unistd.h>

#include <fstream>
#include <new>
#include <string>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/lattice/io.hpp"

// Debian's lib3mf 1.8 leaks the libzip handles of a package it refuses part way (its
// COpcPackageReader error paths; the CLI exits right after such an error, so nothing
// accumulates). Leak reports' stacks end in libzip (the fast unwinder stops there), so blocks
// allocated by libzip are suppressed: a leak in Trellis's own code still stops the fuzzer. The
// located walk (src/geom/locate_3mf.cpp) keeps non-ZIP input from lib3mf; read_mesh runs it first
// with one thread, beside lib3mf with two (then lib3mf also reads packages the walk refuses).
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libzip.so\n";
}

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  static const std::string path = "/tmp/trellis_fuzz_3mf_" + std::to_string(::getpid()) + ".3mf";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data), size);
  try {
    trellis::Diagnostics diag;
    (void)trellis::read_beam_lattice_3mf(path, diag);
  } catch (const trellis::Error&) {
  } catch (const std::bad_alloc&) {
  }
  try {
    (void)trellis::read_mesh(path);
  } catch (const trellis::Error&) {
  } catch (const std::bad_alloc&) {
  }
  return 0;
}
