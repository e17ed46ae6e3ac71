// Number formatting for the G-code and CLI writers (private): straight into a caller's char
// buffer, locale-free, no iostreams or fmt per number. The bytes are exactly those the earlier
// formatting produced (tests/machine/test_fast_number.cpp compares them on a large corpus):
//  - fixed(): llround(v * 10^d), at most d decimals, trailing zeros (and a bare '.') removed;
//  - cli_um(): fmt::format("{}", round(mm * 1e5) / 100), the shortest round-trip form of a
//    coordinate in µm with two decimals (10 nm).
#pragma once
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <fmt/format.h>

namespace trellis::fastnum {

// Enough for any number fixed() or cli_um() writes (fallbacks included).
constexpr int kMaxChars = 48;

// The formatting as it was before the fast path (v * 10^d rounded by std::llround, digits one
// by one): kept for the values the fast path does not take (|v * 10^d| >= 2^62, NaN, inf),
// so that even those print as they always did.
[[gnu::noinline]] inline char* fixed_legacy(char* p, double v, int decimals) {
  static constexpr long long kPow[] = {1, 10, 100, 1000, 10000, 100000, 1000000};
  const long long scale = kPow[decimals];
  long long q = std::llround(v * static_cast<double>(scale));
  if (q < 0) {
    *p++ = '-';
    q = -q;
  }
  long long ip = q / scale, fp = q % scale;
  char buf[32];
  int n = 0;
  do {
    buf[n++] = static_cast<char>('0' + ip % 10);
    ip /= 10;
  } while (ip);
  while (n) *p++ = buf[--n];
  if (fp) {
    char frac[8];
    for (int i = decimals - 1; i >= 0; --i) {
      frac[i] = static_cast<char>('0' + fp % 10);
      fp /= 10;
    }
    int len = decimals;
    while (len > 0 && frac[len - 1] == '0') --len;
    *p++ = '.';
    std::memcpy(p, frac, static_cast<std::size_t>(len));
    p += len;
  }
  return p;
}

// std::llround(x) (half away from zero) for |x| < 2^62, without the libm call: truncation is
// exact there, and so is the fraction x - trunc(x). False outside that range (and for NaN).
[[gnu::always_inline]] inline bool round_half_away(double x, long long& q) {
  if (!(std::abs(x) < 4.0e18)) return false;
  long long t = static_cast<long long>(x);
  const double f = x - static_cast<double>(t);
  if (f >= 0.5)
    ++t;
  else if (f <= -0.5)
    --t;
  q = t;
  return true;
}

// The decimal digits of u.
[[gnu::always_inline]] inline char* put_uint(char* p, unsigned long long u) {
  static constexpr char kTwo[] =
      "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
      "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
      "8081828384858687888990919293949596979899";
  if (u < 10) {
    *p = static_cast<char>('0' + u);
    return p + 1;
  }
  if (u < 100) {
    std::memcpy(p, kTwo + 2 * u, 2);
    return p + 2;
  }
  if (u < 1000) {
    *p = static_cast<char>('0' + u / 100);
    std::memcpy(p + 1, kTwo + 2 * (u % 100), 2);
    return p + 3;
  }
  return std::to_chars(p, p + 24, u).ptr;
}

// Writes `frac` (< 10^decimals) as '.' and `decimals` digits without trailing zeros; nothing
// if it is 0.
[[gnu::always_inline]] inline char* fraction(char* p, unsigned long long frac, int decimals) {
  if (!frac) return p;
  *p++ = '.';
  for (int i = decimals - 1; i >= 0; --i) {
    p[i] = static_cast<char>('0' + frac % 10);
    frac /= 10;
  }
  char* e = p + decimals;
  while (e[-1] == '0') --e;  // frac > 0: a digit other than 0 stops it
  return e;
}

// v with at most `decimals` (0..6) decimals, trailing zeros removed: "12.5", "-0.001", "3".
// Call with a constant `decimals` (it is inlined, the divisions become multiplications).
[[gnu::always_inline]] inline char* fixed(char* p, double v, int decimals) {
  static constexpr long long kPow[] = {1, 10, 100, 1000, 10000, 100000, 1000000};
  const unsigned long long scale = static_cast<unsigned long long>(kPow[decimals]);
  long long q;
  if (!round_half_away(v * static_cast<double>(scale), q)) return fixed_legacy(p, v, decimals);
  unsigned long long u = static_cast<unsigned long long>(q);
  if (q < 0) {
    *p++ = '-';
    u = 0 - u;
  }
  p = put_uint(p, u / scale);
  return fraction(p, u % scale, decimals);
}

// A CLI coordinate: `mm` in µm rounded to 10 nm, as fmt's shortest "{}" of
// round(mm * 1e5) / 100 prints it (-0 as 0). With |round(mm * 1e5)| < 10^15 the decimal
// q / 100 has at most 15 significant digits, so it is the shortest form that reads back as the
// same double, and fmt prints it in fixed notation: its digits are q's. Beyond that, fmt itself.
[[gnu::always_inline]] inline char* cli_um(char* p, double mm) {
  const double r = std::round(mm * 1e5);
  if (!(std::abs(r) < 1e15)) {
    double v = r / 100.0;
    if (v == 0) v = 0;
    return fmt::format_to(p, "{}", v);
  }
  long long q = static_cast<long long>(r);
  unsigned long long u = static_cast<unsigned long long>(q);
  if (q < 0) {
    *p++ = '-';
    u = 0 - u;
  }
  p = put_uint(p, u / 100);
  return fraction(p, u % 100, 2);
}

// Copies a string literal (without its terminating NUL).
template <std::size_t N>
inline char* lit(char* p, const char (&s)[N]) {
  std::memcpy(p, s, N - 1);
  return p + N - 1;
}

}  // namespace trellis::fastnum
