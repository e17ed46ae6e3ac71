// MeatPack encoder for binary G-code blocks (bgcode.hpp). Hand-written: Debian packages no
// MeatPack library (libbgcode, which holds PrusaSlicer's, is not packaged, and its encoder drops
// comments and spaces, which would break the exact read-back we promise). The format is
// Marlin's: feature/meatpack.h and libbgcode doc/specifications.md "GCode" (encoding 2 =
// MeatPack with comments kept).
//
// Lossless by construction, for our reader and for PrusaSlicer's and the firmware's rule (a
// space put back before a G-line's parameter letter): lines with a comment go raw with packing
// off; a G line whose words are single-spaced letter+number words ("G1 X1.5 Y2 E.03") is packed in
// no-spaces mode with its spaces dropped; every other line is packed with its spaces. Each block
// sets the modes it needs before its first line, so a block decodes on its own.
#include <cctype>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "trellis/machine/bgcode.hpp"

namespace trellis {

namespace {

// Marlin's MeatPack commands: two 0xFF signal bytes, then the command.
constexpr std::uint8_t kEnablePacking = 0xFB, kDisablePacking = 0xFA;
constexpr std::uint8_t kNoSpacesOn = 0xF7, kNoSpacesOff = 0xF6;

// The 4-bit code of a character, or 0xF when it goes as a full byte. In no-spaces mode code 11
// is 'E' instead of ' '.
std::uint8_t code_of(char c, bool no_spaces) {
  if (c >= '0' && c <= '9') return static_cast<std::uint8_t>(c - '0');
  switch (c) {
    case '.':
      return 10;
    case ' ':
      return no_spaces ? 0xF : 11;
    case 'E':
      return no_spaces ? 11 : 0xF;
    case '\n':
      return 12;
    case 'G':
      return 13;
    case 'X':
      return 14;
    default:
      return 0xF;
  }
}

// A letter the firmware's and PrusaSlicer's decoders put a space back before on a G line.
bool parameter_letter(char c) {
  return std::string_view("XYZEFIJRGPWHCA").find(c) != std::string_view::npos;
}

bool number_char(char c) {
  return std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+';
}

// A G line (without its newline) whose spaces every decoder puts back exactly: words of one
// letter and a number ending in a digit or '.', one space apart, later words starting with a
// parameter letter, no comment.
bool spaces_restorable(std::string_view line) {
  if (line.size() < 2 || line[0] != 'G') return false;
  std::size_t i = 0;
  while (i < line.size()) {
    const std::size_t end = std::min(line.find(' ', i), line.size());
    const std::string_view word = line.substr(i, end - i);
    if (word.size() < 2 || (i > 0 && !parameter_letter(word[0]))) return false;
    if (!std::isupper(static_cast<unsigned char>(word[0]))) return false;
    for (std::size_t k = 1; k < word.size(); ++k)
      if (!number_char(word[k])) return false;
    if (!std::isdigit(static_cast<unsigned char>(word.back())) && word.back() != '.') return false;
    i = end + 1;
    if (end + 1 == line.size()) return false;  // a trailing space
  }
  return true;
}

class Packer {
 public:
  Packer(std::string& out, bool no_spaces_allowed) : out_(out), allowed_(no_spaces_allowed) {}

  void line(std::string_view text, bool ends) {
    if (!ends || text.find(';') != std::string_view::npos) return raw(text, ends);
    // No-spaces mode while the block stays packed to more than half its text (see
    // meatpack_encode), with room for this line's dropped spaces.
    const bool no_spaces = allowed_ && 2 * out_.size() >= consumed_ + 16 && spaces_restorable(text);
    consumed_ += text.size() + 1;
    packing(true);
    spaces(no_spaces);
    pending_ = -1;
    for (const char c : text)
      if (!(no_spaces && c == ' ')) put(c, no_spaces);
    put('\n', no_spaces);
    if (pending_ >= 0) pair(static_cast<std::uint8_t>(pending_), code_of('\n', no_spaces), 0, 0);
  }
  void rest(std::string_view text, bool ends) { raw(text, ends); }

 private:
  void command(std::uint8_t c) {
    out_ += '\xFF';
    out_ += '\xFF';
    out_ += static_cast<char>(c);
  }
  void packing(bool on) {
    if (packing_ != (on ? 1 : 0)) command(on ? kEnablePacking : kDisablePacking);
    packing_ = on ? 1 : 0;
  }
  void spaces(bool no_spaces) {
    if (no_spaces_ != (no_spaces ? 1 : 0)) command(no_spaces ? kNoSpacesOn : kNoSpacesOff);
    no_spaces_ = no_spaces ? 1 : 0;
  }
  // Text as it is (a line with a comment, or a line a block ends or starts inside): packing off;
  // the no-spaces mode off too unless it is a comment line (our reader would put spaces back).
  void raw(std::string_view text, bool ends) {
    consumed_ += text.size() + (ends ? 1 : 0);
    if (!text.starts_with(';')) spaces(false);
    packing(false);
    for (const char c : text)
      if (static_cast<unsigned char>(c) == 0xFF)
        throw std::invalid_argument("G-code with a 0xFF byte cannot be MeatPack-encoded");
    out_.append(text);
    if (ends) out_ += '\n';
  }
  // Characters two by two: the first in the low nibble; 0xF = it follows as a full byte (the low
  // one's first). A line's last odd character pairs with its newline.
  void put(char c, bool no_spaces) {
    if (static_cast<unsigned char>(c) == 0xFF)
      throw std::invalid_argument("G-code with a 0xFF byte cannot be MeatPack-encoded");
    const int code = code_of(c, no_spaces);
    if (pending_ < 0) {
      pending_ = code, first_ = c;
      return;
    }
    pair(static_cast<std::uint8_t>(pending_), static_cast<std::uint8_t>(code), first_, c);
    pending_ = -1;
  }
  void pair(std::uint8_t lo, std::uint8_t hi, char a, char b) {
    out_ += static_cast<char>(lo | (hi << 4));
    if (lo == 0xF) out_ += a;
    if (hi == 0xF) out_ += b;
  }

  std::string& out_;
  bool allowed_;
  std::size_t consumed_ = 0;           // text bytes packed so far
  int packing_ = -1, no_spaces_ = -1;  // -1: not set in this block yet
  int pending_ = -1;                   // the code waiting for its pair's second character
  char first_ = 0;
};

}  // namespace

namespace {

std::string pack(std::string_view text, bool continues_line, bool no_spaces_allowed) {
  std::string out;
  out.reserve(text.size() * 3 / 4 + 16);
  Packer packer(out, no_spaces_allowed);
  while (!text.empty()) {
    const std::size_t nl = text.find('\n');
    const bool ends = nl != std::string_view::npos;
    const std::string_view line = text.substr(0, ends ? nl : text.size());
    // The rest of a line the previous block ended inside: as it is, like its start.
    if (continues_line)
      packer.rest(line, ends);
    else
      packer.line(line, ends);
    continues_line = false;
    text.remove_prefix(ends ? nl + 1 : text.size());
  }
  return out;
}

}  // namespace

std::string meatpack_encode(std::string_view text, bool continues_line) {
  std::string out = pack(text, continues_line, true);
  // PrusaSlicer's decoder (libbgcode MeatPack::unbinarize, which its G-code viewer runs) decodes
  // into a buffer of twice the packed size and loses a character when it must grow it right
  // after putting back a space. So lines drop their spaces only while the block stays packed to
  // more than half its text (Packer::line), and a block that still is not is packed again with
  // every space kept: that decoder then reads it in one buffer.
  if (out.size() * 2 <= text.size()) out = pack(text, continues_line, false);
  return out;
}

}  // namespace trellis
