#include "trellis/machine/bgcode_writer.hpp"

#include <zlib.h>

#include <algorithm>
#include <filesystem>

#include "trellis/core/error.hpp"
#include "trellis/machine/machine_check.hpp"

namespace trellis {

namespace {

void put_u16(std::string& out, std::uint16_t v) {
  out += static_cast<char>(v & 0xFF);
  out += static_cast<char>(v >> 8);
}

void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
}

// zlib's format (what the reader's uncompress and libbgcode's inflate take).
std::string deflate_zlib(std::string_view data) {
  uLongf size = compressBound(static_cast<uLong>(data.size()));
  std::string out(size, '\0');
  const int rc = compress2(reinterpret_cast<Bytef*>(out.data()), &size,
                           reinterpret_cast<const Bytef*>(data.data()),
                           static_cast<uLong>(data.size()), Z_DEFAULT_COMPRESSION);
  if (rc != Z_OK)
    throw IoError("zlib cannot compress a binary G-code block (" + std::to_string(rc) + ")");
  out.resize(size);
  return out;
}

bool lowercase_ext_is(const std::string& path, const char* ext) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e == ext;
}

}  // namespace

BgcodeWriter::BgcodeWriter(ByteWriter put, BgcodeOptions options)
    : put_(std::move(put)), options_(options) {}

// "Blocks": header (type, compression, uncompressed size, compressed size when compressed),
// parameters, data, then the "Block checksum" (CRC32 of the three).
void BgcodeWriter::block(BgcodeBlock type, BgcodeCompression compression, std::string_view params,
                         std::string_view data) {
  block_.clear();
  put_u16(block_, static_cast<std::uint16_t>(type));
  std::string_view stored = data;
  switch (compression) {
    case BgcodeCompression::None:
      break;
    case BgcodeCompression::Deflate:
      packed_ = deflate_zlib(data);
      stored = packed_;
      break;
    case BgcodeCompression::Heatshrink11:
    case BgcodeCompression::Heatshrink12:
      packed_ =
          heatshrink_encode(data, compression == BgcodeCompression::Heatshrink11 ? 11 : 12, 4);
      stored = packed_;
      break;
  }
  put_u16(block_, static_cast<std::uint16_t>(compression));
  put_u32(block_, static_cast<std::uint32_t>(data.size()));
  if (compression != BgcodeCompression::None)
    put_u32(block_, static_cast<std::uint32_t>(stored.size()));
  block_.append(params);
  block_.append(stored);
  const auto crc = static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(block_.data()), static_cast<uInt>(block_.size())));
  put_u32(block_, crc);
  put_(block_);
  bytes_ += block_.size();
}

// The metadata blocks' "INI encoding" (encoding 0): one key=value line each.
void BgcodeWriter::metadata(BgcodeBlock type, const BgcodeMetadata::Pairs& pairs,
                            BgcodeCompression compression) {
  std::string ini;
  for (const auto& [key, value] : pairs) {
    if (key.find_first_of("=\n") != std::string::npos || value.find('\n') != std::string::npos)
      throw std::logic_error("binary G-code metadata with '=' in a key or a line break: " + key);
    ini += key + "=" + value + "\n";
  }
  std::string params;
  put_u16(params, 0);
  block(type, compression, params, ini);
}

void BgcodeWriter::start(const BgcodeMetadata& m, const std::vector<GcodeThumbnail>& thumbnails) {
  std::string header(kBgcodeMagic, 4);
  put_u32(header, kBgcodeVersion);
  put_u16(header, kBgcodeCrc32);
  put_(header);
  bytes_ += header.size();
  metadata(BgcodeBlock::FileMetadata, m.file, BgcodeCompression::None);
  metadata(BgcodeBlock::PrinterMetadata, m.printer, BgcodeCompression::None);
  // "Thumbnail": parameters format (0 = PNG), width, height; the PNG bytes as they are.
  for (const auto& t : thumbnails) {
    std::string params;
    put_u16(params, 0);
    put_u16(params, static_cast<std::uint16_t>(t.width));
    put_u16(params, static_cast<std::uint16_t>(t.height));
    block(BgcodeBlock::Thumbnail, BgcodeCompression::None, params, t.png);
  }
  metadata(BgcodeBlock::PrintMetadata, m.print, BgcodeCompression::None);
  metadata(BgcodeBlock::SlicerMetadata, m.slicer, BgcodeCompression::Deflate);
  started_ = true;
}

// A G-code block of the first `upto` pending bytes ("GCode": parameter encoding 0 = text,
// 2 = MeatPack with comments).
void BgcodeWriter::flush_gcode(std::size_t upto) {
  std::string params;
  const std::string_view text = std::string_view(pending_).substr(0, upto);
  if (options_.meatpack) {
    put_u16(params, kBgcodeMeatPackComments);
    encoded_ = meatpack_encode(text, mid_line_);
    block(BgcodeBlock::Gcode, options_.gcode, params, encoded_);
  } else {
    put_u16(params, 0);
    block(BgcodeBlock::Gcode, options_.gcode, params, text);
  }
  mid_line_ = !text.empty() && text.back() != '\n';
  pending_.erase(0, upto);
}

void BgcodeWriter::gcode(std::string_view text) {
  if (!started_ || finished_)
    throw std::logic_error("BgcodeWriter: gcode() outside start()/finish()");
  const std::size_t limit = options_.block_size;
  while (!text.empty()) {
    const std::size_t take = std::min(text.size(), limit * 2 - std::min(pending_.size(), limit));
    pending_.append(text.substr(0, take));
    text.remove_prefix(take);
    // Full blocks out, each ending after its last whole line (a line longer than a block is cut).
    while (pending_.size() > limit) {
      const std::size_t nl = pending_.rfind('\n', limit - 1);
      flush_gcode(nl == std::string::npos ? limit : nl + 1);
    }
  }
}

void BgcodeWriter::finish() {
  if (!started_ || finished_)
    throw std::logic_error("BgcodeWriter: finish() twice or before start()");
  if (!pending_.empty()) flush_gcode(pending_.size());
  finished_ = true;
}

BgcodeOptions bgcode_options(const MachineProfile& profile) {
  BgcodeOptions o;
  o.meatpack = profile.binary_encoding == GcodeEncoding::MeatPack;
  return o;
}

bool binary_gcode_output(const std::string& path, const MachineProfile& p) {
  const bool named = lowercase_ext_is(path, ".bgcode");
  if (!named && !p.binary_gcode) return false;
  if (!named)
    throw SettingError("gcode.binary = true writes binary G-code, but the output '" + path +
                           "' is not named .bgcode (Prusa printers tell the formats apart by "
                           "the extension): name it .bgcode, or set gcode.binary = false",
                       {"", 0, "gcode.binary"});
  if (p.firmware != Firmware::Prusa)
    throw MachineError(
        "binary G-code (.bgcode) is read by Prusa's firmware only (MK4, MK3.9, XL, "
        "MINI, Core One); the machine '" +
            p.name + "' (machine.flavor = " + to_string(p.flavor) + ", machine.firmware = '" +
            to_string(p.firmware) +
            "') is not declared to run it: write text G-code (.gcode), or set "
            "machine.firmware = \"prusa\" in its profile if it does",
        {"", 0, "machine.firmware"});
  return true;
}

}  // namespace trellis
