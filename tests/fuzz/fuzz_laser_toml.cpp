// Fuzzes the laser (PBF) profile reader — a settings TOML read through the schema: any input
// parses or throws trellis::Error.
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/settings/settings.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    trellis::Settings st;
    st.load_toml(std::string(reinterpret_cast<const char*>(data), size), "fuzz.toml");
    (void)st.config().laser;
  } catch (const trellis::Error&) {
  }
  return 0;
}
