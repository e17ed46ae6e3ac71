// Fuzzes parse_segments_csv: any input either parses or throws trellis::Error; never crashes or
// hangs.
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/lattice/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    const auto in =
        trellis::parse_segments_csv(std::string(reinterpret_cast<const char*>(data), size), "fuzz");
    trellis::Diagnostics diag;
    trellis::clean_graph(in.graph, {}, diag, in.edge_where);
  } catch (const trellis::Error&) {
  }
  return 0;
}
