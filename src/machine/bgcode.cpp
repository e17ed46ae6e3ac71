#include "trellis/machine/bgcode.hpp"

#include <zlib.h>

#include <cctype>
#include <cstring>
#include <vector>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

constexpr std::size_t kMaxBlock = std::size_t{1} << 28;  // 256 MiB: PrusaSlicer writes 64 KiB

std::uint16_t u16(const unsigned char* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t u32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

std::string inflate_zlib(std::string_view data, std::size_t size, const std::string& where) {
  std::string out(size, '\0');
  uLongf got = static_cast<uLongf>(size);
  const int rc =
      uncompress(reinterpret_cast<Bytef*>(out.data()), &got,
                 reinterpret_cast<const Bytef*>(data.data()), static_cast<uLong>(data.size()));
  if (rc != Z_OK || got != size)
    throw ParseError("Deflate data does not decompress to the " + std::to_string(size) +
                         " bytes its block header states (zlib: " + std::to_string(rc) + ")",
                     {where});
  return out;
}

// "key=value" lines as "; key = value" comments.
std::string metadata_comments(std::string_view ini) {
  std::string out;
  std::size_t a = 0;
  while (a < ini.size()) {
    std::size_t b = ini.find('\n', a);
    if (b == std::string_view::npos) b = ini.size();
    const std::string_view l = ini.substr(a, b - a);
    const auto eq = l.find('=');
    if (eq != std::string_view::npos) {
      out += "; ";
      out += l.substr(0, eq);
      out += " = ";
      out += l.substr(eq + 1);
      out += '\n';
    }
    a = b + 1;
  }
  return out;
}

}  // namespace

bool is_bgcode(std::string_view head) {
  return head.size() >= 4 && head.substr(0, 4) == "GCDE";
}

void MeatPackDecoder::put(char c, std::string& out) {
  // No-spaces mode drops the spaces between words ("G1X10Y2E.4"); put one back before each
  // word letter that follows a value (outside comments), so the text is ordinary G-code and a
  // number glued to a letter can still be told from a malformed one by the text reader.
  if (c == '\n') {
    comment_ = false;
  } else if (c == ';') {
    comment_ = true;
  } else if (no_spaces_ && !comment_ && std::isalpha(static_cast<unsigned char>(c)) &&
             (std::isdigit(static_cast<unsigned char>(prev_)) || prev_ == '.')) {
    out += ' ';
  }
  out += c;
  prev_ = c;
}

void MeatPackDecoder::command(std::uint8_t c) {
  switch (c) {
    case 0xFB:  // enable packing
      active_ = true;
      break;
    case 0xFA:  // disable packing
      active_ = false;
      break;
    case 0xF9:  // reset all
      active_ = no_spaces_ = false;
      break;
    case 0xF7:  // no spaces on
      no_spaces_ = true;
      break;
    case 0xF6:  // no spaces off
      no_spaces_ = false;
      break;
    default:  // 0xF8 query config, or unknown: nothing to decode
      break;
  }
}

void MeatPackDecoder::inner(std::uint8_t c, std::string& out) {
  if (!active_) return put(static_cast<char>(c), out);
  if (full_chars_ > 0) {  // a byte that could not be packed
    put(static_cast<char>(c), out);
    if (second_) {
      put(second_, out);
      second_ = 0;
    }
    --full_chars_;
    return;
  }
  static constexpr char kCodes[] = "0123456789. \nGX";
  auto code = [&](unsigned n) { return n == 11 && no_spaces_ ? 'E' : kCodes[n]; };
  const unsigned lo = c & 0xF, hi = c >> 4;
  if (lo == 0xF) {
    ++full_chars_;
    if (hi == 0xF)
      ++full_chars_;
    else
      second_ = code(hi);
    return;
  }
  const char first = code(lo);
  put(first, out);
  if (first == '\n') return;  // the other half of a line's last byte is padding
  if (hi == 0xF)
    ++full_chars_;
  else
    put(code(hi), out);
}

void MeatPackDecoder::feed(std::string_view data, std::string& out) {
  for (const char ch : data) {
    const auto c = static_cast<std::uint8_t>(ch);
    if (c == 0xFF && !cmd_next_) {
      if (ff_count_) {
        cmd_next_ = true;
        ff_count_ = 0;
      } else {
        ff_count_ = 1;
      }
    } else if (cmd_next_) {
      command(c);
      cmd_next_ = false;
    } else {
      if (ff_count_) {  // a single 0xFF: two full bytes follow
        inner(0xFF, out);
        ff_count_ = 0;
      }
      inner(c, out);
    }
  }
}

namespace {

// The blocks of a file in order: `block` gets each one with its data decompressed and, for
// G-code, decoded (constant memory: one block at a time).
void for_each_block(const std::function<std::size_t(char*, std::size_t)>& read,
                    const std::function<void(const BgcodeBlockRead&)>& on_block,
                    const std::string& origin) {
  std::size_t offset = 0;
  std::vector<char> buf;
  auto need = [&](std::size_t n, const char* what) {
    buf.resize(n);
    std::size_t got = 0;
    while (got < n) {
      const std::size_t k = read(buf.data() + got, n - got);
      if (k == 0) break;
      got += k;
    }
    if (got != n)
      throw ParseError(std::string("binary G-code ends inside ") + what + " at byte " +
                           std::to_string(offset + got),
                       {origin});
    offset += n;
    return reinterpret_cast<const unsigned char*>(buf.data());
  };
  const unsigned char* h = need(10, "the file header");
  if (std::memcmp(h, kBgcodeMagic, 4) != 0)
    throw ParseError("not a binary G-code file (no GCDE magic)", {origin});
  if (u32(h + 4) != kBgcodeVersion)
    throw ParseError(
        "binary G-code version " + std::to_string(u32(h + 4)) + " (this reader knows version 1)",
        {origin});
  const std::uint16_t checksum = u16(h + 8);
  if (checksum > kBgcodeCrc32)
    throw ParseError("unknown checksum type " + std::to_string(checksum), {origin});
  MeatPackDecoder meatpack;
  std::string block;
  BgcodeBlockRead r;
  std::size_t gcode_blocks = 0;
  for (;;) {
    // End of file: a clean end only between blocks.
    char first = 0;
    if (read(&first, 1) == 0) break;
    const std::size_t start = offset;
    const std::string at = "block at byte " + std::to_string(start);
    block.assign(1, first);
    offset += 1;
    need(7, "a block header");
    block.append(buf.data(), 7);
    const auto* b = reinterpret_cast<const unsigned char*>(block.data());
    const auto type = u16(b);
    const auto compression = u16(b + 2);
    const std::size_t size = u32(b + 4);
    if (type > 5) throw ParseError("unknown block type " + std::to_string(type), {origin, 0, at});
    if (compression > 3)
      throw ParseError("unknown compression " + std::to_string(compression), {origin, 0, at});
    std::size_t stored = size;
    if (compression != 0) {
      need(4, "a block header");
      block.append(buf.data(), 4);
      stored = u32(reinterpret_cast<const unsigned char*>(block.data()) + 8);
    }
    if (size > kMaxBlock || stored > kMaxBlock)
      throw ParseError("block of " + std::to_string(std::max(size, stored)) +
                           " bytes (more than 256 MiB: a damaged header?)",
                       {origin, 0, at});
    const std::size_t header = block.size();
    const bool thumbnail = type == static_cast<std::uint16_t>(BgcodeBlock::Thumbnail);
    const std::size_t params = thumbnail ? 6 : 2;
    need(params + stored, "a block");
    block.append(buf.data(), params + stored);
    r.checked = false;
    if (checksum == kBgcodeCrc32) {
      const unsigned char* c = need(4, "a block checksum");
      const std::uint32_t want = u32(c);
      const auto got = static_cast<std::uint32_t>(
          crc32(0L, reinterpret_cast<const Bytef*>(block.data()), static_cast<uInt>(block.size())));
      if (want != got) throw ParseError("CRC32 mismatch (damaged file)", {origin, 0, at});
      r.checked = true;
    }
    const auto* bp = reinterpret_cast<const unsigned char*>(block.data());
    r.type = static_cast<BgcodeBlock>(type);
    r.compression = static_cast<BgcodeCompression>(compression);
    r.encoding = u16(bp + header);
    r.width = thumbnail ? u16(bp + header + 2) : 0;
    r.height = thumbnail ? u16(bp + header + 4) : 0;
    const std::string_view data(block.data() + header + params, stored);
    switch (compression) {
      case 0:
        r.data.assign(data);
        break;
      case 1:
        r.data = inflate_zlib(data, size, origin + " " + at);
        break;
      default:
        try {
          r.data = heatshrink_decode(data, compression == 2 ? 11 : 12, 4, size);
        } catch (const ParseError& e) {
          throw ParseError(e.message(), {origin, 0, at});
        }
    }
    if (r.type == BgcodeBlock::Gcode) {
      ++gcode_blocks;
      if (r.encoding == 1 || r.encoding == 2) {
        std::string decoded;
        meatpack.feed(r.data, decoded);
        r.data = std::move(decoded);
      } else if (r.encoding != 0) {
        throw ParseError("unknown G-code encoding " + std::to_string(r.encoding), {origin, 0, at});
      }
    } else if (!thumbnail && r.encoding != 0) {
      throw ParseError("unknown metadata encoding " + std::to_string(r.encoding), {origin, 0, at});
    }
    on_block(r);
  }
  if (gcode_blocks == 0) throw ParseError("binary G-code file without G-code blocks", {origin});
}

std::function<std::size_t(char*, std::size_t)> read_from(std::string_view bytes) {
  return [bytes, pos = std::size_t{0}](char* dst, std::size_t n) mutable {
    const std::size_t k = std::min(n, bytes.size() - pos);
    std::memcpy(dst, bytes.data() + pos, k);
    pos += k;
    return k;
  };
}

}  // namespace

void read_bgcode(const std::function<std::size_t(char*, std::size_t)>& read,
                 const std::function<void(std::string_view)>& text, const std::string& origin) {
  for_each_block(
      read,
      [&](const BgcodeBlockRead& b) {
        if (b.type == BgcodeBlock::Gcode)
          text(b.data);
        else if (b.type != BgcodeBlock::Thumbnail)
          text(metadata_comments(b.data));
      },
      origin);
}

std::string bgcode_to_text(std::string_view bytes, const std::string& origin) {
  std::string out;
  read_bgcode(
      read_from(bytes), [&](std::string_view t) { out.append(t); }, origin);
  return out;
}

std::vector<BgcodeBlockRead> bgcode_blocks(std::string_view bytes, const std::string& origin) {
  std::vector<BgcodeBlockRead> out;
  for_each_block(
      read_from(bytes), [&](const BgcodeBlockRead& b) { out.push_back(b); }, origin);
  return out;
}

}  // namespace trellis
