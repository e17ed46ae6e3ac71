// Number formatting for the G-code and CLI writers (private): straight into a caller's char
// buffer, locale-free, no iostreams or fmt per number. The bytes are exactly those the earlier
// formatting produced (tests/machine/test_fast_number.cpp compares them on a large corpus):
//  - fixed(): llround(v * 10^d), at most d decimals, trailing zeros (and a bare '.') removed;
//  - cli_um(): fmt::format("{}", round(mm * 1e5) / 100), the shortest round-trip form of a
//    coordinate in µm with two decimals (10 nm).
#pragma once
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#ifdef __linux__
#include <sys/mman.h>
#endif

#include <fmt/format.h>

namespace trellis::fastnum {

// Enough for any number fixed() or cli_um() writes (fallbacks included), with the 8 bytes past
// its end that the digit writers may scribble on.
constexpr int kMaxChars = 48;

// The formatting as it was before the fast path (v * 10^d rounded by std::llround, digits one
// by one): kept for the values the fast path does not take (|v * 10^d| >= 2^62, NaN, inf),
// so that even those print as they always did.
[[gnu::noinline]] inline char* fixed_legacy(char* p, double v, int decimals) {
  static constexpr long long kPow[] = {1, 10, 100, 1000, 10000, 100000, 1000000};
  const long long scale = kPow[decimals];
  const long long q = std::llround(v * static_cast<double>(scale));
  // The magnitude as unsigned: beyond long long (NaN, inf, |v * 10^d| >= 2^63) llround gives
  // LLONG_MIN, whose negation as a signed number is undefined (it printed bytes that are not
  // digits).
  std::uint64_t u = static_cast<std::uint64_t>(q);
  if (q < 0) {
    *p++ = '-';
    u = 0 - u;
  }
  std::uint64_t ip = u / static_cast<std::uint64_t>(scale),
                fp = u % static_cast<std::uint64_t>(scale);
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
// exact there, and so is the fraction x - trunc(x). Branch-free (coordinates round up or down at
// random, a branch would be mispredicted half the time). False outside that range (and for NaN).
[[gnu::always_inline]] inline bool round_half_away(double x, long long& q) {
  if (!(std::abs(x) < 4.0e18)) return false;
  const long long t = static_cast<long long>(x);
  const double f = x - static_cast<double>(t);
  q = t + static_cast<long long>(f >= 0.5) - static_cast<long long>(f <= -0.5);
  return true;
}

// std::llround(x), inlined where round_half_away takes x (the libm call only outside it).
[[gnu::always_inline]] inline long long llround(double x) {
  long long q;
  return round_half_away(x, q) ? q : std::llround(x);
}

inline constexpr char kTwoDigits[] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
    "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
    "8081828384858687888990919293949596979899";

// The decimal digits of u. Below 10^8 without branches on its length (it varies at random
// between neighbouring coordinates): eight digits written, the significant ones kept. May write
// up to 8 bytes past the returned end (the buffers here have room: kMaxChars).
[[gnu::always_inline]] inline char* put_uint(char* p, unsigned long long u) {
  if (u >= 100000000ULL) return std::to_chars(p, p + 24, u).ptr;
  const int n = 1 + (u >= 10) + (u >= 100) + (u >= 1000) + (u >= 10000) + (u >= 100000) +
                (u >= 1000000) + (u >= 10000000);
  // Built in a register (byte stores read back as one word would stall store forwarding).
  auto two = [](unsigned k) {
    std::uint16_t t;
    std::memcpy(&t, kTwoDigits + 2 * k, 2);
    return static_cast<std::uint64_t>(t);
  };
  const unsigned hi = static_cast<unsigned>(u / 10000), lo = static_cast<unsigned>(u % 10000);
  std::uint64_t w = two(hi / 100) | two(hi % 100) << 16 | two(lo / 100) << 32 | two(lo % 100) << 48;
  w >>= 8 * (8 - n);  // the n significant digits to the front
  std::memcpy(p, &w, 8);
  return p + n;
}

// Writes `frac` (0 < frac < 10^decimals, decimals <= 6) as '.' and `decimals` digits without
// trailing zeros; nothing if frac is 0. Branch-free but for frac == 0; may write up to 8 bytes
// past the returned end.
[[gnu::always_inline]] inline char* fraction(char* p, unsigned long long frac, int decimals) {
  if (!frac) return p;
  *p++ = '.';
  std::uint64_t w = 0x3030303030303030ULL;  // '0' x 8, the digits added in a register
  for (int i = decimals - 1; i >= 0; --i) {
    w += (frac % 10) << (8 * i);
    frac /= 10;
  }
  // Bit 7 of each byte that is a digit other than 0 (bytes past `decimals` are '0'): the last
  // of them ends the fraction; frac > 0, so there is one.
  const std::uint64_t nonzero =
      ((w ^ 0x3030303030303030ULL) + 0x7F7F7F7F7F7F7F7FULL) & 0x8080808080808080ULL;
  const int len = (63 - std::countl_zero(nonzero)) / 8 + 1;
  std::memcpy(p, &w, 8);
  return p + len;
}

// The eight decimal digits of q < 10^8 as bytes 0..9, the most significant in the lowest byte
// (SWAR, after Lemire and Khuong: both halves of q split by 100, then by 10, in one register).
[[gnu::always_inline]] inline std::uint64_t eight_digits(std::uint64_t q) {
  const std::uint64_t merged = (q / 10000) | ((q % 10000) << 32);
  const std::uint64_t top = ((merged * 10486ULL) >> 20) & ((0x7FULL << 32) | 0x7FULL);
  const std::uint64_t bot = merged - 100ULL * top;
  const std::uint64_t hundreds = (bot << 16) + top;
  std::uint64_t tens = (hundreds * 103ULL) >> 10;
  tens &= (0xFULL << 48) | (0xFULL << 32) | (0xFULL << 16) | 0xFULL;
  tens += (hundreds - 10ULL * tens) << 8;
  return tens;
}

// q / 10^decimals with at most `decimals` (1..6) decimals, trailing zeros removed, for
// q < 10^8: all digits made at once in a register, integer part and fraction cut from it
// with shifts (no branch on the number's length). May write up to 8 bytes past the end.
[[gnu::always_inline]] inline char* fixed_small(char* p, std::uint64_t q, int decimals) {
  const std::uint64_t raw = eight_digits(q);
  const std::uint64_t nonzero = (raw + 0x7F7F7F7F7F7F7F7FULL) & 0x8080808080808080ULL;
  const int first = nonzero ? std::countr_zero(nonzero) / 8 : 8;  // leading zero digits
  const int start = first < 7 - decimals ? first : 7 - decimals;  // keep one integer digit
  const std::uint64_t ascii = raw + 0x3030303030303030ULL;
  const std::uint64_t int_part = ascii >> (8 * start);
  std::memcpy(p, &int_part, 8);
  p += 8 - decimals - start;
  // The fraction: the last `decimals` digits, up to the last one that is not 0.
  const std::uint64_t frac_nonzero =
      (nonzero >> (8 * (8 - decimals)));  // bit 7 of each fraction digit other than 0
  if (!frac_nonzero) return p;
  *p++ = '.';
  const std::uint64_t frac = ascii >> (8 * (8 - decimals));
  std::memcpy(p, &frac, 8);
  return p + (63 - std::countl_zero(frac_nonzero)) / 8 + 1;
}

// Three decimal digits at a time from tables (4 + 8 kB, in the cache while a file is written):
// kInt3[n] is n (< 1000) without leading zeros in bytes 0..2 and its length in byte 3;
// kFrac3[n] is ".ddd" (n / 1000 as a fraction) without trailing zeros in bytes 0..3 and its
// length in byte 7, 0 for n = 0 (nothing written).
// dig3[n] is n's three digits with leading zeros ("007"); frac2[n] is ".dd" (n / 100) without
// trailing zeros in bytes 0..2 and its length in byte 3, 0 for n = 0.
struct Digits3 {
  std::uint32_t int3[1000];
  std::uint64_t frac3[1000];
  std::uint32_t dig3[1000];
  std::uint32_t frac2[100];
};
inline constexpr Digits3 kDigits3 = [] {
  Digits3 t{};
  for (unsigned n = 0; n < 1000; ++n) {
    const unsigned d[3] = {n / 100, n / 10 % 10, n % 10};
    const unsigned len = n >= 100 ? 3 : n >= 10 ? 2 : 1;
    std::uint32_t a = len << 24;
    for (unsigned k = 0; k < len; ++k) a |= (0x30u + d[3 - len + k]) << (8 * k);
    t.int3[n] = a;
    unsigned flen = 0;  // digits kept: up to the last one that is not 0
    for (unsigned k = 0; k < 3; ++k)
      if (d[k]) flen = k + 1;
    std::uint64_t b = 0;
    if (flen) {
      b = std::uint64_t{'.'} | std::uint64_t{flen + 1} << 56;
      for (unsigned k = 0; k < flen; ++k) b |= std::uint64_t{0x30u + d[k]} << (8 * (k + 1));
    }
    t.frac3[n] = b;
    t.dig3[n] = (0x30u + d[0]) | (0x30u + d[1]) << 8 | (0x30u + d[2]) << 16;
  }
  for (unsigned n = 1; n < 100; ++n) {
    const unsigned flen = n % 10 ? 2 : 1;
    std::uint32_t c = '.' | (flen + 1) << 24 | (0x30u + n / 10) << 8;
    if (flen == 2) c |= (0x30u + n % 10) << 16;
    t.frac2[n] = c;
  }
  return t;
}();

// A '-' for negative q (written anyway, kept only then) and |q|: the small writers' sign.
[[gnu::always_inline]] inline char* sign_abs(char* p, long long q, std::uint64_t& u) {
  u = static_cast<std::uint64_t>(q);
  *p = '-';
  if (q < 0) u = 0 - u;
  return p + (q < 0);
}

// n (< 1000) without leading zeros from one table entry; may write up to 3 bytes past the end.
[[gnu::always_inline]] inline char* int3(char* p, std::uint32_t n) {
  const std::uint32_t a = kDigits3.int3[n];
  std::memcpy(p, &a, 4);
  return p + (a >> 24);
}

// fixed_q(p, q, 3) for |q| < 10^6 (|v| < 1000 mm, every coordinate on a bed): the integer part
// and the fraction one table entry each, no branch but the sign's. May write up to 8 bytes past
// the returned end.
[[gnu::always_inline]] inline char* fixed3_small(char* p, long long q) {
  std::uint64_t u;
  p = sign_abs(p, q, u);
  p = int3(p, static_cast<std::uint32_t>(u / 1000));
  const auto fr = static_cast<std::uint32_t>(u % 1000);
  const std::uint64_t b = kDigits3.frac3[fr];
  std::memcpy(p, &b, 8);
  return p + (b >> 56);
}
inline constexpr long long kFixed3Small = 1000000;  // fixed3_small takes |q| below this

// fixed_q(p, q, 5) for |q| < 10^8 (|v| < 1000): the integer part one table entry, the five
// decimals two (three, then two, which end it unless they are 00). May write up to 8 bytes past
// the returned end.
[[gnu::always_inline]] inline char* fixed5_small(char* p, long long q) {
  std::uint64_t u;
  p = sign_abs(p, q, u);
  p = int3(p, static_cast<std::uint32_t>(u / 100000));
  const auto fr = static_cast<std::uint32_t>(u % 100000);
  const std::uint32_t hi = fr / 100, lo = fr % 100;
  if (lo) [[likely]] {
    *p = '.';
    std::memcpy(p + 1, &kDigits3.dig3[hi], 4);
    const std::uint32_t c = kDigits3.frac2[lo], digits = c >> 8;  // ".dd" less its '.'
    std::memcpy(p + 4, &digits, 4);
    return p + 3 + (c >> 24);
  }
  const std::uint64_t b = kDigits3.frac3[hi];
  std::memcpy(p, &b, 8);
  return p + (b >> 56);
}
inline constexpr long long kFixed5Small = 100000000;  // fixed5_small takes |q| below this

// u / 100 with at most two decimals (trailing zeros removed) for u < 10^8, as fixed_small(p, u,
// 2) writes it: the integer part (below 10^6) from one or two table entries, the fraction from
// one. May write up to 8 bytes past the returned end.
[[gnu::always_inline]] inline char* fixed2_small(char* p, std::uint64_t u) {
  const auto ip = static_cast<std::uint32_t>(u / 100), fr = static_cast<std::uint32_t>(u % 100);
  if (ip < 1000) {
    p = int3(p, ip);
  } else {
    p = int3(p, ip / 1000);
    std::memcpy(p, &kDigits3.dig3[ip % 1000], 4);
    p += 3;
  }
  const std::uint32_t c = kDigits3.frac2[fr];
  std::memcpy(p, &c, 4);
  return p + (c >> 24);
}

// q / 10^decimals (q already rounded: llround(v * 10^decimals)) with at most `decimals`
// (0..6) decimals, trailing zeros removed; what fixed() prints for that v. For a caller that
// also needs q itself (the G-code writer's move words, which read back as q / 10^decimals).
[[gnu::always_inline]] inline char* fixed_q(char* p, long long q, int decimals) {
  static constexpr unsigned long long kPow[] = {1, 10, 100, 1000, 10000, 100000, 1000000};
  const unsigned long long scale = kPow[decimals];
  unsigned long long u = static_cast<unsigned long long>(q);
  if (q < 0) {
    *p++ = '-';
    u = 0 - u;
  }
  if (decimals > 0 && u < 100000000ULL) [[likely]]
    return fixed_small(p, u, decimals);
  p = put_uint(p, u / scale);
  return fraction(p, u % scale, decimals);
}

// v with at most `decimals` (0..6) decimals, trailing zeros removed: "12.5", "-0.001", "3".
// Call with a constant `decimals` (it is inlined, the divisions become multiplications).
[[gnu::always_inline]] inline char* fixed(char* p, double v, int decimals) {
  static constexpr long long kPow[] = {1, 10, 100, 1000, 10000, 100000, 1000000};
  long long q;
  if (!round_half_away(v * static_cast<double>(kPow[decimals]), q))
    return fixed_legacy(p, v, decimals);
  return fixed_q(p, q, decimals);
}

// A CLI coordinate: `mm` in µm rounded to 10 nm, as fmt's shortest "{}" of
// round(mm * 1e5) / 100 prints it (-0 as 0). With |round(mm * 1e5)| < 10^15 the decimal
// q / 100 has at most 15 significant digits, so it is the shortest form that reads back as the
// same double, and fmt prints it in fixed notation: its digits are q's. Beyond that, fmt itself
// (cli_um_fmt). round(mm * 1e5) is round_half_away's q (llround's value) without the libm call.
[[gnu::noinline]] inline char* cli_um_fmt(char* p, double mm) {
  double v = std::round(mm * 1e5) / 100.0;
  if (v == 0) v = 0;
  return fmt::format_to(p, "{}", v);
}
[[gnu::always_inline]] inline char* cli_um(char* p, double mm) {
  long long q;
  if (!round_half_away(mm * 1e5, q) || !(q < 1000000000000000LL && q > -1000000000000000LL))
      [[unlikely]]
    return cli_um_fmt(p, mm);
  unsigned long long u = static_cast<unsigned long long>(q);
  if (q < 0) {
    *p++ = '-';
    u = 0 - u;
  }
  if (u < 100000000ULL) return fixed2_small(p, u);
  p = put_uint(p, u / 100);
  return fraction(p, u % 100, 2);
}

// Asks for transparent huge pages under a large output buffer (reserved, not yet written):
// 512x fewer page faults while the file is written. Advice only; nothing changes if refused.
inline void advise_huge_pages(std::string& buffer) {
#ifdef __linux__
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  if (buffer.capacity() < 4 * kHuge) return;
  std::uintptr_t a = reinterpret_cast<std::uintptr_t>(buffer.data());
  std::uintptr_t b = a + buffer.capacity();
  a = (a + kHuge - 1) & ~(kHuge - 1);
  b &= ~(kHuge - 1);
  if (b > a) madvise(reinterpret_cast<void*>(a), b - a, MADV_HUGEPAGE);
#else
  (void)buffer;
#endif
}

// Copies a string literal (without its terminating NUL).
template <std::size_t N>
inline char* lit(char* p, const char (&s)[N]) {
  std::memcpy(p, s, N - 1);
  return p + N - 1;
}

}  // namespace trellis::fastnum
