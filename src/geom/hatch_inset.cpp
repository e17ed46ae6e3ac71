// Hatch lines of a region minus another, kept a distance away from both regions' outlines: the
// plain hatch, then on each line the stretches within `inset` of any outline edge (the edge's
// capsule cut by the line: one interval, the capsule being convex) and the cut region's own
// stretches are taken out. Equivalent to hatching the inward offset of (keep − cut) by `inset`
// (polygon offsets spend their time resolving the offset edges' self-intersections; this
// handles each edge on the few lines within reach of it).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include "trellis/geom/regions.hpp"

namespace trellis {

namespace {

struct Span {
  double lo, hi;
};

// The stretch of the line t = 0 (in along/across coordinates) within r of the segment a–b;
// without b's disc when !end_disc (a ring's next edge adds it: the disc at a and the band beside
// the segment form a convex set, so the stretch is still one interval).
bool capsule_span(Vec2 a, Vec2 b, double r, Span* out, bool end_disc = true) {
  double lo = 1e300, hi = -1e300;
  for (int e = 0; e < (end_disc ? 2 : 1); ++e) {  // the end discs
    const Vec2 c = e == 0 ? a : b;
    if (std::abs(c.y) > r) continue;
    const double w = std::sqrt(r * r - c.y * c.y);
    lo = std::min(lo, c.x - w);
    hi = std::max(hi, c.x + w);
  }
  // The band beside the segment: distance to its line <= r, projection within the segment.
  const Vec2 d = b - a;
  const double dd = d.x * d.x + d.y * d.y;
  if (dd > 0) {
    const double len = std::sqrt(dd);
    // Distance: |d.x·(0 − a.y) − d.y·(x − a.x)| / len <= r, i.e. |d.y·x + k| <= r·len with
    // k = d.x·a.y − d.y·a.x (sign flipped, same set).
    const double k = d.x * a.y - d.y * a.x;
    double x0 = -1e300, x1 = 1e300;
    if (d.y != 0) {
      const double p = (-r * len - k) / d.y, q = (r * len - k) / d.y;
      x0 = std::min(p, q);
      x1 = std::max(p, q);
    } else if (std::abs(k) > r * len) {
      x0 = 1, x1 = 0;  // parallel and farther than r
    }
    // Projection λ = ((x − a.x)·d.x − a.y·d.y) / dd within [0, 1].
    if (d.x != 0) {
      const double p = a.x + a.y * d.y / d.x, q = a.x + (dd + a.y * d.y) / d.x;
      x0 = std::max(x0, std::min(p, q));
      x1 = std::min(x1, std::max(p, q));
    } else {
      const double lambda = -a.y * d.y / dd;
      if (lambda < 0 || lambda > 1) x0 = 1, x1 = 0;
    }
    if (x0 <= x1) {
      lo = std::min(lo, x0);
      hi = std::max(hi, x1);
    }
  }
  if (lo > hi) return false;
  *out = {lo, hi};
  return true;
}

}  // namespace

std::vector<Segment2> trim_hatch(const std::vector<Segment2>& segs, const Regions& region,
                                 double angle_deg, double spacing, double inset, bool remove_inside,
                                 Vec2 origin) {
  if (segs.empty() || (!(inset > 0) && !remove_inside) || region.empty()) return segs;
  const double ang = angle_deg * std::numbers::pi / 180;
  const Vec2 u{std::cos(ang), std::sin(ang)}, v{-std::sin(ang), std::cos(ang)};
  auto along = [&](Vec2 p) { return (p.x - origin.x) * u.x + (p.y - origin.y) * u.y; };
  auto across = [&](Vec2 p) { return (p.x - origin.x) * v.x + (p.y - origin.y) * v.y; };
  auto line_of = [&](Vec2 p) { return static_cast<long long>(std::llround(across(p) / spacing)); };
  // The stretches to take out, per line (indexed from the lowest line with hatch).
  long long k_lo = line_of(segs.front().a), k_hi = k_lo;
  for (const auto& s : segs) {
    k_lo = std::min(k_lo, line_of(s.a));
    k_hi = std::max(k_hi, line_of(s.a));
  }
  std::vector<std::vector<Span>> spans(static_cast<std::size_t>(k_hi - k_lo + 1));
  std::vector<char> used(spans.size(), 0);
  for (const auto& s : segs) used[static_cast<std::size_t>(line_of(s.a) - k_lo)] = 1;
  auto slot = [&](long long k) -> std::vector<Span>* {
    if (k < k_lo || k > k_hi || !used[static_cast<std::size_t>(k - k_lo)]) return nullptr;
    return &spans[static_cast<std::size_t>(k - k_lo)];
  };
  if (remove_inside)
    for (const auto& s : hatch(region, angle_deg, spacing, origin))
      if (auto* sp = slot(line_of(s.a))) sp->push_back({along(s.a), along(s.b)});
  if (inset > 0) {
    // Consecutive edges of a ring cut mostly the same stretch of a line (their capsules share
    // the end disc of the common vertex): a span overlapping the one the previous edge left on
    // the same line widens it instead of adding one (the union is the same; far fewer spans to
    // sort). last[k]: (edge serial, span index) of the latest span on line k. Each vertex's
    // disc is added once, by the edge starting there.
    std::vector<std::pair<std::size_t, std::size_t>> last(spans.size(), {~std::size_t{0}, 0});
    std::size_t serial = 0;
    auto add_ring = [&](const std::vector<Vec2>& ring) {
      ++serial;  // a ring's first edge never widens the previous ring's spans
      for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++, ++serial) {
        const double ta = across(ring[j]), tb = across(ring[i]);
        const auto k0 =
            std::max(k_lo, static_cast<long long>(std::ceil((std::min(ta, tb) - inset) / spacing)));
        const auto k1 = std::min(
            k_hi, static_cast<long long>(std::floor((std::max(ta, tb) + inset) / spacing)));
        for (long long k = k0; k <= k1; ++k) {
          auto* sp = slot(k);
          if (!sp) continue;
          const double t = static_cast<double>(k) * spacing;
          Span c;
          if (!capsule_span({along(ring[j]), ta - t}, {along(ring[i]), tb - t}, inset, &c, false))
            continue;
          auto& [from, at] = last[static_cast<std::size_t>(k - k_lo)];
          if (from + 1 == serial && at < sp->size()) {
            Span& p = (*sp)[at];
            if (c.lo <= p.hi && c.hi >= p.lo) {
              p.lo = std::min(p.lo, c.lo);
              p.hi = std::max(p.hi, c.hi);
              from = serial;
              continue;
            }
          }
          from = serial;
          at = sp->size();
          sp->push_back(c);
        }
      }
    };
    for (const auto& p : region) {
      if (p.outer.size() >= 2) add_ring(p.outer);
      for (const auto& h : p.holes)
        if (h.size() >= 2) add_ring(h);
    }
  }
  for (auto& sp : spans)
    std::sort(sp.begin(), sp.end(), [](const Span& a, const Span& b) { return a.lo < b.lo; });
  std::vector<Segment2> result;
  result.reserve(segs.size());
  for (const auto& s : segs) {
    const auto& sp = spans[static_cast<std::size_t>(line_of(s.a) - k_lo)];
    const double s0 = along(s.a), s1 = along(s.b);
    auto at = [&](double x) { return s.a + u * (x - s0); };
    double cur = s0;
    for (const Span& c : sp) {
      if (c.hi <= cur) continue;
      if (c.lo >= s1) break;
      if (c.lo > cur) result.push_back({at(cur), at(c.lo)});
      cur = std::max(cur, c.hi);
      if (cur >= s1) break;
    }
    if (cur < s1) result.push_back({at(cur), at(s1)});
  }
  // Slivers shorter than a nanometre (touching spans) are dropped.
  // (Vectors at least 2 nm long in |dx| + |dy| are at least 1.4 nm long: no hypot for them.)
  std::erase_if(result, [](const Segment2& g) {
    const double dx = g.b.x - g.a.x, dy = g.b.y - g.a.y;
    return std::abs(dx) + std::abs(dy) < 2e-6 && std::hypot(dx, dy) < 1e-6;
  });
  return result;
}

std::vector<Segment2> hatch_inset(const Regions& keep, const Regions& cut, double angle_deg,
                                  double spacing, double inset, Vec2 origin) {
  const auto kept = trim_hatch(hatch(keep, angle_deg, spacing, origin), keep, angle_deg, spacing,
                               inset, false, origin);
  return trim_hatch(kept, cut, angle_deg, spacing, inset, true, origin);
}

}  // namespace trellis
