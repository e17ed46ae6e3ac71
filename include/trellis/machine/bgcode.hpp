// PrusaSlicer binary G-code (.bgcode), read from its published specification (libbgcode
// doc/specifications.md; no libbgcode code is used): a 10-byte file header ("GCDE", version 1,
// checksum type) followed by blocks (file / printer / print / slicer metadata, thumbnails,
// G-code), each a header (type, compression, sizes), parameters, data and an optional CRC32 over
// all three. Compression: none, Deflate (zlib), Heatshrink with window/lookahead 11/4 or 12/4.
// G-code blocks are plain text or MeatPack (with or without comments kept). The writer is
// machine/bgcode_writer.hpp.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace trellis {

// The specification's "Block header" Type and Compression values.
enum class BgcodeBlock : std::uint16_t {
  FileMetadata = 0,
  Gcode = 1,
  SlicerMetadata = 2,
  PrinterMetadata = 3,
  PrintMetadata = 4,
  Thumbnail = 5
};
enum class BgcodeCompression : std::uint16_t {
  None = 0,
  Deflate = 1,
  Heatshrink11 = 2,
  Heatshrink12 = 3
};
// The specification's "File header": magic, version, checksum type (1 = CRC32).
inline constexpr char kBgcodeMagic[] = "GCDE";
inline constexpr std::uint32_t kBgcodeVersion = 1;
inline constexpr std::uint16_t kBgcodeCrc32 = 1;

// True if `head` (the first bytes of a file) starts with the bgcode magic "GCDE".
bool is_bgcode(std::string_view head);

// Heatshrink (LZSS, machine/heatshrink.cpp): bit stream MSB first; tag 1 = a literal byte
// (8 bits), tag 0 = a back-reference of `window_bits` bits (distance - 1) and `lookahead_bits`
// bits (count - 1). The decoder stops after `size` bytes; a stream that ends early is a
// ParseError; a reference before the first byte reads zeros (heatshrink's zero-filled window).
std::string heatshrink_decode(std::string_view data, int window_bits, int lookahead_bits,
                              std::size_t size);
// The encoder: greedy longest matches within the window; what heatshrink_decode (and
// heatshrink's own decoder, which Prusa's firmware runs) reads back byte for byte.
std::string heatshrink_encode(std::string_view data, int window_bits, int lookahead_bits);

// MeatPack encoder (machine/meatpack.cpp): `text` (one G-code block's bytes) packed so that
// MeatPackDecoder, and decoders that put a space back before a G line's parameter letters (the
// firmware's, PrusaSlicer's), read back exactly `text`. Comments are kept (the block's encoding
// is 2, "MeatPack with comments"). `continues_line`: the text starts inside a line the previous
// block ended in. A 0xFF byte (never in UTF-8) → std::invalid_argument.
std::string meatpack_encode(std::string_view text, bool continues_line = false);
inline constexpr std::uint16_t kBgcodeMeatPackComments = 2;

// MeatPack decoder (Marlin's packing, as used in bgcode G-code blocks): 4-bit codes for the 15
// commonest characters, two per byte, 0b1111 = a full byte follows; 0xFF 0xFF <cmd> switches
// packing / the no-spaces mode (where code 11 means 'E' instead of ' ').
class MeatPackDecoder {
 public:
  void feed(std::string_view data, std::string& out);

 private:
  void inner(std::uint8_t c, std::string& out);
  void command(std::uint8_t c);
  void put(char c, std::string& out);
  bool active_ = false, no_spaces_ = false, cmd_next_ = false;
  int ff_count_ = 0, full_chars_ = 0;
  char second_ = 0;
  char prev_ = '\n';      // the last character put, for no-spaces mode
  bool comment_ = false;  // inside a ; comment
};

// Reads the blocks of a bgcode file from `read` (which fills a buffer with up to n bytes and
// returns how many it got), checks each CRC, decompresses and decodes the G-code blocks and calls
// `text` with each piece of G-code in order (constant memory: one block at a time). Metadata
// blocks become `; key = value` comment lines, thumbnails are skipped. Errors name `origin` and
// the byte offset of the block.
void read_bgcode(const std::function<std::size_t(char*, std::size_t)>& read,
                 const std::function<void(std::string_view)>& text, const std::string& origin);

// The whole file as G-code text (tests, small files).
std::string bgcode_to_text(std::string_view bytes, const std::string& origin = "bgcode");

// One block as read (CRC checked, data decompressed; G-code decoded from MeatPack): its type,
// compression and parameters (encoding; a thumbnail's format, width and height).
struct BgcodeBlockRead {
  BgcodeBlock type{};
  BgcodeCompression compression{};
  std::uint16_t encoding = 0;  // a thumbnail: its format (0 = PNG)
  int width = 0, height = 0;   // thumbnails
  bool checked = false;        // a CRC32 was present and matched
  std::string data;
};
// Every block of a whole file, in order (tests, tools).
std::vector<BgcodeBlockRead> bgcode_blocks(std::string_view bytes,
                                           const std::string& origin = "bgcode");

}  // namespace trellis
