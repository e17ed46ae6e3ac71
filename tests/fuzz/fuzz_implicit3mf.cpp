// Fuzzes the 3MF level-set design reader (field/implicit_3mf.hpp; the package is written to a
// temporary path first, libzip reads files): any input reads or throws trellis::Error, and a
// design that reads evaluates at a few points without crashing.
#include <unistd.h>

#include <fstream>
#include <new>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/field/implicit_3mf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  static const std::string path =
      "/tmp/trellis_fuzz_implicit3mf_" + std::to_string(::getpid()) + ".3mf";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data), size);
  try {
    if (!trellis::is_implicit_3mf(path)) return 0;
    trellis::VcadOptions opt;
    opt.mesh_voxel = 1;
    const auto d = trellis::read_implicit_3mf(path, opt);
    trellis::Evaluator ev(d.field);
    for (double t : {-1.0, 0.0, 0.5, 2.0}) (void)ev.value({t, t * 0.5, -t});
  } catch (const trellis::Error&) {
  } catch (const std::bad_alloc&) {
  }
  return 0;
}
