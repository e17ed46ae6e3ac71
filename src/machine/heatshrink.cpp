// Heatshrink (LZSS) for binary G-code blocks, written here from the format as the heatshrink
// library defines it (atomicobject/heatshrink: heatshrink_decoder.c/heatshrink_encoder.c; the
// bgcode specification, libbgcode doc/specifications.md "Compression", names the two parameter
// pairs 11/4 and 12/4). Debian 12 packages no heatshrink library (`apt-cache search heatshrink`
// finds nothing) and the format is small: a bit stream read MSB first, tag 1 + 8 bits = a literal,
// tag 0 + window_bits (distance - 1) + lookahead_bits (count - 1) = a back-reference that may
// overlap what it produces. The decoder's window starts zero-filled (heatshrink_decoder_reset),
// so a reference reaching before the first byte reads zeros, as the library's decoder does.
#include <algorithm>
#include <vector>

#include "trellis/core/error.hpp"
#include "trellis/machine/bgcode.hpp"

namespace trellis {

namespace {

// Reads bits MSB first.
class BitReader {
 public:
  explicit BitReader(std::string_view d) : d_(d) {}
  // Returns false when fewer than n bits are left.
  bool get(int n, unsigned& v) {
    if (pos_ + static_cast<std::size_t>(n) > d_.size() * 8) return false;
    v = 0;
    for (int i = 0; i < n; ++i, ++pos_) {
      const auto byte = static_cast<unsigned char>(d_[pos_ / 8]);
      v = (v << 1) | ((byte >> (7 - pos_ % 8)) & 1u);
    }
    return true;
  }

 private:
  std::string_view d_;
  std::size_t pos_ = 0;
};

// Writes bits MSB first; the last byte is padded with zero bits (which the decoder, out of
// input, takes for an unfinished back-reference and ignores).
class BitWriter {
 public:
  void put(unsigned v, int n) {
    for (int i = n - 1; i >= 0; --i) {
      acc_ = static_cast<unsigned char>((acc_ << 1) | ((v >> i) & 1u));
      if (++bits_ == 8) {
        out_ += static_cast<char>(acc_);
        acc_ = 0;
        bits_ = 0;
      }
    }
  }
  std::string finish() {
    if (bits_) out_ += static_cast<char>(acc_ << (8 - bits_));
    bits_ = 0;
    acc_ = 0;
    return std::move(out_);
  }

 private:
  std::string out_;
  unsigned char acc_ = 0;
  int bits_ = 0;
};

void check_parameters(int window_bits, int lookahead_bits) {
  // heatshrink's own limits (HEATSHRINK_MIN/MAX_WINDOW_BITS, MIN_LOOKAHEAD_BITS).
  if (window_bits < 4 || window_bits > 15 || lookahead_bits < 3 || lookahead_bits > window_bits)
    throw std::logic_error("heatshrink: window/lookahead bits out of range");
}

}  // namespace

std::string heatshrink_decode(std::string_view data, int window_bits, int lookahead_bits,
                              std::size_t size) {
  check_parameters(window_bits, lookahead_bits);
  std::string out;
  out.reserve(size);
  BitReader bits(data);
  while (out.size() < size) {
    unsigned tag = 0, v = 0, count = 0;
    if (!bits.get(1, tag)) break;
    if (tag) {
      if (!bits.get(8, v)) break;
      out += static_cast<char>(v);
      continue;
    }
    if (!bits.get(window_bits, v) || !bits.get(lookahead_bits, count)) break;
    const std::size_t offset = std::size_t{v} + 1;
    for (unsigned k = 0; k <= count && out.size() < size; ++k)
      out += offset > out.size() ? '\0' : out[out.size() - offset];
  }
  if (out.size() != size)
    throw ParseError("Heatshrink data ends after " + std::to_string(out.size()) + " of " +
                     std::to_string(size) + " bytes");
  return out;
}

// Greedy longest match over the last 2^window_bits bytes, found through chains of earlier
// positions with the same two-byte prefix (at most kChain tried per position: G-code repeats
// itself close by). A match of two bytes or more is taken (1 + window + lookahead bits, 17 for
// 12/4, against 9 bits per literal), as heatshrink's own encoder does.
std::string heatshrink_encode(std::string_view data, int window_bits, int lookahead_bits) {
  check_parameters(window_bits, lookahead_bits);
  constexpr int kChain = 48;
  const std::size_t window = std::size_t{1} << window_bits;
  const std::size_t longest = std::size_t{1} << lookahead_bits;
  const std::size_t n = data.size();
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::vector<std::size_t> head(1 << 16, kNone), prev(n, kNone);
  const auto key = [&](std::size_t i) {
    return (static_cast<unsigned char>(data[i]) << 8) | static_cast<unsigned char>(data[i + 1]);
  };
  const auto remember = [&](std::size_t i) {
    if (i + 1 >= n) return;
    prev[i] = head[key(i)];
    head[key(i)] = i;
  };
  BitWriter bits;
  std::size_t i = 0;
  while (i < n) {
    std::size_t best = 0, best_distance = 0;
    if (i + 1 < n) {
      int tries = 0;
      for (std::size_t j = head[key(i)]; j != kNone && i - j <= window && tries < kChain;
           j = prev[j], ++tries) {
        std::size_t len = 0;
        const std::size_t cap = std::min(longest, n - i);
        while (len < cap && data[j + len] == data[i + len]) ++len;
        if (len > best) {
          best = len;
          best_distance = i - j;
          if (len == cap) break;
        }
      }
    }
    if (best >= 2) {
      bits.put(0, 1);
      bits.put(static_cast<unsigned>(best_distance - 1), window_bits);
      bits.put(static_cast<unsigned>(best - 1), lookahead_bits);
      for (std::size_t k = 0; k < best; ++k) remember(i + k);
      i += best;
    } else {
      bits.put(1, 1);
      bits.put(static_cast<unsigned char>(data[i]), 8);
      remember(i);
      ++i;
    }
  }
  return bits.finish();
}

}  // namespace trellis
