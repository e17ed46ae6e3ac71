// Common Layer Interface build files (CLI 2.0) for laser powder-bed machines, written and read.
// ASCII or binary (little-endian long commands: 127 layer, 130 polyline, 132 hatches; the
// reader also takes the short ones, 128, 129 and 131). Contour paths are $$POLYLINE id 1, hatch
// vectors $$HATCHES id 2; units 1 µm. CLI+: the header also carries one parameter block per id,
// `// PROFILE_DEF=<id> NAME="<label>" POWER=<W> SPEED=<mm/s> //` (a comment, so plain CLI readers
// skip it — the convention of the 3MF Consortium's CLI+ exporter), which the reader maps back
// onto each path's power and speed.
// Several lasers (LaserProfile::lasers, or a path's `tool` beyond 0): each laser has its own
// contour and hatch ids (laser L's are laser 1's plus 2 × L × the parts, one part without a
// plate), labelled "contour laser 2" and, in CLI+, LASER=2; the reader sets each path's `tool`
// to its laser (0-based) from either.
#pragma once
#include <cstdio>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// A laser parameter set beyond the contour and hatch ids (a contour offset's, the core's, the
// up-skin's…): written under its own id after every part's and laser's contour and hatch ids,
// one per set and laser, labelled with its name (and, in CLI+, its power and speed).
struct CliParameterSet {
  std::string name;             // the id's label; "hatch" in it reads back as hatch
  bool hatch = false;           // for hatch vectors (else contours)
  double power = 0, speed = 0;  // W, mm/s: the paths written under it have exactly these
};

// The build file's sets for named parameter sets (Toolpath::parameter_sets) but the first
// `profile_sets`, the profile's contour and hatch (ids 1 and 2).
std::vector<CliParameterSet> cli_parameter_sets(const std::vector<ParameterSet>& named,
                                                std::size_t profile_sets = 2);

struct CliWriteOptions {
  bool binary = false;  // binary geometry section instead of ASCII
  bool plus = true;     // CLI+ parameter blocks (power and speed per id) in the header
  // A path whose kind, power and speed are a set's goes under the set's id (the first such set);
  // every other path under its part's and laser's contour or hatch id. Per block, the hatch
  // vectors are one $$HATCHES record per run of one id, in their order.
  std::vector<CliParameterSet> sets;
};

std::string write_cli(const Toolpath& toolpath, const LaserProfile& profile,
                      const CliWriteOptions& options);
void write_cli_file(const std::string& path, const Toolpath& toolpath, const LaserProfile& profile,
                    const CliWriteOptions& options);

// A CLI file written layer by layer, in bounded memory: the geometry goes to an anonymous
// temporary file as layers come; finish() writes the header (it needs every point's extent and
// the layer count) and copies the geometry after it into `path` (atomically, see core/file.hpp).
// The bytes are write_cli's for the toolpath of the same layers, source and job. Each layer is
// checked against the laser as it comes (check_for_laser); an error leaves no file.
class CliStreamWriter {
 public:
  CliStreamWriter(std::string path, const LaserProfile& profile, const CliWriteOptions& options,
                  std::string source, std::string job);
  ~CliStreamWriter();
  CliStreamWriter(const CliStreamWriter&) = delete;
  CliStreamWriter& operator=(const CliStreamWriter&) = delete;
  void add(const Layer& layer);
  void finish();
  std::size_t layers() const { return layers_; }

 private:
  void flush();
  std::string path_, source_, job_;
  LaserProfile profile_;
  CliWriteOptions options_;
  std::FILE* body_ = nullptr;
  std::string buffer_;
  BBox3 box_;
  std::size_t layers_ = 0;
  bool finished_ = false;
};

// Any CLI file (ASCII or binary, with or without CLI+ blocks) → the toolpath IR: a layer per
// $$LAYER (z in mm), a path per polyline (role Contour, or Infill when its id's label or
// PROFILE_DEF name says "hatch"/"infill") and per hatch vector (Infill), power and speed from
// the id's CLI+ block. Malformed input → ParseError naming `origin` and the byte offset (and
// line, for ASCII). Unknown commands are skipped with a warning in `diag`.
Toolpath read_cli(const std::string& bytes, const std::string& origin, Diagnostics* diag = nullptr);
Toolpath read_cli_file(const std::string& path, Diagnostics* diag = nullptr);

}  // namespace trellis
