// Common Layer Interface build files (CLI 2.0) for laser powder-bed machines, written and read.
// ASCII or binary (little-endian long commands: 127 layer, 130 polyline, 132 hatches; the
// reader also takes the short ones, 128, 129 and 131). Contour paths are $$POLYLINE id 1, hatch
// vectors $$HATCHES id 2; units 1 µm. CLI+: the header also carries one parameter block per id,
// `// PROFILE_DEF=<id> NAME="<label>" POWER=<W> SPEED=<mm/s> //` (a comment, so plain CLI readers
// skip it — the convention of the 3MF Consortium's CLI+ exporter), which the reader maps back
// onto each path's power and speed.
#pragma once
#include <string>

#include "trellis/core/diagnostics.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct CliWriteOptions {
  bool binary = false;  // binary geometry section instead of ASCII
  bool plus = true;     // CLI+ parameter blocks (power and speed per id) in the header
};

std::string write_cli(const Toolpath& toolpath, const LaserProfile& profile,
                      const CliWriteOptions& options);
void write_cli_file(const std::string& path, const Toolpath& toolpath, const LaserProfile& profile,
                    const CliWriteOptions& options);

// Any CLI file (ASCII or binary, with or without CLI+ blocks) → the toolpath IR: a layer per
// $$LAYER (z in mm), a path per polyline (role Contour, or Infill when its id's label or
// PROFILE_DEF name says "hatch"/"infill") and per hatch vector (Infill), power and speed from
// the id's CLI+ block. Malformed input → ParseError naming `origin` and the byte offset (and
// line, for ASCII). Unknown commands are skipped with a warning in `diag`.
Toolpath read_cli(const std::string& bytes, const std::string& origin, Diagnostics* diag = nullptr);
Toolpath read_cli_file(const std::string& path, Diagnostics* diag = nullptr);

}  // namespace trellis
