// Fuzzes the machine profile reader.
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/settings/settings.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    trellis::machine_profile_from_toml(std::string(reinterpret_cast<const char*>(data), size),
                                       "fuzz");
  } catch (const trellis::Error&) {
  }
  return 0;
}
