// Fuzzes the G-code reader (counts and IR) and, for small prints, the analysis of what it read:
// never crashes, never hangs, and reading line by line counts exactly what feed() counts. Input
// starting with "GCDE" goes through the binary G-code decoder (blocks, CRC, Deflate, Heatshrink,
// MeatPack), whose only failure is a ParseError.
#include <algorithm>
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
  // Differential: line by line (the general reader only) must count exactly what feed() (with
  // its one-pass reader of plain moves) counted.
  {
    trellis::Diagnostics diag2;
    trellis::CountingSink lines(5, 500);
    trellis::GcodeScanner general(lines, {}, diag2, "fuzz");
    for (std::size_t pos = 0; pos < text.size();) {
      const std::size_t nl = std::min(text.find('\n', pos), text.size());
      general.line(text.substr(pos, nl - pos));
      pos = nl + 1;
    }
    lines.finish();
    const auto& a = counter.counts;
    const auto& b = lines.counts;
    if (a.extrusion_moves != b.extrusion_moves || a.travel_moves != b.travel_moves ||
        a.retractions != b.retractions || a.layers != b.layers || a.paths != b.paths ||
        !(a.extruded_length == b.extruded_length ||
          (a.extruded_length != a.extruded_length && b.extruded_length != b.extruded_length)) ||
        !(a.filament == b.filament || (a.filament != a.filament && b.filament != b.filament)) ||
        diag.total() != diag2.total() || scanner.lines() != general.lines())
      __builtin_trap();
  }
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
