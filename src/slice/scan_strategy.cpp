#include "trellis/slice/scan_strategy.hpp"

#include <cmath>
#include <map>
#include <utility>

#include "trellis/core/rng.hpp"

namespace trellis {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Pieces shorter than this (mm) are dropped: a cut that grazes an island's or stripe's corner.
constexpr double kMinPiece = 1e-4;

// The frame of a layer's hatch: u along the lines at `angle`, v across them.
struct Frame {
  Vec2 d, n;
  explicit Frame(double angle_deg) {
    const double a = angle_deg * kPi / 180;
    d = {std::cos(a), std::sin(a)};
    n = {-d.y, d.x};
  }
  double u(Vec2 p) const { return p.x * d.x + p.y * d.y; }
  double v(Vec2 p) const { return p.x * n.x + p.y * n.y; }
};

// Line number of a hatch segment (lines pass through `origin`, `spacing` apart).
long line_of(const Segment2& s, const Frame& f, double spacing, Vec2 origin) {
  return std::lround((f.v(s.a) - f.v(origin)) / spacing);
}

Segment2 oriented(Segment2 s, bool reverse) {
  return reverse ? Segment2{s.b, s.a} : s;
}

// Cells [k·size + shift − grow, (k + 1)·size + shift + grow] holding coordinate range [lo, hi].
std::pair<long, long> cells(double lo, double hi, double size, double shift, double grow) {
  return {static_cast<long>(std::ceil((lo - shift - grow) / size - 1)),
          static_cast<long>(std::floor((hi - shift + grow) / size))};
}

// The piece of segment s (along frame direction `along`, from low to high) inside [lo, hi] of
// that coordinate; false when shorter than kMinPiece.
bool cut(const Segment2& s, double ua, double ub, double lo, double hi, Segment2& out) {
  const double a = std::max(ua, lo), b = std::min(ub, hi);
  if (!(b - a > kMinPiece)) return false;
  const double len = ub - ua;
  const Vec2 dir = (s.b - s.a) * (1 / len);
  out = {s.a + dir * (a - ua), s.a + dir * (b - ua)};
  return true;
}

std::vector<Segment2> lines(const std::vector<Segment2>& all, const Frame& f, double spacing,
                            bool meander, Vec2 origin) {
  std::vector<Segment2> out;
  out.reserve(all.size());
  for (const Segment2& s : all)
    out.push_back(oriented(s, meander && (line_of(s, f, spacing, origin) & 1)));
  return out;
}

std::vector<Segment2> stripes(const std::vector<Segment2>& all, const Frame& f,
                              const ScanPattern& p, Vec2 origin) {
  std::map<long, std::vector<Segment2>> by_stripe;
  const double w = p.stripe_width, grow = p.stripe_overlap / 2;
  for (const Segment2& s : all) {
    const double ua = f.u(s.a), ub = f.u(s.b);
    const auto [k0, k1] = cells(ua, ub, w, 0, grow);
    for (long k = k0; k <= k1; ++k) {
      Segment2 piece;
      if (cut(s, ua, ub, k * w - grow, (k + 1) * w + grow, piece)) by_stripe[k].push_back(piece);
    }
  }
  std::vector<Segment2> out;
  for (auto& [k, pieces] : by_stripe)
    for (const Segment2& s : pieces)
      out.push_back(oriented(s, line_of(s, f, p.hatch_distance, origin) & 1));
  return out;
}

// Island pieces of the lines along one of the island axes: `parity` 0 keeps islands with i + j
// even (lines along u), 1 odd (lines along v). `along` is the frame of the lines.
void island_pieces(const std::vector<Segment2>& all, const Frame& grid, bool along_v, double shift,
                   const ScanPattern& p,
                   std::map<std::pair<long, long>, std::vector<Segment2>>& out) {
  const double size = p.island_size, grow = p.island_overlap / 2;
  for (const Segment2& s : all) {
    // Along the line: the coordinate that varies; across: the constant one.
    const double la = along_v ? grid.v(s.a) : grid.u(s.a), lb = along_v ? grid.v(s.b) : grid.u(s.b);
    const double across = along_v ? grid.u(s.a) : grid.v(s.a);
    const auto [c0, c1] = cells(across, across, size, shift, grow);
    const auto [a0, a1] = cells(la, lb, size, shift, grow);
    for (long c = c0; c <= c1; ++c)
      for (long a = a0; a <= a1; ++a) {
        const long i = along_v ? c : a, j = along_v ? a : c;
        if (((i + j) & 1) != (along_v ? 1 : 0)) continue;
        Segment2 piece;
        if (cut(s, la, lb, a * size + shift - grow, (a + 1) * size + shift + grow, piece))
          out[{j, i}].push_back(piece);
      }
  }
}

std::vector<Segment2> islands(const Regions& region, double inset, double angle,
                              const ScanPattern& p, std::size_t layer, Vec2 origin) {
  const Frame grid(angle), cross(angle + 90);
  const double shift = std::fmod(static_cast<double>(layer) * p.island_shift, p.island_size);
  std::map<std::pair<long, long>, std::vector<Segment2>> by_island;
  island_pieces(hatch_inset(region, {}, angle, p.hatch_distance, inset, origin), grid, false, shift,
                p, by_island);
  island_pieces(hatch_inset(region, {}, angle + 90, p.hatch_distance, inset, origin), grid, true,
                shift, p, by_island);
  std::vector<Segment2> out;
  for (auto& [ij, pieces] : by_island) {
    const bool odd = (ij.first + ij.second) & 1;
    for (const Segment2& s : pieces)
      out.push_back(oriented(s, line_of(s, odd ? cross : grid, p.hatch_distance, origin) & 1));
  }
  return out;
}

}  // namespace

double scan_angle(const ScanPattern& pattern, std::size_t layer) {
  const double a = std::fmod(pattern.angle + static_cast<double>(layer) * pattern.rotation, 360.0);
  return a < 0 ? a + 360 : a;
}

Vec2 random_hatch_shift(double angle_deg, std::uint64_t seed, std::size_t layer, double spacing) {
  const double a = angle_deg * (kPi / 180);
  return Vec2{-std::sin(a), std::cos(a)} * (Rng::stream(seed, layer).uniform01() * spacing);
}

std::vector<Segment2> scan_hatches(const Regions& region, double inset, const ScanPattern& p,
                                   std::size_t layer, Vec2 origin) {
  if (region.empty()) return {};
  const double angle = scan_angle(p, layer);
  if (p.strategy == ScanStrategy::Island) return islands(region, inset, angle, p, layer, origin);
  const Frame f(angle);
  const auto all = hatch_inset(region, {}, angle, p.hatch_distance, inset, origin);
  switch (p.strategy) {
    case ScanStrategy::Rectilinear:
      return lines(all, f, p.hatch_distance, false, origin);
    case ScanStrategy::Meander:
      return lines(all, f, p.hatch_distance, true, origin);
    case ScanStrategy::Stripe:
      return stripes(all, f, p, origin);
    case ScanStrategy::Island:
      break;
  }
  return {};
}

}  // namespace trellis
