// Fuzzes the laser (PBF) profile reader: any input parses or throws trellis::Error.
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/machine/laser.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    (void)trellis::laser_profile_from_toml(std::string(reinterpret_cast<const char*>(data), size),
                                           "fuzz.toml");
  } catch (const trellis::Error&) {
  }
  return 0;
}
