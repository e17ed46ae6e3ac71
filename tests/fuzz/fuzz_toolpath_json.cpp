// Fuzzes the toolpath JSON reader.
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/toolpath/json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    trellis::toolpath_from_json(std::string(reinterpret_cast<const char*>(data), size), "fuzz");
  } catch (const trellis::Error&) {
  }
  return 0;
}
