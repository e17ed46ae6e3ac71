// The G-code writer: one writer for every machine, driven by the profile (style: machines as
// data). `marlin` computes E per segment from Eq. 4; `pneumatic` (.nc) opens a valve and sets a
// pressure per path instead of E; `embedded` is pneumatic inside a support bath: every travel
// lifts straight up to the bath surface plus a clearance, moves, and re-enters straight down;
// optional dwell at nodes and overlap past path ends; one nozzle per tool with XY offsets,
// pressures, the idle nozzle raised and a tool-change command. Numbers: XYZ with 3 decimals (1 µm,
// finer than any motion system here), E with 5 (10 nm of filament, so per-segment rounding cannot
// accumulate), both without trailing zeros; F in whole mm/min.
//
// What other tools read (PrusaSlicer's conventions, docs/gcode.md): embedded PNG thumbnails,
// ;LAYER_COUNT: in the header, ;TYPE: (gcode_type_name), ;WIDTH: and ;HEIGHT: before each path
// where they change, M73 P<percent> R<minutes left> at every layer for firmwares that show it
// (Marlin, RepRapFirmware, Klipper), and the closing "; total layers count", "; estimated printing
// time (normal mode)" and "; filament used [mm]" lines.
#pragma once
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "trellis/machine/profile.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct GcodeStats {
  std::size_t bytes = 0;
  std::size_t paths = 0;
  std::size_t travel_moves = 0;
  std::size_t retractions = 0;
  double travel_length = 0;  // mm
  double print_length = 0;   // mm
  double filament = 0;       // mm of filament (marlin)
  // The print-time estimate of the file written, as `trellis analyze` reads it back
  // (machine/print_time.hpp: acceleration and jerk, dwells, heater waits); heating_s: the heater
  // waits' part of it.
  double print_time_s = 0, heating_s = 0;
  // The prime line drawn before the print (gcode.prime_line): its length and filament (mm; not
  // in `filament`, which is the print's; the footer's "; filament used" has both).
  double prime_length = 0, prime_filament = 0;
  std::size_t tool_changes = 0;      // embedded
  std::size_t gradient_changes = 0;  // mixture / tool / temperature commands for graded paths
  double lookahead = 0;              // mm of path the changes were issued early
  // Build plates: the time estimate per part (Path::part - 1): its moves and the travels into it.
  std::vector<double> part_time_s;
  // Process fields (Path::temperature, fan): nozzle temperature changes written between paths,
  // each followed by the temperature.settle dwell, and the dwell time they add.
  std::size_t temperature_changes = 0;
  double settle_time_s = 0;
  std::size_t fan_changes = 0;
  // Printable but suspicious (machine/machine_check.hpp): kind and message.
  std::vector<std::pair<std::string, std::string>> warnings;
};

// A picture for printer front ends: PNG bytes of a width x height image.
struct GcodeThumbnail {
  int width = 0, height = 0;
  std::string png;
};

// Standard base64 (RFC 4648, with padding).
std::string base64(std::string_view bytes);
// A thumbnail as PrusaSlicer embeds it: "; thumbnail begin WxH LEN", base64 rows, "; thumbnail
// end".
std::string thumbnail_block(const GcodeThumbnail& thumbnail);

// E for a segment of `length` mm printed at layer thickness `layer` (Eq. 4).
double extrusion_for(double length, double layer, const MachineProfile& profile);

// Checks the toolpath against the machine first (check_for_machine): MachineError if it cannot
// print as meant, warnings into the stats.
std::string write_gcode(const Toolpath& toolpath, const MachineProfile& profile,
                        GcodeStats* stats = nullptr,
                        const std::vector<GcodeThumbnail>& thumbnails = {});
// The same text into `out` (its old text replaced), reusing its memory: a caller that writes
// many files keeps one buffer, whose pages the kernel then does not have to fault in and zero for
// each file again (that, and whether it can hand out huge pages, is most of what varies between
// runs of write_gcode on a busy machine: bench_gcode_writer).
void write_gcode_into(std::string& out, const Toolpath& toolpath, const MachineProfile& profile,
                      GcodeStats* stats = nullptr,
                      const std::vector<GcodeThumbnail>& thumbnails = {});
// Writes atomically; returns the stats.
GcodeStats write_gcode_file(const std::string& path, const Toolpath& toolpath,
                            const MachineProfile& profile,
                            const std::vector<GcodeThumbnail>& thumbnails = {});

// The same file from streamed layers (layer_count of them), in bounded memory: `layers` is visited
// a few times (extent, machine check, tools, writing); `meta` gives the source, job and part
// labels (its layers are not read). The bytes are write_gcode_file's for the same layers, except
// that mixtures are refused (their look-ahead needs the whole toolpath).
GcodeStats write_gcode_stream(const std::string& path, const Toolpath& meta,
                              std::size_t layer_count, const LayerSource& layers,
                              const MachineProfile& profile,
                              const std::vector<GcodeThumbnail>& thumbnails = {});
// The same bytes, the thumbnails made by `thumbnails` while the text is written: on another
// thread when the run has two (so `layers` must allow two visits at once, as
// LayerSpill::source's do), put into the header as the text is copied out.
using GcodeThumbnailMaker = std::function<std::vector<GcodeThumbnail>()>;
GcodeStats write_gcode_stream(const std::string& path, const Toolpath& meta,
                              std::size_t layer_count, const LayerSource& layers,
                              const MachineProfile& profile, const GcodeThumbnailMaker& thumbnails);

// Expands {key} / {section.key} placeholders with setting values; throws SettingError.
std::string expand_template(const std::string& text, const MachineProfile& profile,
                            const std::string& which);

}  // namespace trellis
