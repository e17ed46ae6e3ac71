// The scanner's fast lexing of plain moves (src/machine/gcode_lex.hpp) reads what the earlier
// lexing read: the number parser without bounds (scan_decimal_nl) against the bounded one
// (scan_decimal) and against strtod on millions of generated words (signs, no leading digit,
// leading zeros, no digit at all, long mantissas, exponents and other bytes after the number);
// whole lines (lex_move) against the earlier line lexer, kept here verbatim as the oracle, on
// generated lines that fall just inside or outside what it takes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>

#include "../../src/machine/gcode_lex.hpp"
#include "trellis/machine/gcode_reader.hpp"

using namespace trellis;
using namespace trellis::gcode_lex;

namespace {

// The line lexer before the unbounded one (bounded by `end`), verbatim.
template <class Words>
const char* old_lex_move(const char* s, const char* end, Words& w) {
  if (end - s < 4 || s[0] != 'G' || (s[1] != '0' && s[1] != '1') || s[2] != ' ') return nullptr;
  w.seen = 0;
  int n = 0;
  const char* p = s + 2;
  for (;;) {
    while (p < end && *p == ' ') ++p;
    if (p == end) return nullptr;
    const char c = *p;
    if (c == '\n') break;
    if (c < 'A' || c > 'Z') return nullptr;
    double v = 0;
    const char* e = scan_decimal(p + 1, end, v);
    if (e == nullptr || e == end || (*e != ' ' && *e != '\n') || !(std::abs(v) <= kMaxValue))
      return nullptr;
    const std::uint32_t bit = 1u << (c - 'A');
    if ((w.seen & bit) || n == 16) return nullptr;
    w.seen |= bit;
    w.value[c - 'A'] = v;
    ++n;
    p = e;
  }
  return p + 1;
}

std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

// A word's number as slicers write it and as they do not: sign, digits before and after a
// point (none, a few, many; leading zeros), sometimes an exponent or another byte after it.
std::string number(std::mt19937_64& rng) {
  std::string s;
  const int sign = static_cast<int>(rng() % 6);
  if (sign == 0) s += '-';
  if (sign == 1) s += '+';
  if (sign == 2 && rng() % 8 == 0) s += "-+"[rng() % 2];  // a second sign
  auto digits = [&](int n) {
    for (int i = 0; i < n; ++i) {
      const bool zero = rng() % 5 == 0;
      s += static_cast<char>('0' + (zero ? 0 : rng() % 10));
    }
  };
  const int long_one = rng() % 10 == 0;
  digits(static_cast<int>(rng() % (long_one ? 20 : 5)));
  if (rng() % 4 != 0) {
    s += '.';
    digits(static_cast<int>(rng() % (long_one ? 20 : 7)));
  }
  if (rng() % 20 == 0) s += "e5";
  if (rng() % 40 == 0) s += "E-3";
  if (rng() % 40 == 0) s += '.';
  return s;
}

}  // namespace

TEST(GcodeLex, UnboundedNumbersReadAsTheBoundedParserAndStrtod) {
  std::mt19937_64 rng(40);
  const char ends[] = {'\n', ' ', 'X', '*', ';', '\r', '\t', '\0'};
  long accepted = 0, checked_strtod = 0;
  for (int i = 0; i < 3000000; ++i) {
    const std::string word = number(rng) + ends[rng() % sizeof ends] + "\n";
    const char* b = word.data();
    const char* e = b + word.size();
    double fast = 0, bounded = 0;
    const char* fe = scan_decimal_nl(b, fast);
    const char* be = scan_decimal(b, e, bounded);
    ASSERT_EQ(fe == nullptr, be == nullptr) << word;
    if (fe == nullptr) continue;
    ++accepted;
    ASSERT_EQ(fe - b, be - b) << word;
    ASSERT_EQ(bits(fast), bits(bounded)) << word;
    // strtod on the accepted text (it takes "+" and a leading "." as well): the same double.
    if (i % 2 == 0) {
      const std::string text(b, fe);
      char* se = nullptr;
      const double sv = std::strtod(text.c_str(), &se);
      ASSERT_EQ(se - text.c_str(), static_cast<long>(text.size())) << word;
      ASSERT_EQ(bits(fast), bits(sv)) << word;
      ++checked_strtod;
    }
  }
  // The generator reaches both sides: most words are read, many are not.
  EXPECT_GT(accepted, 1500000);
  EXPECT_LT(accepted, 2900000);
  EXPECT_GT(checked_strtod, 700000);
}

TEST(GcodeLex, UnboundedMoveLinesReadAsTheBoundedLexer) {
  std::mt19937_64 rng(41);
  const char* const heads[] = {"G1 ", "G0 ", "G1 ",  "G1 ", "G2 ",
                               "g1 ", "G1",  "G10 ", "M1 ", " G1 "};
  const std::string letters = "XYZEFXYZEXYEABIJS";
  long simple = 0;
  for (int i = 0; i < 1000000; ++i) {
    std::string line = heads[rng() % (sizeof heads / sizeof *heads)];
    const int words = static_cast<int>(rng() % (i % 50 == 0 ? 20 : 5));
    for (int k = 0; k < words; ++k) {
      const int pick = static_cast<int>(rng() % 40);
      if (pick == 0)
        line += 'x';
      else if (pick == 1)
        line += ';';
      else
        line += letters[rng() % letters.size()];
      line += number(rng);
      const int gap = static_cast<int>(rng() % 30);
      if (gap == 0)
        line += "  ";
      else if (gap == 1)
        line += '\t';
      else if (gap == 2)
        line += '\r';
      else if (k + 1 < words || gap < 20)
        line += ' ';
    }
    line += '\n';
    if (rng() % 3 == 0) line += "G1 X1\n";  // a line after it
    GcodeScanner::Words fast, old;
    const char* b = line.data();
    const char* fe = lex_move(b, fast);
    const char* oe = old_lex_move(b, b + line.size(), old);
    ASSERT_EQ(fe == nullptr, oe == nullptr) << line;
    if (fe == nullptr) continue;
    ++simple;
    ASSERT_EQ(fe - b, oe - b) << line;
    ASSERT_EQ(fast.seen, old.seen) << line;
    for (std::uint32_t s = fast.seen; s; s &= s - 1) {
      const int l = __builtin_ctz(s);
      ASSERT_EQ(bits(fast.value[l]), bits(old.value[l])) << line;
    }
  }
  EXPECT_GT(simple, 100000);
  EXPECT_LT(simple, 900000);
}

TEST(GcodeLex, LastNewline) {
  for (const std::string s : {"", "a", "\n", "ab\ncd", "ab\ncd\n", "\n\n", "abc"}) {
    const char* r = last_newline(s.data(), s.data() + s.size());
    const auto at = s.rfind('\n');
    EXPECT_EQ(r == nullptr, at == std::string::npos) << s;
    if (r) EXPECT_EQ(static_cast<std::size_t>(r - s.data()), at) << s;
  }
}
