// Fuzzes the AERO vertex/edge CSV pair: the input is split at the first '|' into the two files.
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/lattice/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto bar = text.find('|');
  try {
    trellis::parse_aero_pair(text.substr(0, bar), "v.csv",
                             bar == std::string::npos ? "" : text.substr(bar + 1), "e.csv");
  } catch (const trellis::Error&) {
  }
  return 0;
}
