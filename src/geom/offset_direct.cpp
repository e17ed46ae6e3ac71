// Mitred offsets without Clipper's clean-up union, where none is needed. ClipperOffset emits each
// ring's offset edges joined through the original vertex where the offset trims a corner, then
// unites the result with a sweep: that union was three quarters of an offset's cost (slicing the
// Vase: 2,355 offsets of ~115 points, 366 k instructions each). Here the trimmed corners are
// the crossings of the neighbouring offset edges and the opened ones Clipper's own mitre or
// square points; an edge trimmed away at both ends (shorter than the offset eats: the finely
// tessellated curves of a slice offset by a bead or two) is dropped and its neighbours crossed,
// as the union cuts off the loop it makes. The rings are kept only when nothing else needs the
// union: every edge left keeps its direction, no two edges of any ring meet, and no ring has
// moved into or out of another. Otherwise offset() runs ClipperOffset as before (on the Vase
// that was 527 of its 2,355 offsets before edges were dropped, 0 after; TR12J half scale 1,976
// of 4,506, then 372).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "clipper_util.hpp"

namespace trellis::clipper_util {

namespace cl = ClipperLib;

namespace {

struct Normal {
  double x, y;
};

Normal unit_normal(const cl::IntPoint& a, const cl::IntPoint& b) {
  const double dx = static_cast<double>(b.X - a.X), dy = static_cast<double>(b.Y - a.Y);
  const double l = std::sqrt(dx * dx + dy * dy);
  if (l == 0) return {0, 0};
  return {dy / l, -dx / l};
}

cl::IntPoint at(const cl::IntPoint& p, double x, double y) {
  return {static_cast<cl::cInt>(round_ll(static_cast<double>(p.X) + x)),
          static_cast<cl::cInt>(round_ll(static_cast<double>(p.Y) + y))};
}

__int128 orient(const cl::IntPoint& a, const cl::IntPoint& b, const cl::IntPoint& c) {
  return static_cast<__int128>(b.X - a.X) * (c.Y - a.Y) -
         static_cast<__int128>(b.Y - a.Y) * (c.X - a.X);
}

// Whether closed segments a-b and c-d share a point.
bool segments_meet(const cl::IntPoint& a, const cl::IntPoint& b, const cl::IntPoint& c,
                   const cl::IntPoint& d) {
  if (std::max(a.X, b.X) < std::min(c.X, d.X) || std::max(c.X, d.X) < std::min(a.X, b.X) ||
      std::max(a.Y, b.Y) < std::min(c.Y, d.Y) || std::max(c.Y, d.Y) < std::min(a.Y, b.Y))
    return false;
  const __int128 d1 = orient(a, b, c), d2 = orient(a, b, d), d3 = orient(c, d, a),
                 d4 = orient(c, d, b);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  // Collinear or touching: an end on the other segment (its box already overlaps).
  auto on = [](const cl::IntPoint& p, const cl::IntPoint& q, const cl::IntPoint& r) {
    return std::min(p.X, q.X) <= r.X && r.X <= std::max(p.X, q.X) && std::min(p.Y, q.Y) <= r.Y &&
           r.Y <= std::max(p.Y, q.Y);
  };
  return (d1 == 0 && on(a, b, c)) || (d2 == 0 && on(a, b, d)) || (d3 == 0 && on(c, d, a)) ||
         (d4 == 0 && on(c, d, b));
}

// One ring offset by delta as ClipperOffset::OffsetPoint would emit it, the trimmed corners
// resolved and edges trimmed away dropped; false where that is not enough (edges reversed side by
// side or beside a square corner, a trimmed corner's edges that do not cross).
bool offset_ring(const cl::Path& src, double delta, double miter_lim, cl::Path& out) {
  const std::size_t n = src.size();
  std::vector<Normal> normal(n);
  for (std::size_t j = 0; j < n; ++j) {
    normal[j] = unit_normal(src[j], src[j + 1 == n ? 0 : j + 1]);
    if (normal[j].x == 0 && normal[j].y == 0) return false;  // a repeated point
  }
  // Each vertex: the points Clipper emits (first, last), or a trimmed corner between the
  // incoming offset edge (ending at `first`) and the outgoing one (starting at `last`).
  struct Corner {
    cl::IntPoint first, last;  // the same point but for a square corner (or a trimmed one)
    bool trim;
    // first and last before rounding: the crossing of two raw edges that meet at a small angle
    // moves far along them with a unit's rounding of their ends.
    Normal exact_first{}, exact_last{};
    // Where the offset lines meet (trimmed, mitred to a point, or nearly straight on): an edge
    // between two such corners that is trimmed away leaves its neighbours' lines to meet.
    bool lines_meet = true;
  };
  std::vector<Corner> c(n);
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t k = j == 0 ? n - 1 : j - 1;
    const Normal a = normal[k], b = normal[j];
    double sin_a = a.x * b.y - b.x * a.y;
    const double cos_a = a.x * b.x + a.y * b.y;
    const double x = static_cast<double>(src[j].X), y = static_cast<double>(src[j].Y);
    if (std::fabs(sin_a * delta) < 1.0 && cos_a > 0) {
      const cl::IntPoint p = at(src[j], a.x * delta, a.y * delta);
      const Normal e{x + a.x * delta, y + a.y * delta};
      c[j] = {p, p, false, e, e};
      continue;
    }
    sin_a = std::clamp(sin_a, -1.0, 1.0);
    if (sin_a * delta < 0) {
      c[j] = {at(src[j], a.x * delta, a.y * delta),
              at(src[j], b.x * delta, b.y * delta),
              true,
              {x + a.x * delta, y + a.y * delta},
              {x + b.x * delta, y + b.y * delta}};
      continue;
    }
    const double r = 1 + cos_a;
    if (r >= miter_lim) {
      const double q = delta / r;
      const cl::IntPoint p = at(src[j], (a.x + b.x) * q, (a.y + b.y) * q);
      const Normal e{x + (a.x + b.x) * q, y + (a.y + b.y) * q};
      c[j] = {p, p, false, e, e};
    } else {
      const double dx = std::tan(std::atan2(sin_a, cos_a) / 4);
      const Normal f{x + delta * (a.x - a.y * dx), y + delta * (a.y + a.x * dx)};
      const Normal l{x + delta * (b.x + b.y * dx), y + delta * (b.y - b.x * dx)};
      c[j] = {at(src[j], delta * (a.x - a.y * dx), delta * (a.y + a.x * dx)),
              at(src[j], delta * (b.x + b.y * dx), delta * (b.y - b.x * dx)),
              false,
              f,
              l,
              false};
    }
  }
  // Raw offset edge j runs from c[j].last to c[j + 1].first; a trimmed corner j is where raw
  // edge prev(j) and raw edge j cross, at parameters along each (u on prev(j), t on j), the edges
  // kept running from start to end. An edge its corners trim past its length (start >= end: an
  // edge shorter than the offset eats, on the trimmed side) makes a small loop that
  // ClipperOffset's union cuts off: where its corners are points on both offset lines (trimmed or
  // mitred), it is dropped and the lines of its neighbours cross instead, one edge at a time while
  // its neighbours keep their direction (two reversed side by side would need the order in which
  // they vanished: ClipperOffset resolves those).
  std::vector<double> start(n, 0.0), end(n, 1.0);
  std::vector<cl::IntPoint> trim_point(n);
  std::vector<std::size_t> prev(n), next(n);
  for (std::size_t j = 0; j < n; ++j)
    prev[j] = j == 0 ? n - 1 : j - 1, next[j] = j + 1 == n ? 0 : j + 1;
  // Raw edge e's ends, unrounded (they do not move when neighbours are dropped).
  auto raw = [&](std::size_t e, Normal& a, Normal& b) {
    const Corner& from = c[e];
    const Corner& to = c[e + 1 == n ? 0 : e + 1];
    a = from.exact_last;
    b = to.exact_first;
  };
  // Trimmed corner between raw edges k and j (j follows k): false where they do not cross on the
  // corner's side (a raw edge that ends before the crossing would leave the union a spike).
  auto cross_at = [&](std::size_t k, std::size_t j) {
    Normal p0, p1, q0, q1;
    raw(k, p0, p1);
    raw(j, q0, q1);
    const double rx = p1.x - p0.x, ry = p1.y - p0.y;
    const double sx = q1.x - q0.x, sy = q1.y - q0.y;
    const double den = rx * sy - ry * sx;
    if (den == 0) return false;
    const double wx = q0.x - p0.x, wy = q0.y - p0.y;
    const double u = (wx * sy - wy * sx) / den, t = (wx * ry - wy * rx) / den;
    if (!(u <= 1 && t >= 0 && std::isfinite(u) && std::isfinite(t))) return false;
    end[k] = u;
    start[j] = t;
    trim_point[j] = {static_cast<cl::cInt>(round_ll(p0.x + u * rx)),
                     static_cast<cl::cInt>(round_ll(p0.y + u * ry))};
    return true;
  };
  for (std::size_t j = 0; j < n; ++j)
    if (c[j].trim && !cross_at(prev[j], j)) return false;
  std::vector<std::size_t> reversed;
  for (std::size_t j = 0; j < n; ++j)
    if (!(start[j] < end[j])) reversed.push_back(j);
  std::vector<char> alive(n, 1);
  std::size_t left = n;
  while (!reversed.empty()) {
    const std::size_t j = reversed.back();
    reversed.pop_back();
    if (!alive[j] || start[j] < end[j]) continue;
    const std::size_t k = prev[j], m = next[j];
    if (!c[j].lines_meet || !c[m].lines_meet || k == m) return false;
    if (!(start[k] < end[k]) || !(start[m] < end[m])) return false;
    alive[j] = 0;
    if (--left < 3) return false;
    next[k] = m;
    prev[m] = k;
    if (!cross_at(k, m)) return false;
    c[m].trim = true;  // (a mitred corner's edges now cross: it is trimmed at trim_point)
    if (!(start[k] < end[k])) reversed.push_back(k);
    if (!(start[m] < end[m])) reversed.push_back(m);
  }
  out.clear();
  out.reserve(left + 4);
  std::size_t first = 0;
  while (!alive[first]) ++first;
  for (std::size_t j = first, count = 0; count < left; j = next[j], ++count) {
    const cl::IntPoint p = c[j].trim ? trim_point[j] : c[j].first;
    if (out.empty() || !(out.back() == p)) out.push_back(p);
    if (!c[j].trim && !(out.back() == c[j].last)) out.push_back(c[j].last);
  }
  while (out.size() > 1 && out.front() == out.back()) out.pop_back();
  return out.size() >= 3;
}

// Neighbours in a ring (edges lo < hi of a ring of m) share one point; they meet elsewhere only
// if the second folds back along the first.
bool neighbours_fold(const cl::Path& r, std::uint32_t lo, std::uint32_t hi, bool& neighbours) {
  const std::size_t m = r.size();
  neighbours = hi == lo + 1 || (lo == 0 && hi + 1 == m);
  if (!neighbours) return false;
  const bool wrap = hi != lo + 1;
  const std::uint32_t e1 = wrap ? hi : lo, e2 = wrap ? lo : hi;
  const cl::IntPoint& a = r[e1];
  const cl::IntPoint& b = r[e1 + 1 == m ? 0 : e1 + 1];
  const cl::IntPoint& c = r[e2];
  const cl::IntPoint& d = r[e2 + 1 == m ? 0 : e2 + 1];
  return orient(a, b, d) == 0 && static_cast<__int128>(b.X - a.X) * (d.X - c.X) +
                                         static_cast<__int128>(b.Y - a.Y) * (d.Y - c.Y) <
                                     0;
}

// The edges' boxes swept along x (sorted by their left side): each edge is tested against those
// whose boxes meet its own. -1 where that takes more than `budget` box tests (many edges side by
// side along x), else whether two edges meet.
int rings_meet_swept(const cl::Paths& rings, std::size_t budget) {
  struct Edge {
    cl::cInt x0, x1, y0, y1;
    std::uint32_t ring, edge;
  };
  thread_local std::vector<Edge> edges;
  edges.clear();
  for (std::uint32_t ri = 0; ri < rings.size(); ++ri) {
    const auto& r = rings[ri];
    for (std::uint32_t e = 0; e < r.size(); ++e) {
      const cl::IntPoint& a = r[e];
      const cl::IntPoint& b = r[e + 1 == r.size() ? 0 : e + 1];
      edges.push_back(
          {std::min(a.X, b.X), std::max(a.X, b.X), std::min(a.Y, b.Y), std::max(a.Y, b.Y), ri, e});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const Edge& p, const Edge& q) { return p.x0 < q.x0; });
  std::size_t tests = 0;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Edge& p = edges[i];
    for (std::size_t j = i + 1; j < edges.size() && edges[j].x0 <= p.x1; ++j) {
      if (++tests > budget) return -1;
      const Edge& q = edges[j];
      if (q.y0 > p.y1 || p.y0 > q.y1) continue;
      if (p.ring == q.ring) {
        bool neighbours = false;
        if (neighbours_fold(rings[p.ring], std::min(p.edge, q.edge), std::max(p.edge, q.edge),
                            neighbours))
          return 1;
        if (neighbours) continue;
      }
      const auto& rp = rings[p.ring];
      const auto& rq = rings[q.ring];
      if (segments_meet(rp[p.edge], rp[p.edge + 1 == rp.size() ? 0 : p.edge + 1], rq[q.edge],
                        rq[q.edge + 1 == rq.size() ? 0 : q.edge + 1]))
        return 1;
    }
  }
  return 0;
}

}  // namespace

bool rings_meet(const cl::Paths& rings, bool& gave_up, bool sweep) {
  gave_up = false;
  std::size_t edges = 0;
  cl::cInt x0 = rings[0][0].X, y0 = rings[0][0].Y, x1 = x0, y1 = y0;
  for (const auto& r : rings) {
    edges += r.size();
    for (const auto& p : r)
      x0 = std::min(x0, p.X), y0 = std::min(y0, p.Y), x1 = std::max(x1, p.X),
      y1 = std::max(y1, p.Y);
  }
  const double w = static_cast<double>(x1 - x0) + 1, h = static_cast<double>(y1 - y0) + 1;
  const double cell = std::max(std::sqrt(w * h / static_cast<double>(edges)) * 2, 1.0);
  const long nx = static_cast<long>(w / cell) + 1, ny = static_cast<long>(h / cell) + 1;
  auto span = [&](const cl::IntPoint& a, const cl::IntPoint& b, long& cx0, long& cx1, long& cy0,
                  long& cy1) {
    cx0 = static_cast<long>(static_cast<double>(std::min(a.X, b.X) - x0) / cell);
    cx1 = static_cast<long>(static_cast<double>(std::max(a.X, b.X) - x0) / cell);
    cy0 = static_cast<long>(static_cast<double>(std::min(a.Y, b.Y) - y0) / cell);
    cy1 = static_cast<long>(static_cast<double>(std::max(a.Y, b.Y) - y0) / cell);
  };
  const std::size_t limit = 16 * edges + 64;
  {
    std::size_t entries = 0;
    for (const auto& r : rings)
      for (std::size_t e = 0; e < r.size(); ++e) {
        long cx0, cx1, cy0, cy1;
        span(r[e], r[e + 1 == r.size() ? 0 : e + 1], cx0, cx1, cy0, cy1);
        entries += static_cast<std::size_t>((cx1 - cx0 + 1) * (cy1 - cy0 + 1));
        if (entries > limit) {
          gave_up = true;
          return true;
        }
      }
  }
  const int swept = sweep ? rings_meet_swept(rings, 8 * edges + 256) : -1;
  if (swept >= 0) return swept == 1;
  struct Hit {
    std::uint32_t cell, ring, edge;
  };
  std::vector<Hit> hits;
  hits.reserve(3 * edges);
  for (std::uint32_t ri = 0; ri < rings.size(); ++ri) {
    const auto& r = rings[ri];
    for (std::uint32_t e = 0; e < r.size(); ++e) {
      long cx0, cx1, cy0, cy1;
      span(r[e], r[e + 1 == r.size() ? 0 : e + 1], cx0, cx1, cy0, cy1);
      for (long y = cy0; y <= cy1; ++y)
        for (long x = cx0; x <= cx1; ++x)
          hits.push_back({static_cast<std::uint32_t>(y * nx + x), ri, e});
    }
  }
  (void)ny;
  std::sort(hits.begin(), hits.end(), [](const Hit& p, const Hit& q) { return p.cell < q.cell; });
  auto seg = [&](const Hit& h, cl::IntPoint& a, cl::IntPoint& b) {
    const auto& r = rings[h.ring];
    a = r[h.edge];
    b = r[h.edge + 1 == r.size() ? 0 : h.edge + 1];
  };
  for (std::size_t i = 0; i < hits.size();) {
    std::size_t j = i;
    while (j < hits.size() && hits[j].cell == hits[i].cell) ++j;
    for (std::size_t p = i; p < j; ++p)
      for (std::size_t q = p + 1; q < j; ++q) {
        const Hit& hp = hits[p];
        const Hit& hq = hits[q];
        if (hp.ring == hq.ring) {
          bool neighbours = false;
          if (neighbours_fold(rings[hp.ring], std::min(hp.edge, hq.edge),
                              std::max(hp.edge, hq.edge), neighbours))
            return true;
          if (neighbours) continue;
        }
        cl::IntPoint a, b, c, d;
        seg(hp, a, b);
        seg(hq, c, d);
        if (segments_meet(a, b, c, d)) return true;
      }
    i = j;
  }
  return false;
}

namespace {

// 1 inside, 0 outside (p is off the ring's edges: the rings do not meet).
bool inside(const cl::Path& ring, const cl::IntPoint& p) {
  bool in = false;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    const cl::IntPoint& a = ring[j];
    const cl::IntPoint& b = ring[i];
    if ((a.Y > p.Y) != (b.Y > p.Y)) {
      const __int128 side = orient(a, b, p);
      if ((side > 0) == (b.Y > a.Y)) in = !in;
    }
  }
  return in;
}

struct Box {
  cl::cInt x0, y0, x1, y1;
};
Box box_of(const cl::Path& r) {
  Box b{r[0].X, r[0].Y, r[0].X, r[0].Y};
  for (const auto& p : r)
    b.x0 = std::min(b.x0, p.X), b.y0 = std::min(b.y0, p.Y), b.x1 = std::max(b.x1, p.X),
    b.y1 = std::max(b.y1, p.Y);
  return b;
}
bool may_hold(const Box& out, const Box& in) {
  return out.x0 <= in.x0 && out.y0 <= in.y0 && out.x1 >= in.x1 && out.y1 >= in.y1;
}

}  // namespace

bool offset_directly(const cl::Paths& rings, double delta, double miter_limit, cl::Paths& out) {
  out.clear();
  if (rings.empty() || delta == 0) return false;
  constexpr std::size_t kMaxRings = 64;  // the containment check is quadratic in rings
  if (rings.size() > kMaxRings) return false;
  const double miter_lim = miter_limit > 2 ? 2 / (miter_limit * miter_limit) : 0.5;
  out.resize(rings.size());
  for (std::size_t i = 0; i < rings.size(); ++i) {
    if (rings[i].size() < 3 || !offset_ring(rings[i], delta, miter_lim, out[i])) return false;
    // Each ring keeps its orientation.
    if ((cl::Area(out[i]) > 0) != (cl::Area(rings[i]) > 0)) return false;
  }
  bool gave_up = false;
  if (rings_meet(out, gave_up)) return false;
  // Rings that do not meet nest as before: the same ring holds each ring's first point.
  std::vector<Box> before(rings.size()), after(rings.size());
  for (std::size_t i = 0; i < rings.size(); ++i)
    before[i] = box_of(rings[i]), after[i] = box_of(out[i]);
  for (std::size_t i = 0; i < rings.size(); ++i)
    for (std::size_t j = 0; j < rings.size(); ++j) {
      if (i == j) continue;
      const bool was = may_hold(before[j], before[i]) && inside(rings[j], rings[i][0]);
      const bool is = may_hold(after[j], after[i]) && inside(out[j], out[i][0]);
      if (was != is) return false;
    }
  return true;
}

}  // namespace trellis::clipper_util
