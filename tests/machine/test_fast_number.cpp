// The writers' fast number formatting (src/machine/fast_number.hpp) prints exactly the bytes the
// earlier formatting printed: the previous G-code formatter (llround, digit by digit) and the
// previous CLI formatter (fmt's shortest "{}") are kept here verbatim as oracles and compared on
// millions of values: random magnitudes from 1e-9 to 1e13, both signs, negative zero, exact
// halfway cases and their neighbours one ulp either side, integers, and values past the fast
// path's range (the fallback). Whole files as well: G-code and CLI written now match digests of
// what the writers wrote before (recorded with the previous library).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "../../src/machine/fast_number.hpp"
#include "../../src/machine/gcode_lex.hpp"
#include "support/machines.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;

namespace {

// The G-code writer's append_fixed before the fast path, verbatim.
void old_append_fixed(std::string& out, double v, int decimals) {
  static constexpr long long kPow[] = {1, 10, 100, 1000, 10000, 100000, 1000000};
  const long long scale = kPow[decimals];
  const long long q = std::llround(v * static_cast<double>(scale));
  // The magnitude as unsigned: beyond long long (NaN, inf, |v * 10^d| >= 2^63) llround gives
  // LLONG_MIN, whose negation as a signed number is undefined (it printed bytes that are not
  // digits).
  std::uint64_t u = static_cast<std::uint64_t>(q);
  if (q < 0) {
    out += '-';
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
  while (n) out += buf[--n];
  if (fp) {
    char frac[8];
    for (int i = decimals - 1; i >= 0; --i) {
      frac[i] = static_cast<char>('0' + fp % 10);
      fp /= 10;
    }
    int len = decimals;
    while (len > 0 && frac[len - 1] == '0') --len;
    out += '.';
    out.append(frac, len);
  }
}

// The CLI writer's put() before the fast path, verbatim.
void old_cli_put(std::string& out, double mm) {
  double v = std::round(mm * 1e5) / 100.0;
  if (v == 0) v = 0;
  out += fmt::format("{}", v);
}

std::string new_fixed(double v, int d) {
  char buf[fastnum::kMaxChars];
  return std::string(buf, fastnum::fixed(buf, v, d));
}
std::string new_cli(double mm) {
  char buf[fastnum::kMaxChars];
  return std::string(buf, fastnum::cli_um(buf, mm));
}
std::string old_fixed(double v, int d) {
  std::string s;
  old_append_fixed(s, v, d);
  return s;
}
std::string old_cli(double mm) {
  std::string s;
  old_cli_put(s, mm);
  return s;
}

// The corpus: each value with its neighbours one ulp either side.
std::vector<double> corpus(unsigned seed) {
  std::vector<double> v = {0.0, -0.0, 0.5, -0.5, 1.5, 2.5, 0.0005, -0.0005, 0.00005, 2.675, 1.005,
                           1.0005, -2.5, 1e-300, -1e-300, std::numeric_limits<double>::denorm_min(),
                           4503599627370495.5, 4503599627370496.0, 9007199254740993.0, 1e12, -1e12,
                           123456.789, 0.1, 0.2, 0.3, 0.7, 199.9995, 200.0005, -199.9995,
                           // past the fast path: the fallback prints what the old code printed
                           1e15, -1e15, 4.7e18, 1e19, -1e19, 1e300, -1e300, INFINITY, -INFINITY,
                           NAN};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> mant(1.0, 10.0), unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exp10(-9, 13), coin(0, 1);
  std::uniform_int_distribution<long long> big(-2000000000000LL, 2000000000000LL);
  for (int i = 0; i < 200000; ++i) {
    // Log-uniform magnitudes, both signs.
    v.push_back((coin(rng) ? -1 : 1) * mant(rng) * std::pow(10.0, exp10(rng)));
    // Toolpath-like coordinates.
    v.push_back(unit(rng) * 300);
    // Exact halfway cases at every precision the writers use: (n + 1/2) / 10^d.
    const int d = 1 + i % 6;
    v.push_back((static_cast<double>(big(rng) % 100000000) + 0.5) / std::pow(10.0, d));
    // Integers, and quarters (exact in binary).
    v.push_back(static_cast<double>(big(rng)));
    v.push_back(static_cast<double>(big(rng) % 1000000) / 4);
  }
  const std::size_t n = v.size();
  for (std::size_t i = 0; i < n; ++i) {
    v.push_back(std::nextafter(v[i], INFINITY));
    v.push_back(std::nextafter(v[i], -INFINITY));
  }
  return v;
}

TEST(FastNumber, FixedPrintsTheBytesOfThePreviousFormatter) {
  const auto values = corpus(1);
  long compared = 0;
  for (const double x : values)
    for (int d = 0; d <= 6; ++d) {
      ASSERT_EQ(new_fixed(x, d), old_fixed(x, d))
          << "value " << fmt::format("{:.17g}", x) << " decimals " << d;
      ++compared;
    }
  EXPECT_GT(compared, 7000000);
  // Beyond the integers (NaN, inf, 1e300) still a sign and digits, nothing else.
  for (const double x :
       std::initializer_list<double>{NAN, INFINITY, -INFINITY, 1e300, -1e300, 1e19})
    for (int d = 0; d <= 6; ++d) {
      const std::string s = new_fixed(x, d);
      EXPECT_TRUE(!s.empty() && s.find_first_not_of("-0123456789.") == std::string::npos &&
                  s.find('-', 1) == std::string::npos)
          << x << " decimals " << d << ": " << s;
    }
  // Spot checks of the rules themselves (half away from zero, no trailing zeros, no "-0").
  EXPECT_EQ(new_fixed(2.5, 0), "3");
  EXPECT_EQ(new_fixed(-2.5, 0), "-3");
  EXPECT_EQ(new_fixed(1.25, 1), "1.3");
  EXPECT_EQ(new_fixed(-0.0, 3), "0");
  EXPECT_EQ(new_fixed(-0.0004, 3), "0");
  EXPECT_EQ(new_fixed(12.5, 3), "12.5");
  EXPECT_EQ(new_fixed(-0.001, 3), "-0.001");
}

// The G-code writer's move words round once: fixed_q() of llround(v * 10^d) prints what the
// previous formatter printed for v, and the reader's parser reads it back as q / 10^d, the value
// the writer hands to its time estimate instead of the text (every precision, both signs, -0,
// ties and their neighbours, huge and tiny values).
TEST(FastNumber, RoundedOnceThePrintedWordsAreThePreviousOnesAndReadBackAsQ) {
  static constexpr double kPow[] = {1, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6};
  const auto values = corpus(5);
  long compared = 0, read = 0;
  for (const double x : values)
    for (int d = 0; d <= 6; ++d) {
      long long q = 0;
      if (!fastnum::round_half_away(x * kPow[d], q)) continue;  // the writer prints fixed_legacy
      char buf[fastnum::kMaxChars];
      const std::string s(buf, fastnum::fixed_q(buf, q, d));
      ASSERT_EQ(s, old_fixed(x, d)) << "value " << fmt::format("{:.17g}", x) << " decimals " << d;
      ++compared;
      double back = 0;
      const char* end = s.data() + s.size();
      // Numbers of more than 15 digits the reader parses otherwise; the writer's stay far below.
      if (gcode_lex::scan_decimal(s.data(), end, back) != end) continue;
      ASSERT_EQ(back, static_cast<double>(q) / kPow[d]) << s << " decimals " << d;
      ASSERT_EQ(std::signbit(back), std::signbit(static_cast<double>(q) / kPow[d])) << s;
      ++read;
    }
  EXPECT_GT(compared, 6000000);
  EXPECT_GT(read, 5000000);
}

// The G-code writer's coordinates below 1000 mm (fixed3_small: three digits a table entry)
// print as fmt's correctly rounded "{:.3f}" of q / 1000 with trailing zeros (and a bare '.')
// removed, for every q the tables take, both signs; the bytes past the end it may write stay
// within the 8 allowed. Through the writer's corpus as well: the previous formatter's bytes.
TEST(FastNumber, ThreeDigitTablesPrintEveryCoordinateBelow1000mm) {
  auto expected = [](long long q) {
    std::string s = fmt::format("{:.3f}", static_cast<double>(q) / 1000);
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
    return s == "-0" ? std::string("0") : s;
  };
  char buf[fastnum::kMaxChars];
  for (long long q = -fastnum::kFixed3Small + 1; q < fastnum::kFixed3Small; ++q) {
    std::memset(buf, 'x', sizeof buf);
    char* end = fastnum::fixed3_small(buf, q);
    ASSERT_EQ(std::string(buf, end), expected(q)) << q;
    std::ptrdiff_t touched = sizeof buf;  // one past the last byte written
    while (touched > 0 && buf[touched - 1] == 'x') --touched;
    ASSERT_LE(touched, end - buf + 8) << q;
  }
  for (const double x : corpus(1)) {
    long long q = 0;
    if (!fastnum::round_half_away(x * 1e3, q) || q >= fastnum::kFixed3Small ||
        q <= -fastnum::kFixed3Small)
      continue;
    ASSERT_EQ(std::string(buf, fastnum::fixed3_small(buf, q)), old_fixed(x, 3))
        << fmt::format("{:.17g}", x);
  }
}

// The CLI writer's coordinates (fixed2_small: µm with two decimals from table entries) print as
// fmt's "{:.2f}" of u / 100 without trailing zeros, for every u below 2 * 10^6 and 2 M random
// ones up to 10^8 (whole kilometres in µm), and as fixed_small did.
TEST(FastNumber, TwoDecimalTablesPrintEveryCliCoordinate) {
  auto expected = [](std::uint64_t u) {
    std::string s = fmt::format("{:.2f}", static_cast<double>(u) / 100);
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
    return s;
  };
  char buf[fastnum::kMaxChars], old[fastnum::kMaxChars];
  auto check = [&](std::uint64_t u) {
    std::memset(buf, 'x', sizeof buf);
    char* end = fastnum::fixed2_small(buf, u);
    const std::string s(buf, end);
    ASSERT_EQ(s, expected(u)) << u;
    ASSERT_EQ(s, std::string(old, fastnum::fixed_small(old, u, 2))) << u;
    std::ptrdiff_t touched = sizeof buf;
    while (touched > 0 && buf[touched - 1] == 'x') --touched;
    ASSERT_LE(touched, end - buf + 8) << u;
  };
  for (std::uint64_t u = 0; u < 2000000 && !HasFatalFailure(); ++u) check(u);
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<std::uint64_t> any(0, 99999999);
  for (int i = 0; i < 2000000 && !HasFatalFailure(); ++i) check(any(rng));
  check(99999999);
  check(100000);
  check(99999900);
}

// The G-code writer's E words below 1000 mm (fixed5_small) print as fmt's correctly rounded
// "{:.5f}" of q / 10^5 without trailing zeros, and as fixed_q did: every |q| below 2 * 10^6 and
// 2 M random ones up to 10^8, both signs.
TEST(FastNumber, FiveDecimalTablesPrintEveryExtrusionBelow1000mm) {
  auto expected = [](long long q) {
    std::string s = fmt::format("{:.5f}", static_cast<double>(q) / 100000);
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
    return s == "-0" ? std::string("0") : s;
  };
  char buf[fastnum::kMaxChars], old[fastnum::kMaxChars];
  auto check = [&](long long q) {
    std::memset(buf, 'x', sizeof buf);
    char* end = fastnum::fixed5_small(buf, q);
    const std::string s(buf, end);
    ASSERT_EQ(s, expected(q)) << q;
    ASSERT_EQ(s, std::string(old, fastnum::fixed_q(old, q, 5))) << q;
    std::ptrdiff_t touched = sizeof buf;
    while (touched > 0 && buf[touched - 1] == 'x') --touched;
    ASSERT_LE(touched, end - buf + 8) << q;
  };
  for (long long q = -2000000; q < 2000000 && !HasFatalFailure(); ++q) check(q);
  std::mt19937_64 rng(13);
  std::uniform_int_distribution<long long> any(-fastnum::kFixed5Small + 1,
                                               fastnum::kFixed5Small - 1);
  for (int i = 0; i < 2000000 && !HasFatalFailure(); ++i) check(any(rng));
  for (const long long q : {99999999LL, -99999999LL, 100000LL, 100100LL, 99900000LL}) check(q);
}

TEST(FastNumber, FixedRoundsAsLlroundEverywhereItTakesTheFastPath) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<long long> n(-(1LL << 53), 1LL << 53);
  for (int i = 0; i < 1000000; ++i) {
    const double x =
        static_cast<double>(n(rng)) / static_cast<double>(1 << (i % 12)) + (i % 3 == 0 ? 0.5 : 0.0);
    long long q = 0;
    ASSERT_TRUE(fastnum::round_half_away(x, q));
    ASSERT_EQ(q, std::llround(x)) << fmt::format("{:.17g}", x);
  }
  long long q = 0;
  EXPECT_FALSE(fastnum::round_half_away(NAN, q));
  EXPECT_FALSE(fastnum::round_half_away(1e19, q));
}

TEST(FastNumber, CliCoordinatesPrintTheBytesOfThePreviousFormatter) {
  const auto values = corpus(2);
  for (const double x : values) {
    ASSERT_EQ(new_cli(x), old_cli(x)) << "value " << fmt::format("{:.17g}", x);
    ASSERT_EQ(new_cli(x / 1000), old_cli(x / 1000)) << "value " << fmt::format("{:.17g}", x / 1000);
  }
  // Coordinates exactly on the 10 nm grid, and halfway between two grid points.
  for (long long k = -3000000; k <= 3000000; k += 7) {
    const double mm = static_cast<double>(k) * 1e-5;
    ASSERT_EQ(new_cli(mm), old_cli(mm)) << k;
    ASSERT_EQ(new_cli(mm + 0.5e-5), old_cli(mm + 0.5e-5)) << k;
  }
  EXPECT_EQ(new_cli(-0.0), "0");
  EXPECT_EQ(new_cli(-0.000001), "0");
  EXPECT_EQ(new_cli(1.5), "1500");
  EXPECT_EQ(new_cli(-0.01234), "-12.34");
  EXPECT_EQ(new_cli(0.0001), "0.1");
}

// FNV-1a digest of a file's formatted numbers: for G-code its moves and per-layer comments (the
// header's settings list and the footer's estimates change with other work, not with number
// formatting; progress lines count by position only), for CLI everything after the header.
std::uint64_t fnv(const std::string& s) {
  std::uint64_t h = 1469598103934665603ULL;
  auto add = [&](std::string_view t) {
    for (const unsigned char c : t) h = (h ^ c) * 1099511628211ULL;
  };
  if (const auto end = s.find("$$HEADEREND"); end != std::string::npos) {
    add(std::string_view(s).substr(end));
    return h;
  }
  for (std::size_t a = 0; a < s.size();) {
    const std::size_t b = std::min(s.find('\n', a), s.size());
    const std::string_view line = std::string_view(s).substr(a, b - a);
    if (line.starts_with("G0 ") || line.starts_with("G1 ") || line.starts_with(";Z:") ||
        line.starts_with(";WIDTH:") || line.starts_with(";HEIGHT:") || line == "M3" || line == "M5")
      add(line), add("\n");
    else if (line.starts_with("M73 P"))  // where progress lines go (their values are estimates)
      add("M73\n");
    a = b + 1;
  }
  return h;
}

Toolpath random_toolpath(unsigned seed, int layers, int paths) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Toolpath tp;
  for (int l = 0; l < layers; ++l) {
    Layer layer{0.2 * (l + 1), {}};
    for (int k = 0; k < paths; ++k) {
      Path p;
      p.height = 0.2;
      p.role = k % 5 == 0 ? PathRole::Infill : PathRole::Contour;
      Vec3 q{u(rng) * 100 - 50, u(rng) * 100 - 50, layer.z};
      const int m = p.role == PathRole::Infill ? 2 : 3 + k % 20;
      for (int i = 0; i < m; ++i) {
        p.points.push_back(q);
        q = q + Vec3{u(rng) - 0.5, u(rng) - 0.5, 0};
      }
      layer.paths.push_back(std::move(p));
    }
    tp.layers.push_back(std::move(layer));
  }
  return tp;
}

// Whole files: the digests were recorded from the writers as they were before the fast
// formatting (the same test run against the previous libtrellis, TRELLIS_PRINT_DIGESTS=1).
TEST(FastNumber, WrittenFilesAreByteIdenticalToThePreviousWriters) {
  const Toolpath tp = random_toolpath(3, 12, 300);
  MachineProfile marlin = test::open_bed();
  marlin.retract_length = 0.8;
  marlin.z_hop = 0.2;
  MachineProfile relative = marlin;
  relative.relative_e = true;
  MachineProfile klipper = marlin;
  klipper.flavor = Flavor::Klipper;
  MachineProfile pneumatic = test::open_bed();
  pneumatic.flavor = Flavor::Pneumatic;
  pneumatic.valve_on = "M3";
  pneumatic.valve_off = "M5";
  const std::vector<std::pair<std::string, std::string>> files = {
      {"marlin", write_gcode(tp, marlin)},
      {"relative_e", write_gcode(tp, relative)},
      {"klipper", write_gcode(tp, klipper)},
      {"pneumatic", write_gcode(tp, pneumatic)},
      {"cli_ascii", write_cli(tp, LaserProfile{}, CliWriteOptions{false, true})},
      {"cli_binary", write_cli(tp, LaserProfile{}, CliWriteOptions{true, false})},
  };
  const std::vector<std::uint64_t> expected = {
      0xd1006cc36b65eaeeULL, 0xcf142c6790dab87cULL, 0xd1006cc36b65eaeeULL,
      0x7535299c85b112b9ULL, 0xafc2cde046f77524ULL, 0x4012684cc91345a8ULL,
  };
  if (std::getenv("TRELLIS_PRINT_DIGESTS"))
    for (const auto& [name, text] : files)
      std::printf("%s %zu 0x%016llxULL\n", name.c_str(), text.size(),
                  static_cast<unsigned long long>(fnv(text)));
  for (std::size_t i = 0; i < files.size(); ++i)
    EXPECT_EQ(fnv(files[i].second), expected[i]) << files[i].first;
}

}  // namespace
