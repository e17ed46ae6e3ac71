// Fuzzes the G-code reader (counts and IR) and, for small prints, the analysis of what it read:
// never crashes, never hangs. Input starting with "GCDE" goes through the binary G-code decoder
// (blocks, CRC, Deflate, Heatshrink, MeatPack), whose only failure is a ParseError.
#include <string_view>

#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/gcode_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  trellis::Diagnostics diag;
  trellis::CountingSink counter(5, 500);
  trellis::GcodeScanner scanner(counter, {}, diag, "fuzz");
  scanner.feed(text);
  scanner.finish();
  counter.finish();
  trellis::Toolpath tp;
  try {
    tp = trellis::read_gcode(text, {}, diag, "fuzz");
  } catch (const trellis::ParseError&) {
    return 0;  // a damaged binary G-code file
  }
  std::size_t segments = 0;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) segments += p.segments();
  if (segments < 500) {
    trellis::Graph design;
    design.nodes = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}};
    design.edges = {{0, 1}, {1, 2}};
    trellis::analyze(tp, counter.counts, &design, {});
  }
  return 0;
}
