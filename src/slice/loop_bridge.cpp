// Closed loops joined by bridges (src/slice/loop_bridge.hpp).
#include "loop_bridge.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <unordered_map>

namespace trellis {

namespace {

double dist(Vec2 a, Vec2 b) {
  return std::hypot(b.x - a.x, b.y - a.y);
}
double dot(Vec2 a, Vec2 b) {
  return a.x * b.x + a.y * b.y;
}
double cross(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}

// A strand with its arc lengths: points at parameters u in [0, L] (a closed one's modulo L).
class Arc {
 public:
  explicit Arc(const Strand& s) : pts_(&s.points), closed_(s.closed) {
    cum_.assign(pts_->size(), 0.0);
    for (std::size_t k = 1; k < pts_->size(); ++k)
      cum_[k] = cum_[k - 1] + dist((*pts_)[k - 1], (*pts_)[k]);
  }
  bool closed() const { return closed_; }
  double length() const { return cum_.empty() ? 0.0 : cum_.back(); }
  std::size_t segments() const { return pts_->size() < 2 ? 0 : pts_->size() - 1; }
  Vec2 point(std::size_t k) const { return (*pts_)[k]; }
  double at_vertex(std::size_t k) const { return cum_[k]; }
  double wrap(double u) const {
    if (!closed_) return std::clamp(u, 0.0, length());
    const double l = length();
    u = std::fmod(u, l);
    return u < 0 ? u + l : u;
  }
  std::size_t segment_of(double u) const {
    u = wrap(u);
    const auto it = std::upper_bound(cum_.begin(), cum_.end(), u);
    const auto k = static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - cum_.begin(), 1)) - 1;
    return std::min(k, segments() - 1);
  }
  Vec2 at(double u) const {
    u = wrap(u);
    const std::size_t k = segment_of(u);
    const double l = cum_[k + 1] - cum_[k];
    const double t = l > 0 ? std::clamp((u - cum_[k]) / l, 0.0, 1.0) : 0.0;
    return (*pts_)[k] + ((*pts_)[k + 1] - (*pts_)[k]) * t;
  }
  Vec2 direction(double u) const {
    const std::size_t k = segment_of(u);
    const Vec2 d = (*pts_)[k + 1] - (*pts_)[k];
    const double l = std::hypot(d.x, d.y);
    return l > 0 ? Vec2{d.x / l, d.y / l} : Vec2{1, 0};
  }
  // The distance from `from` to u going `dir` (+1 forward, -1 back; a closed strand wraps).
  double ahead(double from, double u, int dir) const {
    const double d = dir > 0 ? u - from : from - u;
    if (!closed_) return d;
    const double l = length();
    const double w = std::fmod(d, l);
    return w < 0 ? w + l : w;
  }
  // Appends the vertices strictly between parameters `from` and `to` going `dir`, then the
  // point at `to` (`span`: how far that is, which a closed strand cannot tell when to == from).
  void append(double from, double to, int dir, double span, std::vector<Vec2>& out) const {
    constexpr double kEps = 1e-9;
    const std::size_t m = closed_ ? pts_->size() - 1 : pts_->size();  // distinct vertices
    if (m > 0) {
      from = wrap(from);
      if (dir > 0) {
        std::size_t k = static_cast<std::size_t>(
            std::upper_bound(cum_.begin(), cum_.begin() + static_cast<long>(m), from) -
            cum_.begin());
        for (std::size_t n = 0; n < m; ++n, ++k) {
          if (k >= m) {
            if (!closed_) break;
            k = 0;
          }
          const double t = ahead(from, cum_[k], dir);
          if (!(t > kEps) || !(t < span - kEps)) {
            if (t >= span - kEps) break;
            continue;
          }
          out.push_back((*pts_)[k]);
        }
      } else {
        auto it = std::lower_bound(cum_.begin(), cum_.begin() + static_cast<long>(m), from);
        std::ptrdiff_t k = (it - cum_.begin()) - 1;
        for (std::size_t n = 0; n < m; ++n, --k) {
          if (k < 0) {
            if (!closed_) break;
            k = static_cast<std::ptrdiff_t>(m) - 1;
          }
          const double t = ahead(from, cum_[static_cast<std::size_t>(k)], dir);
          if (!(t > kEps) || !(t < span - kEps)) {
            if (t >= span - kEps) break;
            continue;
          }
          out.push_back((*pts_)[static_cast<std::size_t>(k)]);
        }
      }
    }
    out.push_back(at(to));
  }

 private:
  const std::vector<Vec2>* pts_;
  bool closed_;
  std::vector<double> cum_;
};

// Every segment of every strand, bucketed in square cells.
class SegmentGrid {
 public:
  SegmentGrid(const std::vector<Arc>& arcs, double cell) : arcs_(arcs), cell_(cell) {
    for (std::size_t s = 0; s < arcs.size(); ++s)
      for (std::size_t k = 0; k < arcs[s].segments(); ++k) {
        const Vec2 a = arcs[s].point(k), b = arcs[s].point(k + 1);
        for (long j = key(std::min(a.y, b.y)); j <= key(std::max(a.y, b.y)); ++j)
          for (long i = key(std::min(a.x, b.x)); i <= key(std::max(a.x, b.x)); ++i)
            cells_[pack(i, j)].push_back(
                {static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(k)});
      }
  }
  struct Seg {
    std::uint32_t strand, index;
  };
  // Each segment in the cells within `r` of p (a segment may come more than once).
  template <class Fn>
  void near(Vec2 p, double r, Fn&& fn) const {
    for (long j = key(p.y - r); j <= key(p.y + r); ++j)
      for (long i = key(p.x - r); i <= key(p.x + r); ++i) {
        const auto it = cells_.find(pack(i, j));
        if (it == cells_.end()) continue;
        for (const Seg& s : it->second) fn(s);
      }
  }
  // Whether segment a-b crosses a segment of a strand other than x and y.
  bool crosses(Vec2 a, Vec2 b, std::size_t x, std::size_t y) const {
    const Vec2 m = (a + b) * 0.5;
    bool hit = false;
    near(m, 0.5 * dist(a, b) + 1e-9, [&](const Seg& s) {
      if (hit || s.strand == x || s.strand == y) return;
      const Vec2 p = arcs_[s.strand].point(s.index), q = arcs_[s.strand].point(s.index + 1);
      const Vec2 r = b - a, t = q - p;
      const double den = cross(r, t);
      if (std::abs(den) < 1e-18) return;
      const double u = cross(p - a, t) / den, v = cross(p - a, r) / den;
      if (u >= 0 && u <= 1 && v >= 0 && v <= 1) hit = true;
    });
    return hit;
  }

 private:
  long key(double v) const { return static_cast<long>(std::floor(v / cell_)); }
  static std::uint64_t pack(long i, long j) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) |
           static_cast<std::uint32_t>(j);
  }
  const std::vector<Arc>& arcs_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<Seg>> cells_;
};

// A bridge between strands a and b: connector 1 from a's u1 to b's v1, connector 2 from a's u2
// (u1 + its span, forward) to b's v2.
struct Bridge {
  std::size_t a, b;
  double u1, u2, v1, v2;
  double cost;
};

// A stretch [lo, lo + len] of a strand (a closed one's modulo its length).
struct Stretch {
  double lo, len;
};
bool overlaps(const Stretch& x, const Stretch& y, double period) {
  for (const double shift : {-period, 0.0, period}) {
    if (period <= 0 && shift != 0) continue;
    if (x.lo + shift < y.lo + y.len && y.lo < x.lo + shift + x.len) return true;
  }
  return false;
}

}  // namespace

std::vector<Strand> bridge_strands(const std::vector<Strand>& strands, const BridgeOptions& o,
                                   BridgeStats* stats) {
  const std::size_t n = strands.size();
  std::vector<Arc> arcs;
  arcs.reserve(n);
  for (const Strand& s : strands) arcs.emplace_back(s);
  const double w = o.spacing, far = o.far * w, near = o.near * w;
  const double span = w;          // each bridge leaves out about a spacing of both strands
  const double margin = 0.5 * w;  // between bridges on a strand, and from an open one's ends
  const double parallel = std::cos(o.max_turn * std::numbers::pi / 180);
  auto usable = [&](std::size_t s) {
    return arcs[s].segments() > 0 &&
           arcs[s].length() >= (arcs[s].closed() ? 4 * span : 2 * span + 4 * margin);
  };
  // Candidates: along each strand every spacing, the nearest other strand there and a span on.
  std::vector<Bridge> candidates;
  if (n > 1 && w > 0) {
    const SegmentGrid grid(arcs, far);
    struct Nearest {
      std::size_t strand = SIZE_MAX;
      double d = std::numeric_limits<double>::infinity(), u = 0;
    };
    auto nearest = [&](Vec2 p, std::size_t except, std::size_t only) {
      Nearest best;
      grid.near(p, far, [&](const SegmentGrid::Seg& s) {
        if (s.strand == except || (only != SIZE_MAX && s.strand != only)) return;
        const Arc& arc = arcs[s.strand];
        const Vec2 a = arc.point(s.index), b = arc.point(s.index + 1), d = b - a;
        const double l2 = dot(d, d);
        const double t = l2 > 0 ? std::clamp(dot(p - a, d) / l2, 0.0, 1.0) : 0.0;
        const double e = dist(p, a + d * t);
        if (e < best.d) {
          best = {
              s.strand, e,
              arc.at_vertex(s.index) + t * (arc.at_vertex(s.index + 1) - arc.at_vertex(s.index))};
        }
      });
      return best;
    };
    for (std::size_t a = 0; a < n; ++a) {
      if (!usable(a)) continue;
      const Arc& A = arcs[a];
      const double l = A.length();
      const double first = A.closed() ? 0.0 : margin, last = A.closed() ? l : l - margin - span;
      for (double u = first; u < last; u += w) {
        const Vec2 p1 = A.at(u), p2 = A.at(u + span);
        const Vec2 t1 = A.direction(u), t2 = A.direction(u + span);
        if (dot(t1, t2) < parallel) continue;  // a bend: no bridge across it
        const Nearest q1 = nearest(p1, a, SIZE_MAX);
        if (q1.strand == SIZE_MAX || q1.d < near || q1.d > far) continue;
        const std::size_t b = q1.strand;
        if (!usable(b)) continue;
        const Nearest q2 = nearest(p2, a, SIZE_MAX);
        if (q2.strand != b || q2.d < near || q2.d > far) continue;  // another strand between
        const Arc& B = arcs[b];
        if (std::abs(dot(t1, B.direction(q1.u))) < parallel ||
            std::abs(dot(t2, B.direction(q2.u))) < parallel)
          continue;
        // The span on b: short, and clear of an open strand's ends.
        const double fwd = B.ahead(q1.u, q2.u, 1), bwd = B.ahead(q1.u, q2.u, -1);
        const double along = std::min(fwd, bwd);
        if (along < 0.5 * span || along > 2 * span) continue;
        if (!B.closed() &&
            (std::min(q1.u, q2.u) < margin || std::max(q1.u, q2.u) > B.length() - margin))
          continue;
        const Vec2 b1 = B.at(q1.u), b2 = B.at(q2.u);
        if (grid.crosses(p1, b1, a, b) || grid.crosses(p2, b2, a, b)) continue;
        // The two connectors must not cross each other.
        {
          const Vec2 r = b1 - p1, s = b2 - p2;
          const double den = cross(r, s);
          if (std::abs(den) > 1e-18) {
            const double x = cross(p2 - p1, s) / den, y = cross(p2 - p1, r) / den;
            if (x >= 0 && x <= 1 && y >= 0 && y <= 1) continue;
          }
        }
        candidates.push_back({a, b, A.wrap(u), A.wrap(u + span), q1.u, q2.u,
                              std::abs(q1.d - w) + std::abs(q2.d - w)});
      }
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Bridge& x, const Bridge& y) {
    if (x.cost != y.cost) return x.cost < y.cost;
    if (x.a != y.a) return x.a < y.a;
    if (x.b != y.b) return x.b < y.b;
    return x.u1 < y.u1;
  });
  // A spanning forest, cheapest first: never two open strands in one tree, never two bridges
  // on one stretch of a strand.
  std::vector<std::size_t> root(n);
  std::vector<char> open(n, 0), stay(n, 0);
  for (std::size_t s = 0; s < n; ++s)
    root[s] = s, open[s] = !strands[s].closed, stay[s] = strands[s].stay_closed;
  auto find = [&](std::size_t s) {
    while (root[s] != s) s = root[s] = root[root[s]];
    return s;
  };
  std::vector<std::vector<Stretch>> taken(n);
  auto free = [&](std::size_t s, const Stretch& x) {
    const double period = arcs[s].closed() ? arcs[s].length() : 0.0;
    return std::none_of(taken[s].begin(), taken[s].end(),
                        [&](const Stretch& y) { return overlaps(x, y, period); });
  };
  auto stretch_on_b = [&](const Bridge& c) {
    const Arc& B = arcs[c.b];
    const double fwd = B.ahead(c.v1, c.v2, 1);
    const double lo = fwd <= B.ahead(c.v1, c.v2, -1) ? c.v1 : c.v2;
    return Stretch{lo - margin, std::min(fwd, B.ahead(c.v1, c.v2, -1)) + 2 * margin};
  };
  std::vector<Bridge> bridges;
  for (const Bridge& c : candidates) {
    const std::size_t ra = find(c.a), rb = find(c.b);
    if (ra == rb || (open[ra] && (open[rb] || stay[rb])) || (open[rb] && stay[ra])) continue;
    const Stretch sa{c.u1 - margin, span + 2 * margin}, sb = stretch_on_b(c);
    if (!free(c.a, sa) || !free(c.b, sb)) continue;
    taken[c.a].push_back(sa);
    taken[c.b].push_back(sb);
    root[ra] = rb;
    open[rb] = open[rb] || open[ra];
    stay[rb] = stay[rb] || stay[ra];
    bridges.push_back(c);
  }
  // Each tree walked from its root (its open strand, else its first strand): round each strand,
  // over each bridge to the strand beyond and round it, back, on.
  std::vector<std::vector<std::size_t>> at(n);  // bridges on each strand
  for (std::size_t k = 0; k < bridges.size(); ++k) {
    at[bridges[k].a].push_back(k);
    at[bridges[k].b].push_back(k);
  }
  struct Walker {
    const std::vector<Arc>& arcs;
    const std::vector<Bridge>& bridges;
    const std::vector<std::vector<std::size_t>>& at;
    std::vector<Vec2> out;
    // Strand s from `from` to `to` going `dir` over `length` of it, not over `parent`.
    void walk(std::size_t s, double from, double to, int dir, double length, std::size_t parent) {
      const Arc& arc = arcs[s];
      struct Event {
        double t, enter, leave, other_enter, other_leave;
        std::size_t other, bridge;
      };
      std::vector<Event> events;
      for (const std::size_t k : at[s]) {
        if (k == parent) continue;
        const Bridge& br = bridges[k];
        const bool mine_a = br.a == s;
        const double f1 = mine_a ? br.u1 : br.v1, f2 = mine_a ? br.u2 : br.v2;
        const double g1 = mine_a ? br.v1 : br.u1, g2 = mine_a ? br.v2 : br.u2;
        const double t1 = arc.ahead(from, f1, dir), t2 = arc.ahead(from, f2, dir);
        if (t1 <= t2)
          events.push_back({t1, f1, f2, g1, g2, mine_a ? br.b : br.a, k});
        else
          events.push_back({t2, f2, f1, g2, g1, mine_a ? br.b : br.a, k});
      }
      std::sort(events.begin(), events.end(),
                [](const Event& x, const Event& y) { return x.t < y.t; });
      out.push_back(arc.at(from));
      double here = from;
      for (std::size_t e = 0; e < events.size(); ++e) {
        const Event& ev = events[e];
        arc.append(here, ev.enter, dir, arc.ahead(here, ev.enter, dir), out);
        // The strand beyond, entered at other_enter, round the long way to other_leave.
        const Arc& other = arcs[ev.other];
        const double fwd = other.ahead(ev.other_enter, ev.other_leave, 1);
        const double bwd = other.ahead(ev.other_enter, ev.other_leave, -1);
        const int odir = fwd < bwd ? -1 : 1;  // away from the bridge's own span
        walk(ev.other, ev.other_enter, ev.other_leave, odir, odir > 0 ? fwd : bwd, ev.bridge);
        out.push_back(arc.at(ev.leave));
        here = ev.leave;
      }
      const double rest = events.empty() ? length : arc.ahead(here, to, dir);
      arc.append(here, to, dir, events.empty() ? length : (rest > 0 ? rest : length), out);
    }
  };
  std::vector<Strand> result;
  std::vector<char> walked(n, 0);
  // Roots: a tree's open strand, else its lowest strand.
  std::vector<std::size_t> tree_root(n, SIZE_MAX);
  for (std::size_t s = 0; s < n; ++s) {
    const std::size_t r = find(s);
    if (tree_root[r] == SIZE_MAX || (!strands[s].closed && strands[tree_root[r]].closed))
      tree_root[r] = s;
  }
  for (std::size_t s = 0; s < n; ++s) {
    const std::size_t r = find(s);
    if (walked[r]) continue;
    walked[r] = 1;
    const std::size_t start = tree_root[r];
    const Arc& arc = arcs[start];
    Walker walker{arcs, bridges, at, {}};
    if (arc.segments() == 0) continue;
    walker.walk(start, 0.0, arc.closed() ? 0.0 : arc.length(), 1, arc.length(), SIZE_MAX);
    Strand joined;
    joined.closed = strands[start].closed;
    for (const Vec2 q : walker.out)
      if (joined.points.empty() || dist(joined.points.back(), q) > 1e-9) joined.points.push_back(q);
    if (joined.closed && joined.points.size() > 1 &&
        dist(joined.points.front(), joined.points.back()) > 1e-9)
      joined.points.push_back(joined.points.front());
    result.push_back(std::move(joined));
  }
  if (stats) {
    stats->strands += n;
    stats->bridges += bridges.size();
    stats->results += result.size();
  }
  return result;
}

}  // namespace trellis
