// The linking stage's and the outline simplification's fast paths against plain references
// written here the long way (each edge tested, atan2 at every vertex, fmod and a binary search
// for the points along a ring, every 2-opt cost measured from scratch, hypot for every point,
// Douglas-Peucker through simplify_polyline): the same answers, to the bit, on seeded random
// inputs with the ties and degeneracies that real outlines have (points on a coarse grid, so rays
// pass through vertices and segments along edges; regular polygons, whose vertices lie at equal
// distances; repeated points, straight runs, hairpins).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <tuple>

#include "support/random_regions.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/link.hpp"
#include "trellis/toolpath/order.hpp"

using namespace trellis;
using test::random_region;

namespace {

constexpr double kPi = std::numbers::pi;

double cross2(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}
double len2d(Vec2 a) {
  return std::sqrt(a.x * a.x + a.y * a.y);
}

// ---------------------------------------------------------------- references

// The aligned seam as first written: every turn by atan2, the points along the ring by fmod and
// upper_bound.
std::size_t ref_aligned_seam(const std::vector<Vec2>& ring) {
  const std::size_t n = ring.size();
  if (n == 0) return 0;
  auto rear = [&](std::size_t a, std::size_t b) {
    if (ring[a].y != ring[b].y) return ring[a].y > ring[b].y;
    if (ring[a].x != ring[b].x) return ring[a].x < ring[b].x;
    return a < b;
  };
  auto rear_most = [&] {
    std::size_t best = 0;
    for (std::size_t i = 1; i < n; ++i)
      if (rear(i, best)) best = i;
    return best;
  };
  std::vector<double> cum(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) cum[i + 1] = cum[i] + len2d(ring[(i + 1) % n] - ring[i]);
  const double perimeter = cum[n];
  if (!(perimeter > 0)) return rear_most();
  const double reach = std::min(0.8, perimeter / 8);
  auto point_at = [&](double s) {
    s = std::fmod(s, perimeter);
    if (s < 0) s += perimeter;
    const std::size_t i =
        static_cast<std::size_t>(std::upper_bound(cum.begin(), cum.end(), s) - cum.begin()) - 1;
    const std::size_t k = std::min(i, n - 1);
    const double l = cum[k + 1] - cum[k];
    const double t = l > 0 ? (s - cum[k]) / l : 0;
    return ring[k] + (ring[(k + 1) % n] - ring[k]) * t;
  };
  std::vector<double> turn(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 a = point_at(cum[i] - reach), b = ring[i], c = point_at(cum[i] + reach);
    const Vec2 u = b - a, v = c - b;
    if (len2d(u) < 1e-9 || len2d(v) < 1e-9) continue;
    turn[i] = std::atan2(cross2(u, v), u.x * v.x + u.y * v.y) * 180 / kPi;
  }
  auto sharpest = [&](double sign, double limit) -> long {
    double top = limit;
    for (std::size_t i = 0; i < n; ++i) top = std::max(top, sign * turn[i]);
    if (top <= limit) return -1;
    long best = -1;
    for (std::size_t i = 0; i < n; ++i)
      if (sign * turn[i] >= top - 5 && (best < 0 || rear(i, static_cast<std::size_t>(best))))
        best = static_cast<long>(i);
    return best;
  };
  if (const long c = sharpest(-1, 30); c >= 0) return static_cast<std::size_t>(c);
  if (const long c = sharpest(1, 60); c >= 0) return static_cast<std::size_t>(c);
  return rear_most();
}

// Even-odd inside over every edge of every ring (the test Comb makes of each edge).
bool ref_inside(const Regions& r, Vec2 p) {
  bool in = false;
  for (const auto& poly : r) {
    std::vector<const std::vector<Vec2>*> rings;
    if (poly.outer.size() >= 3) rings.push_back(&poly.outer);
    for (const auto& h : poly.holes)
      if (h.size() >= 3) rings.push_back(&h);
    for (const auto* ring : rings)
      for (std::size_t i = 0; i < ring->size(); ++i) {
        const Vec2 u = (*ring)[i], v = (*ring)[(i + 1) % ring->size()];
        if ((u.y > p.y) != (v.y > p.y) && p.x < (v.x - u.x) * (p.y - u.y) / (v.y - u.y) + u.x)
          in = !in;
      }
  }
  return in;
}

// Whether a-b crosses any edge (the crossing test Comb makes of each edge).
bool ref_crosses(const Regions& r, Vec2 a, Vec2 b) {
  for (const auto& poly : r) {
    std::vector<const std::vector<Vec2>*> rings;
    if (poly.outer.size() >= 3) rings.push_back(&poly.outer);
    for (const auto& h : poly.holes)
      if (h.size() >= 3) rings.push_back(&h);
    for (const auto* ring : rings)
      for (std::size_t i = 0; i < ring->size(); ++i) {
        const Vec2 ea = (*ring)[i], eb = (*ring)[(i + 1) % ring->size()];
        const Vec2 rr = b - a, s = eb - ea;
        const double d = cross2(rr, s);
        if (std::abs(d) < 1e-300) continue;
        const double t = cross2(ea - a, s) / d, u = cross2(ea - a, rr) / d;
        if (t >= 0 && t <= 1 && u >= 0 && u <= 1) return true;
      }
  }
  return false;
}

// Nearest neighbour by brute force (ties: the lower index, its start first), then 2-opt with
// every cost measured from the order itself.
std::vector<OrderStep> ref_order(const std::vector<OrderItem>& items, Vec3 from) {
  const std::size_t n = items.size();
  std::vector<char> taken(n, 0);
  std::vector<OrderStep> order;
  Vec3 at = from;
  for (std::size_t step = 0; step < n; ++step) {
    double best = 1e300;
    OrderStep pick{static_cast<std::size_t>(-1), false};
    for (std::size_t i = 0; i < n; ++i) {
      if (taken[i]) continue;
      for (const bool rev : {false, true}) {
        if (rev && !items[i].reversible) continue;
        const double d = distance(at, rev ? items[i].end : items[i].start);
        if (std::tie(d, i, rev) < std::tie(best, pick.item, pick.reversed)) {
          best = d;
          pick = {i, rev};
        }
      }
    }
    taken[pick.item] = 1;
    order.push_back(pick);
    at = pick.reversed ? items[pick.item].start : items[pick.item].end;
  }
  if (n < 3) return order;
  auto s = [&](std::size_t i) {
    const OrderItem& it = items[order[i].item];
    return order[i].reversed ? it.end : it.start;
  };
  auto e = [&](std::size_t i) {
    const OrderItem& it = items[order[i].item];
    return order[i].reversed ? it.start : it.end;
  };
  std::vector<std::size_t> fixed_before(n + 1, 0);
  bool any_fixed = false;
  for (std::size_t k = 0; k < n; ++k) {
    fixed_before[k + 1] = fixed_before[k] + (items[order[k].item].reversible ? 0 : 1);
    any_fixed = any_fixed || !items[order[k].item].reversible;
  }
  const std::size_t window = n > 2000 ? 64 : n;
  for (int pass = 0; pass < 20; ++pass) {
    bool improved = false;
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const Vec3 before = i == 0 ? from : e(i - 1);
      for (std::size_t j = i + 1; j < n && j - i <= window; ++j) {
        if (any_fixed && fixed_before[j + 1] != fixed_before[i]) break;
        double old_cost = distance(before, s(i));
        double new_cost = distance(before, e(j));
        if (j + 1 < n) {
          old_cost += distance(e(j), s(j + 1));
          new_cost += distance(s(i), s(j + 1));
        }
        if (new_cost < old_cost - 1e-9) {
          std::reverse(order.begin() + static_cast<long>(i),
                       order.begin() + static_cast<long>(j) + 1);
          for (std::size_t k = i; k <= j; ++k) order[k].reversed = !order[k].reversed;
          improved = true;
        }
      }
    }
    if (!improved) break;
  }
  return order;
}

// connect_fill as first written, with each line end's boundary edge found by testing every edge
// of every ring: the nearest within the tolerance, the last of equals in ring order.
std::vector<std::vector<Vec2>> ref_connect_fill(const std::vector<std::vector<Vec2>>& lines,
                                                const Regions& region, double max_connector,
                                                double tolerance) {
  std::vector<const std::vector<Vec2>*> rings;
  for (const auto& poly : region) {
    if (poly.outer.size() >= 3) rings.push_back(&poly.outer);
    for (const auto& h : poly.holes)
      if (h.size() >= 3) rings.push_back(&h);
  }
  std::vector<std::vector<double>> cum(rings.size());
  for (std::size_t r = 0; r < rings.size(); ++r) {
    const auto& ring = *rings[r];
    cum[r].assign(ring.size() + 1, 0.0);
    for (std::size_t i = 0; i < ring.size(); ++i)
      cum[r][i + 1] = cum[r][i] + len2d(ring[(i + 1) % ring.size()] - ring[i]);
  }
  struct End {
    long ring = -1;
    std::size_t edge = 0;
    double s = 0;
  };
  const std::size_t n = lines.size();
  std::vector<End> ends(2 * n);
  for (std::size_t key = 0; key < 2 * n; ++key) {
    const auto& line = lines[key / 2];
    if (line.size() < 2) continue;
    const Vec2 p = key % 2 ? line.back() : line.front();
    double best = tolerance;
    for (std::size_t r = 0; r < rings.size(); ++r)
      for (std::size_t i = 0; i < rings[r]->size(); ++i) {  // ring order: the last of equals
        const Vec2 a = (*rings[r])[i], b = (*rings[r])[(i + 1) % rings[r]->size()];
        double t = 0;
        const double d = distance_to_segment({p.x, p.y, 0}, {a.x, a.y, 0}, {b.x, b.y, 0}, &t);
        if (d <= best) {
          best = d;
          ends[key] = {static_cast<long>(r), i, cum[r][i] + t * (cum[r][i + 1] - cum[r][i])};
        }
      }
  }
  std::vector<std::vector<std::size_t>> on_ring(rings.size());
  for (std::size_t key = 0; key < 2 * n; ++key)
    if (ends[key].ring >= 0) on_ring[static_cast<std::size_t>(ends[key].ring)].push_back(key);
  std::vector<std::size_t> slot(2 * n, 0);
  for (auto& v : on_ring) {
    std::sort(v.begin(), v.end(), [&](std::size_t a, std::size_t b) {
      return std::tie(ends[a].s, a) < std::tie(ends[b].s, b);
    });
    for (std::size_t j = 0; j < v.size(); ++j) slot[v[j]] = j;
  }
  auto neighbour = [&](std::size_t key, bool forward, double& length) -> long {
    const End& e = ends[key];
    if (e.ring < 0) return -1;
    const auto& v = on_ring[static_cast<std::size_t>(e.ring)];
    if (v.size() < 2) return -1;
    const std::size_t m = v.size(), j = slot[key];
    const std::size_t other = v[forward ? (j + 1) % m : (j + m - 1) % m];
    double d = forward ? ends[other].s - e.s : e.s - ends[other].s;
    if (forward ? j + 1 == m : j == 0) d += cum[static_cast<std::size_t>(e.ring)].back();
    length = d;
    return static_cast<long>(other);
  };
  auto connector = [&](std::size_t from, std::size_t to, bool forward, std::vector<Vec2>& out) {
    const End& a = ends[from];
    const End& b = ends[to];
    const auto& ring = *rings[static_cast<std::size_t>(a.ring)];
    const std::size_t m = ring.size();
    std::size_t count = forward ? (b.edge + m - a.edge) % m : (a.edge + m - b.edge) % m;
    if (count == 0 && (forward ? b.s < a.s : b.s > a.s)) count = m;
    for (std::size_t k = forward ? 1 : 0; forward ? k <= count : k < count; ++k)
      out.push_back(forward ? ring[(a.edge + k) % m] : ring[(a.edge + m - k) % m]);
  };
  auto append_line = [&](std::vector<Vec2>& chain, std::size_t entry) {
    const auto& line = lines[entry / 2];
    if (entry % 2 == 0)
      chain.insert(chain.end(), line.begin(), line.end());
    else
      chain.insert(chain.end(), line.rbegin(), line.rend());
  };
  std::vector<char> used(n, 0);
  auto usable = [&](std::size_t key, bool forward, double& length) -> long {
    const long other = neighbour(key, forward, length);
    if (other < 0) return -1;
    const std::size_t line = static_cast<std::size_t>(other) / 2;
    if (line == key / 2 || used[line] || !(max_connector > 0) || length > max_connector) return -1;
    return other;
  };
  auto options = [&](std::size_t key) {
    double l = 0;
    return (usable(key, true, l) >= 0 ? 1 : 0) + (usable(key, false, l) >= 0 ? 1 : 0);
  };
  auto extend = [&](std::vector<Vec2>& chain, std::size_t exit) {
    for (;;) {
      double lf = 0, lb = 0;
      const long f = usable(exit, true, lf), b = usable(exit, false, lb);
      if (f < 0 && b < 0) return;
      const bool forward = f >= 0 && (b < 0 || lf <= lb);
      const std::size_t entry = static_cast<std::size_t>(forward ? f : b);
      connector(exit, entry, forward, chain);
      append_line(chain, entry);
      used[entry / 2] = 1;
      exit = entry ^ 1;
    }
  };
  std::vector<std::vector<Vec2>> chains;
  for (std::size_t i = 0; i < n; ++i) {
    if (used[i] || lines[i].size() < 2) continue;
    used[i] = 1;
    const std::size_t entry = options(2 * i + 1) < options(2 * i) ? 2 * i + 1 : 2 * i;
    std::vector<Vec2> chain;
    append_line(chain, entry);
    extend(chain, entry ^ 1);
    if (options(entry) > 0) {
      std::reverse(chain.begin(), chain.end());
      extend(chain, entry);
    }
    chains.push_back(std::move(chain));
  }
  return chains;
}

// ---------------------------------------------------------------- the comb's route, with a grid

long ref_floor_long(double v) {
  return v >= 0 ? static_cast<long>(v) : static_cast<long>(std::floor(v));
}

struct RingBounds {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  std::size_t edges = 0;
};
RingBounds ring_bounds(const std::vector<const std::vector<Vec2>*>& rings) {
  RingBounds b;
  for (const auto* r : rings) {
    b.edges += r->size();
    for (const Vec2 p : *r)
      b.x0 = std::min(b.x0, p.x), b.y0 = std::min(b.y0, p.y), b.x1 = std::max(b.x1, p.x),
      b.y1 = std::max(b.y1, p.y);
  }
  return b;
}

bool ref_segments_cross(Vec2 p, Vec2 q, Vec2 a, Vec2 b, double& t, double& u) {
  const Vec2 r = q - p, s = b - a;
  const double d = cross2(r, s);
  if (std::abs(d) < 1e-300) return false;
  t = cross2(a - p, s) / d;
  u = cross2(a - p, r) / d;
  return t >= 0 && t <= 1 && u >= 0 && u <= 1;
}

// The route's edge grid as the comb first built it: every edge entered into the cells along it
// and their neighbours; a travel's edges met cell by cell along it, each once.
class RingEdgeList {
 public:
  explicit RingEdgeList(const std::vector<const std::vector<Vec2>*>& rings) : rings_(rings) {}
  Vec2 a(std::uint32_t e) const { return (*rings_[edge_ids_[e].ring])[edge_ids_[e].index]; }
  Vec2 b(std::uint32_t e) const {
    const auto& ring = *rings_[edge_ids_[e].ring];
    return ring[(edge_ids_[e].index + 1) % ring.size()];
  }
  std::uint32_t ring_of(std::uint32_t e) const { return edge_ids_[e].ring; }
  std::uint32_t index_of(std::uint32_t e) const { return edge_ids_[e].index; }

 protected:
  struct EdgeId {
    std::uint32_t ring, index;
  };
  std::vector<const std::vector<Vec2>*> rings_;
  std::vector<EdgeId> edge_ids_;
};
class RingEdges : public RingEdgeList {
 public:
  explicit RingEdges(const std::vector<const std::vector<Vec2>*>& rings) : RingEdgeList(rings) {
    const auto [x0, y0, x1, y1, edges] = ring_bounds(rings_);
    if (edges == 0) return;
    const double w = std::max(x1 - x0, 1e-6), h = std::max(y1 - y0, 1e-6);
    cell_ = std::max({std::sqrt(w * h / static_cast<double>(edges)) * 2, w / 512, h / 512, 1e-6});
    origin_ = {x0 - cell_, y0 - cell_};
    nx_ = static_cast<long>(w / cell_) + 3;
    ny_ = static_cast<long>(h / cell_) + 3;
    // (cell, edge) pairs in the order the edges visit their cells, then counted into cells: an
    // edge stamps a cell and its neighbours, so a cell's repeats of one edge are adjacent. The
    // cells along an edge step to a neighbour at a time, so a cell already stamped from the cell
    // before is not stamped again (the repeats left are dropped below).
    std::vector<std::pair<std::uint32_t, std::uint32_t>> hits;
    hits.reserve(6 * edges);
    for (std::size_t r = 0; r < rings_.size(); ++r) {
      const auto& ring = *rings_[r];
      for (std::size_t i = 0; i < ring.size(); ++i) {
        const std::uint32_t id = static_cast<std::uint32_t>(edge_ids_.size());
        edge_ids_.push_back({static_cast<std::uint32_t>(r), static_cast<std::uint32_t>(i)});
        long px = -1 << 30, py = -1 << 30;
        each_cell(ring[i], ring[i + 1 == ring.size() ? 0 : i + 1], [&](long cx, long cy) {
          for (long y = std::max(0L, cy - 1); y <= std::min(ny_ - 1, cy + 1); ++y)
            for (long x = std::max(0L, cx - 1); x <= std::min(nx_ - 1, cx + 1); ++x)
              if (std::abs(x - px) > 1 || std::abs(y - py) > 1)
                hits.push_back({static_cast<std::uint32_t>(y * nx_ + x), id});
          px = cx, py = cy;
        });
      }
    }
    start_.assign(static_cast<std::size_t>(nx_ * ny_) + 1, 0);
    for (const auto& [cell, id] : hits) ++start_[cell + 1];
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    ids_.resize(hits.size());
    for (const auto& [cell, id] : hits) {
      std::size_t& at = fill[cell];
      if (at > start_[cell] && ids_[at - 1] == id) continue;  // the same edge again
      ids_[at++] = id;
    }
    // Close the gaps repeats left: each cell's ids from start_ to fill.
    std::size_t kept = 0;
    for (std::size_t c = 0; c + 1 < start_.size(); ++c) {
      const std::size_t from = start_[c], to = fill[c];
      start_[c] = kept;
      for (std::size_t k = from; k < to; ++k) ids_[kept++] = ids_[k];
    }
    start_.back() = kept;
    ids_.resize(kept);
    stamp_.assign(edge_ids_.size(), 0);
  }

  bool empty() const { return edge_ids_.empty(); }

  // Each edge whose cells include one along a-b, once.
  template <class Fn>
  void along(Vec2 p, Vec2 q, Fn&& fn) const {
    if (empty()) return;
    const std::uint32_t s = next_stamp();
    each_cell(p, q, [&](long cx, long cy) {
      if (cx < 0 || cy < 0 || cx >= nx_ || cy >= ny_) return;
      const std::size_t c = static_cast<std::size_t>(cy * nx_ + cx);
      for (std::size_t k = start_[c]; k < start_[c + 1]; ++k) {
        const std::uint32_t e = ids_[k];
        if (stamp_[e] == s) continue;
        stamp_[e] = s;
        fn(e);
      }
    });
  }

 private:
  long cell_of(double d) const { return ref_floor_long(d / cell_); }
  template <class Fn>
  void each_cell(Vec2 p, Vec2 q, Fn&& fn) const {
    const double l = len2d(q - p);
    const int steps = static_cast<int>(std::min(1e7, std::ceil(l / (0.5 * cell_)))) + 1;
    long lx = -1 << 30, ly = -1 << 30;
    for (int k = 0; k <= steps; ++k) {
      const double t = static_cast<double>(k) / steps;
      const long cx = cell_of(p.x + (q.x - p.x) * t - origin_.x);
      const long cy = cell_of(p.y + (q.y - p.y) * t - origin_.y);
      if (cx == lx && cy == ly) continue;
      lx = cx, ly = cy;
      fn(cx, cy);
    }
  }
  std::uint32_t next_stamp() const {
    if (++stamp_now_ == 0) {
      std::fill(stamp_.begin(), stamp_.end(), 0);
      stamp_now_ = 1;
    }
    return stamp_now_;
  }

  std::vector<std::size_t> start_;
  std::vector<std::uint32_t> ids_;
  mutable std::vector<std::uint32_t> stamp_;
  mutable std::uint32_t stamp_now_ = 0;
  Vec2 origin_;
  double cell_ = 1;
  long nx_ = 0, ny_ = 0;
};

std::vector<const std::vector<Vec2>*> ref_rings(const Regions& region) {
  std::vector<const std::vector<Vec2>*> rings;
  for (const auto& poly : region) {
    if (poly.outer.size() >= 3) rings.push_back(&poly.outer);
    for (const auto& h : poly.holes)
      if (h.size() >= 3) rings.push_back(&h);
  }
  return rings;
}

// Comb::route as first written: the crossings with the route's rings from the grid, inside and
// crossing tests over every edge.
bool ref_route(const Regions& inside, const Regions& route, Vec2 a, Vec2 b, double max_length,
               std::vector<Vec2>& via) {
  via.clear();
  if (!ref_inside(inside, a) || !ref_inside(inside, b)) return false;
  if (!ref_crosses(inside, a, b)) return len2d(b - a) <= max_length;
  struct Hit {
    double t;
    std::uint32_t edge;
    double u;
  };
  std::vector<Hit> hits;
  const auto route_rings = ref_rings(route);
  const RingEdges re(route_rings);
  if (re.empty()) return false;
  re.along(a, b, [&](std::uint32_t e) {
    double t = 0, u = 0;
    if (ref_segments_cross(a, b, re.a(e), re.b(e), t, u)) hits.push_back({t, e, u});
  });
  auto on_ring = [&](Vec2 p, double t) {
    double best = 1e-6;
    long edge = -1;
    double at = 0;
    re.along(p, p, [&](std::uint32_t e) {
      double u = 0;
      const Vec2 ea = re.a(e), eb = re.b(e);
      const double d = distance_to_segment({p.x, p.y, 0}, {ea.x, ea.y, 0}, {eb.x, eb.y, 0}, &u);
      if (d <= best) best = d, edge = e, at = u;
    });
    if (edge >= 0) hits.push_back({t, static_cast<std::uint32_t>(edge), at});
  };
  on_ring(a, 0);
  on_ring(b, 1);
  std::sort(hits.begin(), hits.end(), [](const Hit& x, const Hit& y) { return x.t < y.t; });
  std::vector<Vec2> path{a};
  const double total = len2d(b - a);
  for (std::size_t k = 0; k + 1 < hits.size(); ++k) {
    const Hit& h0 = hits[k];
    const Hit& h1 = hits[k + 1];
    if ((h1.t - h0.t) * total < 1e-7) continue;
    const Vec2 mid = a + (b - a) * (0.5 * (h0.t + h1.t));
    if (ref_inside(route, mid)) continue;
    if (re.ring_of(h0.edge) != re.ring_of(h1.edge)) return false;
    const auto& ring = *route_rings[re.ring_of(h0.edge)];
    const std::size_t m = ring.size();
    const std::size_t e0 = re.index_of(h0.edge), e1 = re.index_of(h1.edge);
    auto arc = [&](bool forward, std::vector<Vec2>& pts) {
      pts.clear();
      pts.push_back(a + (b - a) * h0.t);
      std::size_t count = forward ? (e1 + m - e0) % m : (e0 + m - e1) % m;
      if (count == 0 && (forward ? h1.u < h0.u : h1.u > h0.u)) count = m;
      for (std::size_t s = 0; s < count; ++s)
        pts.push_back(forward ? ring[(e0 + 1 + s) % m] : ring[(e0 + m - s) % m]);
      pts.push_back(a + (b - a) * h1.t);
      double l = 0;
      for (std::size_t s = 1; s < pts.size(); ++s) l += len2d(pts[s] - pts[s - 1]);
      return l;
    };
    std::vector<Vec2> fwd, back;
    const double lf = arc(true, fwd), lb = arc(false, back);
    const auto& pick = lf <= lb ? fwd : back;
    path.insert(path.end(), pick.begin(), pick.end());
  }
  path.push_back(b);
  std::vector<Vec2> kept{path.front()};
  std::size_t i = 0;
  while (i + 1 < path.size()) {
    std::size_t j = i + 1;
    while (j + 1 < path.size() && !ref_crosses(inside, path[i], path[j + 1])) ++j;
    if (ref_crosses(inside, path[i], path[j])) return false;
    kept.push_back(path[j]);
    i = j;
  }
  double length = 0;
  for (std::size_t s = 1; s < kept.size(); ++s) length += len2d(kept[s] - kept[s - 1]);
  if (length > max_length) return false;
  via.assign(kept.begin() + 1, kept.end() - 1);
  return true;
}

// A ring simplified as first written: split at the first point farthest from point 0 by hypot,
// each half through simplify_polyline.
std::vector<Vec2> ref_simplify_ring(const std::vector<Vec2>& ring, double tol) {
  const std::size_t n = ring.size();
  if (n < 4 || tol <= 0) return ring;
  std::size_t far = 0;
  double best = -1;
  for (std::size_t i = 1; i < n; ++i) {
    const double d = std::hypot(ring[i].x - ring[0].x, ring[i].y - ring[0].y);
    if (d > best) best = d, far = i;
  }
  std::vector<Vec3> a, b;
  for (std::size_t i = 0; i <= far; ++i) a.push_back({ring[i].x, ring[i].y, 0});
  for (std::size_t i = far; i <= n; ++i) b.push_back({ring[i % n].x, ring[i % n].y, 0});
  a = simplify_polyline(a, tol);
  b = simplify_polyline(b, tol);
  std::vector<Vec2> out;
  for (const auto& q : a) out.push_back(q.xy());
  for (std::size_t i = 1; i + 1 < b.size(); ++i) out.push_back(b[i].xy());
  return out.size() >= 3 ? out : ring;
}

// ---------------------------------------------------------------- generated rings

// Rings of the kinds outlines are made of: stars, regular polygons (equal distances), rounded
// rectangles sampled finely (offset corners), points snapped to a coarse grid (repeats, straight
// runs, axis-parallel edges), hairpins.
std::vector<Vec2> random_ring(Rng& rng, int kind) {
  std::vector<Vec2> ring;
  const Vec2 c{200 * rng.uniform01() - 100, 200 * rng.uniform01() - 100};
  switch (kind % 5) {
    case 0:
      return test::star(rng, c, 2 + 5 * rng.uniform01(), 8 + 20 * rng.uniform01(),
                        3 + static_cast<int>(rng.uniform_index(300)), rng.uniform01() < 0.7);
    case 1: {
      const int n = 3 + static_cast<int>(rng.uniform_index(200));
      const double r = 0.5 + 30 * rng.uniform01();
      for (int i = 0; i < n; ++i)
        ring.push_back(c + Vec2{r * std::cos(2 * kPi * i / n), r * std::sin(2 * kPi * i / n)});
      return ring;
    }
    case 2: {
      const double w = 1 + 40 * rng.uniform01(), h = 1 + 40 * rng.uniform01();
      const double r = std::min(w, h) * 0.4 * rng.uniform01();
      const int per = 1 + static_cast<int>(rng.uniform_index(24));
      const Vec2 corners[4] = {{w, h}, {-w, h}, {-w, -h}, {w, -h}};
      for (int q = 0; q < 4; ++q)
        for (int k = 0; k <= per; ++k) {
          const double a = kPi / 2 * (q + static_cast<double>(k) / per);
          const Vec2 in{corners[q].x - (corners[q].x > 0 ? r : -r),
                        corners[q].y - (corners[q].y > 0 ? r : -r)};
          ring.push_back(c + in + Vec2{r * std::cos(a), r * std::sin(a)});
        }
      return ring;
    }
    case 3: {
      auto g = test::star(rng, c, 3, 20, 4 + static_cast<int>(rng.uniform_index(80)), true);
      const double step = rng.uniform01() < 0.5 ? 0.5 : 1.0;
      for (auto& p : g) p = {std::round(p.x / step) * step, std::round(p.y / step) * step};
      return g;
    }
    default: {
      // A hairpin: out along a line and back just beside it, with a repeated point.
      const int n = 3 + static_cast<int>(rng.uniform_index(60));
      for (int i = 0; i <= n; ++i) ring.push_back(c + Vec2{0.3 * i, 0});
      ring.push_back(ring.back());
      for (int i = n; i >= 0; --i) ring.push_back(c + Vec2{0.3 * i, 0.05 + 0.01 * (i % 3)});
      return ring;
    }
  }
}

}  // namespace

TEST(LinkSame, AlignedAndRearSeamsAreTheReferencesOnGeneratedRings) {
  Rng rng(291);
  for (int trial = 0; trial < 3000; ++trial) {
    const auto ring = random_ring(rng, trial);
    ASSERT_EQ(seam_vertex(ring, Seam::Aligned, {0, 0}, 1, 0), ref_aligned_seam(ring))
        << "trial " << trial << ", " << ring.size() << " points";
    // Rear: the largest y, then the smallest x, then the first.
    std::size_t rear = 0;
    for (std::size_t i = 1; i < ring.size(); ++i)
      if (std::tie(ring[rear].y, ring[i].x) < std::tie(ring[i].y, ring[rear].x)) rear = i;
    ASSERT_EQ(seam_vertex(ring, Seam::Rear, {0, 0}, 1, 0), rear) << "trial " << trial;
  }
}

TEST(LinkSame, CombInsideAndStraightAreTheReferencesOnGeneratedRegions) {
  Rng rng(292);
  std::size_t straight = 0, blocked = 0, in = 0, out = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Regions r = random_region(rng, 5 + 40 * rng.uniform01());
    if (trial % 2 == 1)  // coarse grid: rays through vertices, segments along edges
      for (auto& poly : r) {
        for (auto& p : poly.outer) p = {std::round(p.x), std::round(p.y)};
        for (auto& h : poly.holes)
          for (auto& p : h) p = {std::round(p.x), std::round(p.y)};
      }
    const Comb comb(r, r);
    std::vector<Vec2> probes;
    for (int k = 0; k < 60; ++k) {
      Vec2 p{100 * rng.uniform01() - 50, 100 * rng.uniform01() - 50};
      if (trial % 2 == 1) p = {std::round(p.x), std::round(p.y)};
      probes.push_back(p);
    }
    for (const auto& poly : r)  // the vertices themselves
      for (std::size_t k = 0; k < poly.outer.size(); k += 3) probes.push_back(poly.outer[k]);
    for (const Vec2 p : probes) {
      const bool want = ref_inside(r, p);
      ASSERT_EQ(comb.contains(p), want) << "trial " << trial << " at " << p.x << "," << p.y;
      (want ? in : out) += 1;
    }
    for (std::size_t k = 0; k + 1 < probes.size(); ++k) {
      const Vec2 a = probes[k], b = probes[(k * 7 + 3) % probes.size()];
      const bool want = ref_inside(r, a) && ref_inside(r, b) && !ref_crosses(r, a, b);
      ASSERT_EQ(comb.straight(a, b), want)
          << "trial " << trial << " " << a.x << "," << a.y << " to " << b.x << "," << b.y;
      (want ? straight : blocked) += 1;
    }
  }
  // Both answers were asked for often.
  EXPECT_GT(in, 1000u);
  EXPECT_GT(out, 1000u);
  EXPECT_GT(straight, 300u);
  EXPECT_GT(blocked, 300u);
}

TEST(LinkSame, OrderIsTheReferenceNearestNeighbourAndTwoOpt) {
  Rng rng(293);
  for (int trial = 0; trial < 120; ++trial) {
    const std::size_t n = 1 + rng.uniform_index(trial < 100 ? 120 : 700);
    std::vector<OrderItem> items(n);
    for (auto& it : items) {
      it.start = {100 * rng.uniform01(), 100 * rng.uniform01(), trial % 5 == 0 ? 0.5 : 0.0};
      it.end = it.start + Vec3{10 * rng.uniform01() - 5, 10 * rng.uniform01() - 5, 0};
      if (trial % 3 == 0) {  // ties
        it.start = {std::round(it.start.x), std::round(it.start.y), 0};
        it.end = {std::round(it.end.x), std::round(it.end.y), 0};
      }
      it.reversible = trial % 4 != 1 || rng.uniform01() < 0.9;
      if (trial % 6 == 2) it.start.y = it.end.y = 50;  // on one line: a grid one cell high
      if (trial % 6 == 4 && rng.uniform01() < 0.5)     // two clusters far apart
        it.start.x += 5000, it.end.x += 5000;
    }
    const Vec3 from{-5, 50, 0};
    const auto got = order_by_travel(items, from);
    const auto want = ref_order(items, from);
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t k = 0; k < got.size(); ++k) {
      ASSERT_EQ(got[k].item, want[k].item) << "trial " << trial << " step " << k;
      ASSERT_EQ(got[k].reversed, want[k].reversed) << "trial " << trial << " step " << k;
    }
  }
}

TEST(LinkSame, SimplifiedRingsAreTheReferencesOnGeneratedRings) {
  Rng rng(294);
  std::size_t dropped = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    auto ring = random_ring(rng, trial);
    if (trial % 7 == 0 && ring.size() > 4) ring[2] = ring[1];  // a repeated point
    const double tol = std::pow(10.0, -4 + 4 * rng.uniform01());
    const auto want = ref_simplify_ring(ring, tol);
    const Regions got = simplify(Regions{Polygon2{ring, {}}}, tol);
    ASSERT_EQ(got.size(), 1u);
    ASSERT_EQ(got[0].outer, want) << "trial " << trial << ", " << ring.size() << " points";
    dropped += ring.size() - want.size();
  }
  EXPECT_GT(dropped, 1000u);  // simplification happened, not only copies
}

TEST(LinkSame, ConnectedFillIsTheReferenceOnGeneratedRegions) {
  // Hatch lines of generated regions (their ends on the outline, at its vertices when the grid
  // puts them there), some ends moved off it or onto a vertex, empty and one-point lines, and
  // tolerances from the default to a fraction of the spacing (many edges within reach, ties).
  Rng rng(295);
  std::size_t on_boundary = 0, joined = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Regions r = random_region(rng, 3 + 40 * rng.uniform01());
    const bool grid = trial % 3 == 1;
    if (grid)
      for (auto& poly : r) {
        for (auto& p : poly.outer) p = {std::round(p.x), std::round(p.y)};
        for (auto& h : poly.holes)
          for (auto& p : h) p = {std::round(p.x), std::round(p.y)};
      }
    const double spacing = grid ? 1.0 : 0.3 + 3 * rng.uniform01();
    const double angle = grid && trial % 2 == 0 ? 0.0 : 180 * rng.uniform01();
    std::vector<std::vector<Vec2>> lines;
    for (const auto& seg : hatch(r, angle, spacing)) lines.push_back({seg.a, seg.b});
    std::vector<Vec2> vertices;
    for (const auto& poly : r)
      vertices.insert(vertices.end(), poly.outer.begin(), poly.outer.end());
    for (auto& l : lines) {
      const double u = rng.uniform01();
      if (u < 0.05)
        l.back() = l.back() + Vec2{0.5 * rng.uniform01(), 0.5 * rng.uniform01()};  // off it
      else if (u < 0.1 && !vertices.empty())
        l.front() = vertices[rng.uniform_index(vertices.size())];  // on a vertex
      else if (u < 0.12)
        l.clear();
      else if (u < 0.14)
        l.resize(1);
    }
    const double tolerance = trial % 4 == 3 ? 0.05 + 0.4 * rng.uniform01() * spacing : 1e-4;
    const double max_connector = trial % 5 == 4 ? 0 : (1 + 3 * rng.uniform01()) * spacing;
    const auto got = connect_fill(lines, r, max_connector, nullptr, tolerance);
    const auto want = ref_connect_fill(lines, r, max_connector, tolerance);
    ASSERT_EQ(got.size(), want.size()) << "trial " << trial;
    for (std::size_t k = 0; k < got.size(); ++k)
      ASSERT_EQ(got[k], want[k]) << "trial " << trial << " chain " << k;
    for (const auto& c : got) joined += c.size() > 2;
    on_boundary += lines.size();
  }
  EXPECT_GT(on_boundary, 3000u);  // lines were asked about
  EXPECT_GT(joined, 500u);        // and chains joined through connectors
}

TEST(LinkSame, CombRoutesAreTheReferenceOnGeneratedRegions) {
  // Travels between points inside generated regions, on their route's rings (at vertices and
  // along edges) and on a coarse grid (crossings through vertices, at equal distances), routed
  // along an inward offset or along the outline itself.
  Rng rng(296);
  std::size_t routed = 0, refused = 0, with_via = 0;
  for (int trial = 0; trial < 500; ++trial) {
    Regions r = random_region(rng, 5 + 40 * rng.uniform01());
    const bool grid = trial % 2 == 1;
    if (grid)
      for (auto& poly : r) {
        for (auto& p : poly.outer) p = {std::round(p.x), std::round(p.y)};
        for (auto& h : poly.holes)
          for (auto& p : h) p = {std::round(p.x), std::round(p.y)};
      }
    const Regions route = trial % 3 == 0 ? r : offset(r, -(0.2 + 1.5 * rng.uniform01()));
    if (route.empty()) continue;
    const Comb comb(r, route);
    std::vector<Vec2> points;
    for (int k = 0; k < 30; ++k) {
      Vec2 p{100 * rng.uniform01() - 50, 100 * rng.uniform01() - 50};
      if (grid) p = {std::round(p.x), std::round(p.y)};
      points.push_back(p);
    }
    for (const auto* ring : ref_rings(route))
      for (std::size_t k = 0; k < ring->size(); k += 1 + rng.uniform_index(6)) {
        const Vec2 u = (*ring)[k], v = (*ring)[(k + 1) % ring->size()];
        points.push_back(rng.uniform01() < 0.5 ? u : u + (v - u) * 0.5);
      }
    for (std::size_t k = 0; k < points.size(); ++k) {
      const Vec2 a = points[k], b = points[(k * 7 + 3) % points.size()];
      const double max_length = (1.5 + 2 * rng.uniform01()) * len2d(b - a) + 0.4;
      std::vector<Vec2> got, want;
      const bool ok = comb.route(a, b, max_length, got);
      ASSERT_EQ(ok, ref_route(r, route, a, b, max_length, want))
          << "trial " << trial << " " << a.x << "," << a.y << " to " << b.x << "," << b.y;
      ASSERT_EQ(got, want) << "trial " << trial << " travel " << k;
      (ok ? routed : refused) += 1;
      with_via += !got.empty();
    }
  }
  EXPECT_GT(routed, 500u);
  EXPECT_GT(refused, 500u);
  EXPECT_GT(with_via, 200u);  // routes that go round (not only straight travels)
}
