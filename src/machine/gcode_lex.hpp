// Lexical helpers shared by the G-code reader's files (private): locale-free ASCII classes and
// the fast decimal parser, parameter lookup.
#pragma once
#include <string.h>  // memrchr (GNU)

#include <charconv>
#include <cmath>
#include <cstdint>
#include <string_view>

namespace trellis::gcode_lex {

constexpr double kMaxValue = 1e6;

// Locale-free ASCII classification: the reader's hot path.
inline bool is_digit(char c) {
  return c >= '0' && c <= '9';
}
inline bool is_alpha(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}
inline char upper(char c) {
  return c >= 'a' && c <= 'z' ? static_cast<char>(c - 32) : c;
}

// G-code numbers are plain decimals ([-+]digits[.digits]). With at most 15 significant digits
// the mantissa and 10^k are exact doubles, so one division gives the correctly rounded value,
// about 3x faster than std::from_chars; anything else falls back to from_chars.
// Parses a plain decimal ([-+]digits[.digits], at most 15 digits) at b; returns the end of it, or
// nullptr if what is there is not such a number.
inline const char* scan_decimal(const char* b, const char* e, double& out) {
  static constexpr double kPow10[] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
  const char* p = b;
  const bool neg = p < e && *p == '-';
  if (p < e && (*p == '-' || *p == '+')) ++p;
  std::uint64_t m = 0;
  const char* start = p;
  while (p < e && is_digit(*p)) m = m * 10 + static_cast<unsigned>(*p++ - '0');
  const auto int_digits = p - start;
  std::ptrdiff_t frac = 0;
  if (p < e && *p == '.') {
    const char* f = ++p;
    while (p < e && is_digit(*p)) m = m * 10 + static_cast<unsigned>(*p++ - '0');
    frac = p - f;
  }
  if (int_digits + frac == 0 || int_digits + frac > 15) return nullptr;
  out = frac ? static_cast<double>(m) / kPow10[frac] : static_cast<double>(m);
  if (neg) out = -out;
  return p;
}

inline bool parse_number(const char* b, const char* e, double& out) {
  if (scan_decimal(b, e, out) == e) return true;
  if (b < e && *b == '+') ++b;
  const auto r = std::from_chars(b, e, out);
  return b < e && r.ec == std::errc() && r.ptr == e;
}

inline bool starts_with(std::string_view s, std::string_view p) {
  return s.substr(0, p.size()) == p;
}

// The value after `key` in a command's arguments, empty if absent. A one-letter key is a G-code
// word (letter and number, blanks optional: "S200 T1" or "S200T1": a letter after a digit starts
// the next word); a longer one (Klipper's
// "HEATER=") runs to the next blank.
inline std::string_view param(std::string_view args, std::string_view key) {
  const bool letter = key.size() == 1;
  for (std::size_t p = 0; p < args.size();) {
    while (p < args.size() && (args[p] == ' ' || args[p] == '\t')) ++p;
    if (p < args.size() && (args[p] == ';' || args[p] == '*')) break;
    std::size_t q = p + 1;
    while (q < args.size() && args[q] != ' ' && args[q] != '\t' && args[q] != '*' &&
           args[q] != ';' && !(letter && is_alpha(args[q]) && is_digit(args[q - 1])))
      ++q;
    const std::string_view word = args.substr(p, std::min(q, args.size()) - p);
    if (word.size() >= key.size()) {
      bool same = true;
      for (std::size_t i = 0; i < key.size() && same; ++i) same = upper(word[i]) == upper(key[i]);
      if (same) return word.substr(key.size());
    }
    p = q;
  }
  return {};
}

// The last newline in [b, e), or null if there is none: where lex_move may lex up to.
inline const char* last_newline(const char* b, const char* e) {
  return static_cast<const char*>(::memrchr(b, '\n', static_cast<std::size_t>(e - b)));
}

// The digits at p added to m (m * 10 + digit each); the first byte that is not a digit ends
// them (no bound checked: the caller knows one such byte is there, a newline).
[[gnu::always_inline]] inline const char* add_digits(const char* p, std::uint64_t& m) {
  for (unsigned d; (d = static_cast<unsigned>(static_cast<unsigned char>(*p)) - '0') < 10; ++p)
    m = m * 10 + d;
  return p;
}

// scan_decimal() for a number that a byte other than a digit, sign or '.' follows before the
// buffer ends (a line's newline: lex_move's lines): no bound checked. One pass of the digits into
// an integer mantissa and a count of decimals, the value m / 10^decimals as scan_decimal gives it
// (the same double: both exact, one correctly rounded division). Returns the end of the number,
// or null where scan_decimal gives null (no digit, more than 15).
[[gnu::always_inline]] inline const char* scan_decimal_nl(const char* p, double& out) {
  static constexpr double kPow10[] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
  const bool neg = *p == '-';
  p += neg || *p == '+';
  std::uint64_t m = 0;
  const char* const start = p;
  p = add_digits(p, m);
  std::ptrdiff_t digits = p - start, frac = 0;
  if (*p == '.') {
    const char* const f = ++p;
    p = add_digits(p, m);
    frac = p - f;
    digits += frac;
  }
  if (static_cast<std::size_t>(digits - 1) >= 15) return nullptr;
  const double v = static_cast<double>(m) / kPow10[frac];  // x / 1 is x: no branch on frac
  out = neg ? -v : v;
  return p;
}

// The common line "G0 "/"G1 " + plain words (upper case, each followed by a blank or the
// newline; no '\r', tab, comment or checksum) at `s`, whose newline comes before the buffer
// ends (the caller has found the buffer's last newline: nothing here checks a bound): its words
// in `w` (GcodeScanner::Words) and the position after its newline, or null if the line is not
// that simple. Lexing only: the scanner reads such a line from its words exactly as from its
// text (GcodeScanner::simple_move; a two-thread scan lexes on one thread).
template <class Words>
inline const char* lex_move(const char* s, Words& w) {
  if (s[0] != 'G' || (s[1] != '0' && s[1] != '1') || s[2] != ' ') return nullptr;
  std::uint32_t seen = 0;
  int n = 0;
  const char* p = s + 3;
  for (;;) {
    while (*p == ' ') ++p;
    const unsigned letter = static_cast<unsigned>(static_cast<unsigned char>(*p)) - 'A';
    if (letter >= 26) {
      if (*p != '\n') return nullptr;
      break;
    }
    double v;
    p = scan_decimal_nl(p + 1, v);
    if (p == nullptr || (*p != ' ' && *p != '\n') || !(std::abs(v) <= kMaxValue)) return nullptr;
    const std::uint32_t bit = 1u << letter;
    if ((seen & bit) || n == 16) return nullptr;
    seen |= bit;
    w.value[letter] = v;
    ++n;
  }
  w.seen = seen;
  return p + 1;
}

}  // namespace trellis::gcode_lex
