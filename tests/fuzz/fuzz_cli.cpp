// Fuzzes the laser build-file (CLI, ASCII and binary) reader: any input reads or throws
// trellis::Error.
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/machine/cli.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    (void)trellis::read_cli(std::string(reinterpret_cast<const char*>(data), size), "fuzz.cli");
  } catch (const trellis::Error&) {
  }
  return 0;
}
