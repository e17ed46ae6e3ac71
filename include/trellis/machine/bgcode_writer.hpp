// PrusaSlicer binary G-code (.bgcode) out, written from the published specification (libbgcode
// doc/specifications.md; no libbgcode code is used; the reader is machine/bgcode.hpp): the
// "File header" (GCDE, version 1, CRC32), then the blocks in the order the specification lists
// them: file metadata, printer metadata, one thumbnail block per picture (PNG), print metadata,
// slicer metadata, and the G-code in blocks of at most 64 KiB (PrusaSlicer's size), each ending
// at a line end, every block followed by its CRC32. G-code blocks are Heatshrink 12/4, as
// PrusaSlicer 2.7+ writes them: Prusa's firmware decompresses G-code blocks stored plain or
// Heatshrink 11/4 or 12/4 and refuses Deflate ones (Prusa-Firmware-Buddy,
// PrusaPackGcodeReader::init_decompression); the slicer metadata block is Deflate, as
// PrusaSlicer's. The G-code is MeatPack-encoded before compression by default, as PrusaSlicer
// writes it (gcode.binary_encoding; encoding 2 keeps comments), or plain text (encoding 0).
//
// The G-code blocks hold the text G-code writer's bytes exactly (machine/gcode_writer.hpp),
// written without its "; thumbnail begin" comments: the pictures are in the thumbnail blocks.
// The writer holds one block at a time, so a streamed G-code is packed in bounded memory.
// write_gcode_file and write_gcode_stream (machine/gcode_writer.hpp) write this format for a
// path ending in .bgcode or with gcode.binary set (binary_gcode_output below).
#pragma once
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "trellis/core/file.hpp"
#include "trellis/machine/bgcode.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/profile.hpp"

namespace trellis {

// Key-value pairs of the four metadata blocks ("INI encoding": key=value lines).
struct BgcodeMetadata {
  using Pairs = std::vector<std::pair<std::string, std::string>>;
  Pairs file, printer, print, slicer;
};

struct BgcodeOptions {
  // G-code blocks: any of the specification's compressions; Heatshrink 12/4 is what the
  // printers read (see above).
  BgcodeCompression gcode = BgcodeCompression::Heatshrink12;
  // The most G-code bytes in one block before compression.
  std::size_t block_size = std::size_t{1} << 16;
  bool meatpack = true;  // G-code blocks MeatPack-encoded (encoding 2) before compression
};

// Packs G-code text into a .bgcode byte stream through `put`: start() once with the metadata
// and pictures, gcode() with the text in pieces of any size, finish() at the end.
class BgcodeWriter {
 public:
  explicit BgcodeWriter(ByteWriter put, BgcodeOptions options = {});
  void start(const BgcodeMetadata& metadata, const std::vector<GcodeThumbnail>& thumbnails);
  void gcode(std::string_view text);
  void finish();
  std::size_t bytes() const { return bytes_; }  // written so far

 private:
  void block(BgcodeBlock type, BgcodeCompression compression, std::string_view params,
             std::string_view data);
  void metadata(BgcodeBlock type, const BgcodeMetadata::Pairs& pairs,
                BgcodeCompression compression);
  void flush_gcode(std::size_t upto);
  ByteWriter put_;
  BgcodeOptions options_;
  std::string pending_, packed_, block_, encoded_;
  std::size_t bytes_ = 0;
  bool started_ = false, finished_ = false;
  bool mid_line_ = false;  // the last G-code block ended inside a line
};

// The options a machine profile asks for (gcode.binary_encoding).
BgcodeOptions bgcode_options(const MachineProfile& profile);

// Whether writing G-code to `path` for this machine makes binary G-code: the path ends in
// .bgcode, or gcode.binary is set. Refuses (MachineError, SettingError) a machine whose firmware
// is not Prusa's (machine.firmware) and gcode.binary with an output not named .bgcode.
bool binary_gcode_output(const std::string& path, const MachineProfile& profile);

}  // namespace trellis
