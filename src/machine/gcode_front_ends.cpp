// What printer front ends read from our G-code besides the moves (gcode_writer.hpp): thumbnails
// in PrusaSlicer's block format (M73 progress: the Marlin family, MachineProfile::marlin_family).
#include "trellis/machine/gcode_writer.hpp"

namespace trellis {

std::string base64(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) |
                       (static_cast<unsigned char>(bytes[i + 1]) << 8) |
                       static_cast<unsigned char>(bytes[i + 2]);
    for (int k = 18; k >= 0; k -= 6) out += kAlphabet[(v >> k) & 63];
  }
  if (i < bytes.size()) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string thumbnail_block(const GcodeThumbnail& t) {
  // PrusaSlicer's layout: "; thumbnail begin WxH LEN" (LEN = base64 characters), rows of at most
  // 78 characters, "; thumbnail end", framed by bare ";" lines.
  const std::string b64 = base64(t.png);
  std::string out = ";\n; thumbnail begin " + std::to_string(t.width) + "x" +
                    std::to_string(t.height) + " " + std::to_string(b64.size()) + "\n";
  for (std::size_t a = 0; a < b64.size(); a += 78) out += "; " + b64.substr(a, 78) + "\n";
  out += "; thumbnail end\n;\n";
  return out;
}

}  // namespace trellis
