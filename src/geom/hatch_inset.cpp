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

#include "clipper_util.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

namespace {

struct Span {
  double lo, hi;
};

// std::ceil and std::floor to an integer, the same numbers for |x| < 2^52 (line numbers of a
// hatch), inline: the library calls were 3–5% of trim_hatch (std::llround: round_ll).
long long ceil_ll(double x) {
  const auto i = static_cast<long long>(x);
  return i + (static_cast<double>(i) < x);
}
long long floor_ll(double x) {
  const auto i = static_cast<long long>(x);
  return i - (static_cast<double>(i) > x);
}

// The stretches of the lines t = const (in along/across coordinates s, t) within r of the
// segment a–b, without b's disc (a ring's next edge adds it: the disc at a and the band beside the
// segment form a convex set, so each stretch is one interval). Everything that does not depend on
// the line is worked out once per edge, so a line costs a square root (a's disc) and a few
// multiply-adds.
class Capsule {
 public:
  Capsule(Vec2 a, Vec2 b, double r) : sa_(a.x), ta_(a.y), r_(r) {
    const double dx = b.x - a.x, dy = b.y - a.y, dd = dx * dx + dy * dy;
    if (!(dd > 0)) return;
    band_ = true;
    const double rl = r * std::sqrt(dd);
    // The band: distance to the segment's line |dy·s − dx·(t − ta) − dy·sa| / len <= r, i.e.
    // s within [(−r·len − k)/dy, (r·len − k)/dy] with k = dx·(ta − t) − dy·sa: its ends move
    // along the lines by dx/dy per unit of t.
    const double k0 = dx * a.y - dy * a.x;
    if (dy != 0) {
      const double p = (-rl - k0) / dy, q = (rl - k0) / dy;
      lo0_ = std::min(p, q);
      hi0_ = std::max(p, q);
      slope_ = dx / dy;
    } else {
      parallel_ = true;  // then the band holds the lines with |dx·(ta − t)| <= r·len
      par_k0_ = k0;
      par_dx_ = dx;
      par_rl_ = rl;
    }
    // The projection onto the segment within [0, 1]: s between p and p + dd/dx with
    // p = sa + (ta − t)·dy/dx; or (dx = 0) the lines with −(ta − t)·dy/dd in [0, 1].
    if (dx != 0) {
      proj_ratio_ = dy / dx;
      proj_len_ = dd / dx;
    } else {
      vertical_ = true;
      vert_dy_dd_ = dy / dd;
    }
  }
  bool span(double t, Span* out) const {
    double lo = 1e300, hi = -1e300;
    const double ya = ta_ - t;
    if (std::abs(ya) <= r_) {
      const double w = std::sqrt(r_ * r_ - ya * ya);
      lo = sa_ - w;
      hi = sa_ + w;
    }
    if (band_) {
      double x0 = -1e300, x1 = 1e300;
      if (!parallel_) {
        x0 = lo0_ + slope_ * t;
        x1 = hi0_ + slope_ * t;
      } else if (std::abs(par_k0_ - par_dx_ * t) > par_rl_) {
        x0 = 1, x1 = 0;
      }
      if (!vertical_) {
        const double p = sa_ + ya * proj_ratio_, q = p + proj_len_;
        x0 = std::max(x0, std::min(p, q));
        x1 = std::min(x1, std::max(p, q));
      } else {
        const double lambda = -ya * vert_dy_dd_;
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

 private:
  double sa_, ta_, r_;
  bool band_ = false, parallel_ = false, vertical_ = false;
  double lo0_ = 0, hi0_ = 0, slope_ = 0;
  double par_k0_ = 0, par_dx_ = 0, par_rl_ = 0;
  double proj_ratio_ = 0, proj_len_ = 0, vert_dy_dd_ = 0;
};

}  // namespace

std::vector<Segment2> trim_hatch(const std::vector<Segment2>& segs, const Regions& region,
                                 double angle_deg, double spacing, double inset, bool remove_inside,
                                 Vec2 origin) {
  if (segs.empty() || (!(inset > 0) && !remove_inside) || region.empty()) return segs;
  const double ang = angle_deg * std::numbers::pi / 180;
  const Vec2 u{std::cos(ang), std::sin(ang)}, v{-std::sin(ang), std::cos(ang)};
  auto along = [&](Vec2 p) { return (p.x - origin.x) * u.x + (p.y - origin.y) * u.y; };
  auto across = [&](Vec2 p) { return (p.x - origin.x) * v.x + (p.y - origin.y) * v.y; };
  auto line_of = [&](Vec2 p) { return clipper_util::round_ll(across(p) / spacing); };
  // The stretches to take out, per line (indexed from the lowest line with hatch), gathered in
  // one array (line, span) and grouped by line at the end.
  std::vector<long long> seg_line(segs.size());
  for (std::size_t i = 0; i < segs.size(); ++i) seg_line[i] = line_of(segs[i].a);
  const long long k_lo = *std::min_element(seg_line.begin(), seg_line.end());
  const long long k_hi = *std::max_element(seg_line.begin(), seg_line.end());
  const auto lines = static_cast<std::size_t>(k_hi - k_lo + 1);
  std::vector<char> used(lines, 0);
  for (const long long k : seg_line) used[static_cast<std::size_t>(k - k_lo)] = 1;
  auto wanted = [&](long long k) {
    return k >= k_lo && k <= k_hi && used[static_cast<std::size_t>(k - k_lo)];
  };
  struct Entry {
    std::size_t line;
    Span span;
  };
  std::vector<Entry> flat;
  if (remove_inside)
    for (const auto& s : hatch(region, angle_deg, spacing, origin)) {
      const long long k = line_of(s.a);
      if (wanted(k)) flat.push_back({static_cast<std::size_t>(k - k_lo), {along(s.a), along(s.b)}});
    }
  if (inset > 0) {
    // Consecutive edges of a ring cut mostly the same stretch of a line (their capsules share
    // the end disc of the common vertex): a span overlapping the one the previous edge left on
    // the same line widens it instead of adding one (the union is the same; far fewer spans to
    // sort). last[k]: (edge serial, span index) of the latest span on line k. Each vertex's
    // disc is added once, by the edge starting there.
    std::vector<std::pair<std::size_t, std::size_t>> last(lines, {~std::size_t{0}, 0});
    std::size_t serial = 0;
    std::vector<Vec2> st;                             // the ring in (along, across) coordinates
    std::vector<std::pair<long long, long long>> kr;  // each vertex's first and last line
    auto add_ring = [&](const std::vector<Vec2>& ring) {
      ++serial;  // a ring's first edge never widens the previous ring's spans
      st.resize(ring.size());
      kr.resize(ring.size());
      // Each vertex's lines within reach, worked out once for both its edges (rounding is
      // monotonic, so an edge's range is the union of its ends': the same numbers).
      for (std::size_t i = 0; i < ring.size(); ++i) {
        st[i] = {along(ring[i]), across(ring[i])};
        kr[i] = {ceil_ll((st[i].y - inset) / spacing), floor_ll((st[i].y + inset) / spacing)};
      }
      for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++, ++serial) {
        const auto k0 = std::max(k_lo, std::min(kr[j].first, kr[i].first));
        const auto k1 = std::min(k_hi, std::max(kr[j].second, kr[i].second));
        if (k0 > k1) continue;
        const Capsule capsule(st[j], st[i], inset);
        for (long long k = k0; k <= k1; ++k) {
          if (!used[static_cast<std::size_t>(k - k_lo)]) continue;
          Span c;
          if (!capsule.span(static_cast<double>(k) * spacing, &c)) continue;
          auto& [from, at] = last[static_cast<std::size_t>(k - k_lo)];
          if (from + 1 == serial) {
            Span& p = flat[at].span;
            if (c.lo <= p.hi && c.hi >= p.lo) {
              p.lo = std::min(p.lo, c.lo);
              p.hi = std::max(p.hi, c.hi);
              from = serial;
              continue;
            }
          }
          from = serial;
          at = flat.size();
          flat.push_back({static_cast<std::size_t>(k - k_lo), c});
        }
      }
    };
    for (const auto& p : region) {
      if (p.outer.size() >= 2) add_ring(p.outer);
      for (const auto& h : p.holes)
        if (h.size() >= 2) add_ring(h);
    }
  }
  // Grouped by line (a counting sort), each line's spans by their start.
  std::vector<std::size_t> begin(lines + 1, 0);
  for (const Entry& e : flat) ++begin[e.line + 1];
  for (std::size_t k = 0; k < lines; ++k) begin[k + 1] += begin[k];
  std::vector<Span> spans(flat.size());
  {
    std::vector<std::size_t> fill(begin.begin(), begin.end() - 1);
    for (const Entry& e : flat) spans[fill[e.line]++] = e.span;
  }
  for (std::size_t k = 0; k < lines; ++k)
    std::sort(spans.begin() + static_cast<std::ptrdiff_t>(begin[k]),
              spans.begin() + static_cast<std::ptrdiff_t>(begin[k + 1]),
              [](const Span& a, const Span& b) { return a.lo < b.lo; });
  std::vector<Segment2> result;
  result.reserve(segs.size());
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const Segment2& s = segs[i];
    const auto k = static_cast<std::size_t>(seg_line[i] - k_lo);
    const double s0 = along(s.a), s1 = along(s.b);
    auto at = [&](double x) { return s.a + u * (x - s0); };
    double cur = s0;
    for (std::size_t c_at = begin[k]; c_at < begin[k + 1]; ++c_at) {
      const Span& c = spans[c_at];
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
