#include "trellis/slice/link.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "trellis/core/error.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/toolpath/order.hpp"

namespace trellis {

Seam seam_from_string(const std::string& name) {
  if (name == "aligned") return Seam::Aligned;
  if (name == "nearest") return Seam::Nearest;
  if (name == "rear") return Seam::Rear;
  if (name == "random") return Seam::Random;
  throw SettingError("unknown seam '" + name + "' (expected aligned, nearest, rear or random)");
}

const char* to_string(Seam seam) {
  switch (seam) {
    case Seam::Aligned:
      return "aligned";
    case Seam::Nearest:
      return "nearest";
    case Seam::Rear:
      return "rear";
    case Seam::Random:
      return "random";
  }
  return "?";
}

void LinkStats::add(const LinkStats& o) {
  starts += o.starts;
  lower_bound += o.lower_bound;
  travels += o.travels;
  inside_travels += o.inside_travels;
  travel_length += o.travel_length;
  connector_length += o.connector_length;
  fill_lines += o.fill_lines;
  fill_chains += o.fill_chains;
}

namespace {

double cross(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}
double len(Vec2 a) {
  return std::sqrt(a.x * a.x + a.y * a.y);
}

// floor(v) as a long: truncation where that is floor (v >= 0, most grid cells), without the
// call.
long floor_long(double v) {
  return v >= 0 ? static_cast<long>(v) : static_cast<long>(std::floor(v));
}

// The box of closed rings' points and their number of edges, for sizing an edge grid.
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

// The cells of a uniform grid over closed rings (about four edges a cell) along a segment,
// sampled every half cell. The comb's crossings of a travel with the route's rings are taken in
// the order such a grid gives them (an edge in every cell along it and their neighbours, met at
// the first cell along the travel that holds it, the edges of a cell in ring order), which the
// comb's routes depend on where crossings lie at equal distances along a travel; the grid itself
// (every edge entered into its cells, counting-sorted) was most of the comb's cost, and only the
// few crossing edges need their place in it (first_cell).
class CellWalk {
 public:
  explicit CellWalk(const std::vector<const std::vector<Vec2>*>& rings) {
    const auto [x0, y0, x1, y1, edges] = ring_bounds(rings);
    if (edges == 0) return;
    const double w = std::max(x1 - x0, 1e-6), h = std::max(y1 - y0, 1e-6);
    cell_ = std::max({std::sqrt(w * h / static_cast<double>(edges)) * 2, w / 512, h / 512, 1e-6});
    origin_ = {x0 - cell_, y0 - cell_};
    nx_ = static_cast<long>(w / cell_) + 3;
    ny_ = static_cast<long>(h / cell_) + 3;
  }

  bool in_grid(long cx, long cy) const { return cx >= 0 && cy >= 0 && cx < nx_ && cy < ny_; }

  // The cells along p-q in order (each once in a row; outside the grid too).
  template <class Fn>
  void each_cell(Vec2 p, Vec2 q, Fn&& fn) const {
    const double l = len(q - p);
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

  // The cells of a travel in the grid, in order.
  void walk(Vec2 p, Vec2 q, std::vector<std::pair<long, long>>& out) const {
    out.clear();
    each_cell(p, q, [&](long cx, long cy) {
      if (in_grid(cx, cy)) out.push_back({cx, cy});
    });
  }

  // The first of the walk's cells that holds edge a-b (a cell holds the edges with a cell along
  // them at most one cell away); -1 if none does.
  long first_cell(const std::vector<std::pair<long, long>>& walk, Vec2 a, Vec2 b) const {
    cells_.clear();
    each_cell(a, b, [&](long cx, long cy) { cells_.push_back({cx, cy}); });
    for (std::size_t k = 0; k < walk.size(); ++k)
      for (const auto& [x, y] : cells_)
        if (std::abs(walk[k].first - x) <= 1 && std::abs(walk[k].second - y) <= 1)
          return static_cast<long>(k);
    return -1;
  }

 private:
  long cell_of(double d) const { return floor_long(d / cell_); }
  Vec2 origin_;
  double cell_ = 1;
  long nx_ = 0, ny_ = 0;
  mutable std::vector<std::pair<long, long>> cells_;
};

// Where segment p-q crosses segment a-b: parameters along each (false when parallel or apart).
bool segments_cross(Vec2 p, Vec2 q, Vec2 a, Vec2 b, double& t, double& u) {
  const Vec2 r = q - p, s = b - a;
  const double d = cross(r, s);
  if (std::abs(d) < 1e-300) return false;
  t = cross(a - p, s) / d;
  u = cross(a - p, r) / d;
  return t >= 0 && t <= 1 && u >= 0 && u <= 1;
}

// The edges of closed rings in runs of kRun consecutive edges, each run with its box: an inside
// test and a crossing test (each tests every edge that can pass, once) that skip the runs a ray
// or segment cannot meet, and the edges near a segment or a point. Built in one pass over the
// points where an edge grid enters each edge into several cells and sorts them; for an island's
// travel, which asks a few questions of its outline, that build was most of the cost.
class RingRuns {
 public:
  explicit RingRuns(const std::vector<const std::vector<Vec2>*>& rings) : rings_(rings) {
    for (std::size_t r = 0; r < rings_.size(); ++r) {
      const auto& ring = *rings_[r];
      const std::size_t n = ring.size();
      first_.push_back(edges_);
      edges_ += static_cast<std::uint32_t>(n);
      for (std::size_t i0 = 0; i0 < n; i0 += kRun) {
        const std::size_t i1 = std::min(n, i0 + kRun);
        Run run{static_cast<std::uint32_t>(r),
                static_cast<std::uint32_t>(i0),
                static_cast<std::uint32_t>(i1),
                ring[i0].x,
                ring[i0].y,
                ring[i0].x,
                ring[i0].y};
        for (std::size_t i = i0 + 1; i <= i1; ++i) {  // the runs' points, the last edge's end
          const Vec2 q = ring[i == n ? 0 : i];
          run.x0 = std::min(run.x0, q.x), run.y0 = std::min(run.y0, q.y);
          run.x1 = std::max(run.x1, q.x), run.y1 = std::max(run.y1, q.y);
        }
        runs_.push_back(run);
      }
    }
  }

  // Crossings of the ray from p towards +x with the rings (even-odd: inside when odd).
  bool inside(Vec2 p) const {
    bool in = false;
    for (const Run& run : runs_) {
      // An edge counts only when p.y lies in [its lower y, its upper y) (exact compares), and
      // where its crossing lies beyond p.x, which the rounding of that crossing may put a few
      // ulps past the run's box (the slack).
      if (!(run.y0 <= p.y && p.y < run.y1) || p.x > run.x1 + kSlack) continue;
      const auto& ring = *rings_[run.ring];
      const std::size_t n = ring.size();
      for (std::size_t i = run.from; i < run.to; ++i) {
        const Vec2 u = ring[i], v = ring[i + 1 == n ? 0 : i + 1];
        if ((u.y > p.y) != (v.y > p.y) && p.x < (v.x - u.x) * (p.y - u.y) / (v.y - u.y) + u.x)
          in = !in;
      }
    }
    return in;
  }

  // Whether segment a-b crosses an edge (segments_cross).
  bool crosses(Vec2 a, Vec2 b) const {
    const double x0 = std::min(a.x, b.x) - kSlack, x1 = std::max(a.x, b.x) + kSlack;
    const double y0 = std::min(a.y, b.y) - kSlack, y1 = std::max(a.y, b.y) + kSlack;
    for (const Run& run : runs_) {
      if (run.x0 > x1 || run.x1 < x0 || run.y0 > y1 || run.y1 < y0) continue;
      const auto& ring = *rings_[run.ring];
      const std::size_t n = ring.size();
      for (std::size_t i = run.from; i < run.to; ++i) {
        double t = 0, u = 0;
        if (segments_cross(a, b, ring[i], ring[i + 1 == n ? 0 : i + 1], t, u)) return true;
      }
    }
    return false;
  }

  // The number of edges (numbered ring by ring).
  std::uint32_t edges() const { return edges_; }

  // Each edge (number, ring, index, ends) in number order whose run's box, grown by the slack,
  // segment a-b may meet: every edge segments_cross finds crossing a-b among them (its box is
  // left out only when all its corners lie on one side of the line, by far more than rounding).
  template <class Fn>
  void near_segment(Vec2 a, Vec2 b, Fn&& fn) const {
    const double x0 = std::min(a.x, b.x) - kSlack, x1 = std::max(a.x, b.x) + kSlack;
    const double y0 = std::min(a.y, b.y) - kSlack, y1 = std::max(a.y, b.y) + kSlack;
    const Vec2 d = b - a;
    for (const Run& run : runs_) {
      if (run.x0 > x1 || run.x1 < x0 || run.y0 > y1 || run.y1 < y0) continue;
      const double s0 = cross(d, Vec2{run.x0 - kSlack, run.y0 - kSlack} - a);
      const double s1 = cross(d, Vec2{run.x1 + kSlack, run.y0 - kSlack} - a);
      const double s2 = cross(d, Vec2{run.x0 - kSlack, run.y1 + kSlack} - a);
      const double s3 = cross(d, Vec2{run.x1 + kSlack, run.y1 + kSlack} - a);
      if ((s0 > 0 && s1 > 0 && s2 > 0 && s3 > 0) || (s0 < 0 && s1 < 0 && s2 < 0 && s3 < 0))
        continue;
      each_in(run, fn);
    }
  }

  // Each edge in number order whose run's box comes within `reach` (and the slack) of p.
  template <class Fn>
  void near_point(Vec2 p, double reach, Fn&& fn) const {
    const double r = reach + kSlack;
    for (const Run& run : runs_)
      if (run.x0 - r <= p.x && p.x <= run.x1 + r && run.y0 - r <= p.y && p.y <= run.y1 + r)
        each_in(run, fn);
  }

 private:
  static constexpr std::size_t kRun = 16;
  static constexpr double kSlack = 1e-7;  // mm: far beyond rounding, far below a feature
  struct Run {
    std::uint32_t ring, from, to;  // edges from..to-1 of the ring
    double x0, y0, x1, y1;         // the box of their points
  };
  template <class Fn>
  void each_in(const Run& run, Fn&& fn) const {
    const auto& ring = *rings_[run.ring];
    const std::size_t n = ring.size();
    for (std::size_t i = run.from; i < run.to; ++i)
      fn(first_[run.ring] + static_cast<std::uint32_t>(i), run.ring, static_cast<std::uint32_t>(i),
         ring[i], ring[i + 1 == n ? 0 : i + 1]);
  }
  std::vector<const std::vector<Vec2>*> rings_;
  std::vector<Run> runs_;
  std::vector<std::uint32_t> first_;  // each ring's first edge number
  std::uint32_t edges_ = 0;
};

std::vector<const std::vector<Vec2>*> ring_pointers(const Regions& region) {
  std::vector<const std::vector<Vec2>*> rings;
  for (const auto& poly : region) {
    if (poly.outer.size() >= 3) rings.push_back(&poly.outer);
    for (const auto& h : poly.holes)
      if (h.size() >= 3) rings.push_back(&h);
  }
  return rings;
}

}  // namespace

// ---------------------------------------------------------------- connect_fill

namespace {

// The ends of a region's fill lines that lie on its boundary (within `tolerance`), in order
// along each boundary ring: end key 2i is line i's first point, 2i + 1 its last.
class FillEnds {
 public:
  FillEnds(const std::vector<std::vector<Vec2>>& lines, const Regions& region, double tolerance)
      : lines_(lines), rings_(ring_pointers(region)), ends_(2 * lines.size()), cum_(rings_.size()) {
    for (std::size_t r = 0; r < rings_.size(); ++r) {
      const auto& ring = *rings_[r];
      cum_[r].resize(ring.size() + 1, 0.0);
      for (std::size_t i = 0; i < ring.size(); ++i)
        cum_[r][i + 1] = cum_[r][i] + len(ring[(i + 1) % ring.size()] - ring[i]);
    }
    find_edges(tolerance);
    // Each ring's ends in order along it (sorted with their positions beside them, which the
    // comparisons read without looking them up).
    on_ring_.resize(rings_.size());
    std::vector<std::vector<std::pair<double, std::size_t>>> by_s(rings_.size());
    for (std::size_t key = 0; key < 2 * lines.size(); ++key)
      if (ends_[key].ring >= 0)
        by_s[static_cast<std::size_t>(ends_[key].ring)].push_back({ends_[key].s, key});
    slot_.assign(2 * lines.size(), 0);
    for (std::size_t r = 0; r < rings_.size(); ++r) {
      auto& w = by_s[r];
      std::sort(w.begin(), w.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first < b.first : a.second < b.second;
      });
      auto& v = on_ring_[r];
      v.resize(w.size());
      for (std::size_t j = 0; j < w.size(); ++j) v[j] = w[j].second, slot_[w[j].second] = j;
    }
  }

  long ring(std::size_t key) const { return ends_[key].ring; }

  // The neighbour of end `key` along its ring (forward or back) and the boundary between them;
  // -1 when the end is not on the boundary or alone on its ring.
  long neighbour(std::size_t key, bool forward, double& length) const {
    const End& e = ends_[key];
    if (e.ring < 0) return -1;
    const auto& v = on_ring_[static_cast<std::size_t>(e.ring)];
    if (v.size() < 2) return -1;
    const std::size_t m = v.size(), j = slot_[key];
    const std::size_t other = v[forward ? (j + 1) % m : (j + m - 1) % m];
    const double total = cum_[static_cast<std::size_t>(e.ring)].back();
    double d = forward ? ends_[other].s - e.s : e.s - ends_[other].s;
    const bool wraps = forward ? j + 1 == m : j == 0;
    if (wraps) d += total;
    length = d;
    return static_cast<long>(other);
  }

  // The boundary's vertices strictly between end `from` and end `to` (its neighbour).
  void connector(std::size_t from, std::size_t to, bool forward, std::vector<Vec2>& out) const {
    const End& a = ends_[from];
    const End& b = ends_[to];
    const auto& ring = *rings_[static_cast<std::size_t>(a.ring)];
    const std::size_t m = ring.size();
    if (forward) {
      std::size_t count = (b.edge + m - a.edge) % m;
      if (count == 0 && b.s < a.s) count = m;
      for (std::size_t k = 1; k <= count; ++k) out.push_back(ring[(a.edge + k) % m]);
    } else {
      std::size_t count = (a.edge + m - b.edge) % m;
      if (count == 0 && b.s > a.s) count = m;
      for (std::size_t k = 0; k < count; ++k) out.push_back(ring[(a.edge + m - k) % m]);
    }
  }

  // Line (entry / 2) from end `entry` to its other end, appended.
  void append_line(std::vector<Vec2>& chain, std::size_t entry) const {
    const auto& line = lines_[entry / 2];
    if (entry % 2 == 0)
      chain.insert(chain.end(), line.begin(), line.end());
    else
      chain.insert(chain.end(), line.rbegin(), line.rend());
  }

  // Polygons of the region holding a line end, polygons crossed by one line counted once.
  std::size_t regions(const Regions& region) const {
    std::vector<std::size_t> polygon_of;
    for (std::size_t pi = 0; pi < region.size(); ++pi) {
      if (region[pi].outer.size() >= 3) polygon_of.push_back(pi);
      for (const auto& h : region[pi].holes)
        if (h.size() >= 3) polygon_of.push_back(pi);
    }
    // Polygons that touch (Boolean results may share an edge) can be crossed by one line: the
    // polygons joined by a line count once (union-find).
    std::vector<std::size_t> root(region.size());
    for (std::size_t k = 0; k < root.size(); ++k) root[k] = k;
    auto find = [&](std::size_t k) {
      while (root[k] != k) k = root[k] = root[root[k]];
      return k;
    };
    auto poly = [&](const End& e) { return polygon_of[static_cast<std::size_t>(e.ring)]; };
    const std::size_t n = lines_.size();
    for (std::size_t i = 0; i < n; ++i)
      if (ends_[2 * i].ring >= 0 && ends_[2 * i + 1].ring >= 0)
        root[find(poly(ends_[2 * i]))] = find(poly(ends_[2 * i + 1]));
    std::vector<char> touched(region.size(), 0);
    std::size_t count = 0;
    for (const End& e : ends_) {
      if (e.ring < 0) continue;
      char& t = touched[find(poly(e))];
      if (!t) t = 1, ++count;
    }
    return std::max<std::size_t>(count, 1);
  }

 private:
  struct End {
    long ring = -1;
    std::size_t edge = 0;
    double s = 0;
  };
  // Each end's boundary edge: the nearest within `tolerance`, the last of equals in ring order
  // (edges numbered ring by ring). The ends (a region's line ends, fewer than its edges on the
  // large layers) are bucketed in a grid, and each edge, once, tests the ends in the cells its
  // box (grown by the tolerance) covers: an edge within the tolerance of an end is tested, and
  // the pick (least distance, then the greatest edge) does not depend on the order. Bucketing
  // the edges instead and asking each end (as first written) cost two passes over every
  // edge's cells and a query per end.
  void find_edges(double tolerance) {
    std::vector<std::uint32_t> keys;
    keys.reserve(ends_.size());
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (std::size_t key = 0; key < ends_.size(); ++key) {
      const auto& line = lines_[key / 2];
      if (line.size() < 2) continue;
      const Vec2 p = key % 2 ? line.back() : line.front();
      keys.push_back(static_cast<std::uint32_t>(key));
      x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x),
      y1 = std::max(y1, p.y);
    }
    if (keys.empty() || rings_.empty()) return;
    const double w = std::max(x1 - x0, 1e-6), h = std::max(y1 - y0, 1e-6);
    const double cell =
        std::max({std::sqrt(w * h / static_cast<double>(keys.size())), w / 1024, h / 1024, 1e-6});
    const long nx = static_cast<long>(w / cell) + 1, ny = static_cast<long>(h / cell) + 1;
    auto cx = [&](double x) { return std::clamp(floor_long((x - x0) / cell), -1L, nx); };
    auto cy = [&](double y) { return std::clamp(floor_long((y - y0) / cell), -1L, ny); };
    // The ends' points by cell (counting sort), with their best edge so far.
    struct Probe {
      Vec2 p;
      double best, t;
      std::uint32_t key, ring, index, edge;
      bool found;
    };
    std::vector<std::uint32_t> start(static_cast<std::size_t>(nx * ny) + 1, 0);
    std::vector<std::uint32_t> cell_of(keys.size());
    auto point = [&](std::uint32_t key) {
      const auto& line = lines_[key / 2];
      return key % 2 ? line.back() : line.front();
    };
    for (std::size_t j = 0; j < keys.size(); ++j) {
      const Vec2 p = point(keys[j]);
      cell_of[j] = static_cast<std::uint32_t>(cy(p.y) * nx + cx(p.x));
      ++start[cell_of[j] + 1];
    }
    for (std::size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
    std::vector<Probe> probes(keys.size());
    {
      std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
      for (std::size_t j = 0; j < keys.size(); ++j)
        probes[fill[cell_of[j]]++] = {point(keys[j]), tolerance, 0, keys[j], 0, 0, 0, false};
    }
    std::uint32_t e = 0;  // the edge's number, ring by ring
    for (std::size_t r = 0; r < rings_.size(); ++r) {
      const auto& ring = *rings_[r];
      const std::size_t n = ring.size();
      for (std::size_t i = 0; i < n; ++i, ++e) {
        const Vec2 a = ring[i], b = ring[i + 1 == n ? 0 : i + 1];
        const double ex0 = std::min(a.x, b.x), ex1 = std::max(a.x, b.x);
        const double ey0 = std::min(a.y, b.y), ey1 = std::max(a.y, b.y);
        // (The cells of the box grown by the tolerance: an end within it is in one of them,
        // the bounds computed as the test below computes them.)
        const long i0 = std::max(0L, cx(ex0 - tolerance)),
                   i1 = std::min(nx - 1, cx(ex1 + tolerance));
        const long j0 = std::max(0L, cy(ey0 - tolerance)),
                   j1 = std::min(ny - 1, cy(ey1 + tolerance));
        for (long y = j0; y <= j1; ++y)
          for (long x = i0; x <= i1; ++x) {
            const auto c = static_cast<std::size_t>(y * nx + x);
            for (std::uint32_t k = start[c]; k < start[c + 1]; ++k) {
              Probe& q = probes[k];
              const Vec2 p = q.p;
              // (Farther than `best` from the edge's box: farther from the edge.)
              if (p.x < ex0 - q.best || p.x > ex1 + q.best || p.y < ey0 - q.best ||
                  p.y > ey1 + q.best)
                continue;
              double t = 0;
              const double d = distance_to_segment({p.x, p.y, 0}, {a.x, a.y, 0}, {b.x, b.y, 0}, &t);
              if (d < q.best || (d == q.best && (!q.found || e > q.edge))) {
                q.best = d, q.t = t, q.edge = e, q.found = true;
                q.ring = static_cast<std::uint32_t>(r), q.index = static_cast<std::uint32_t>(i);
              }
            }
          }
      }
    }
    for (const Probe& q : probes)
      if (q.found) {
        const auto& cum = cum_[q.ring];
        ends_[q.key] = {static_cast<long>(q.ring), q.index,
                        cum[q.index] + q.t * (cum[q.index + 1] - cum[q.index])};
      }
  }

  const std::vector<std::vector<Vec2>>& lines_;
  std::vector<const std::vector<Vec2>*> rings_;
  std::vector<End> ends_;
  std::vector<std::vector<double>> cum_;
  std::vector<std::vector<std::size_t>> on_ring_;
  std::vector<std::size_t> slot_;
};

}  // namespace

std::vector<std::vector<Vec2>> connect_fill(const std::vector<std::vector<Vec2>>& lines,
                                            const Regions& region, double max_connector,
                                            ConnectStats* stats, double tolerance) {
  const std::size_t n = lines.size();
  std::vector<std::vector<Vec2>> chains;
  if (stats) stats->lines += n;
  const FillEnds ends(lines, region, tolerance);
  if (stats && n > 0) stats->regions += ends.regions(region);
  std::vector<char> used(n, 0);
  auto usable = [&](std::size_t key, bool forward, double& length) -> long {
    const long other = ends.neighbour(key, forward, length);
    if (other < 0) return -1;
    const std::size_t line = static_cast<std::size_t>(other) / 2;
    if (line == key / 2 || used[line] || !(max_connector > 0) || length > max_connector) return -1;
    return other;
  };
  auto options = [&](std::size_t key) {
    double l = 0;
    return (usable(key, true, l) >= 0 ? 1 : 0) + (usable(key, false, l) >= 0 ? 1 : 0);
  };
  // Extends `chain` (ending at end `exit`) while a connector to an unused line exists.
  auto extend = [&](std::vector<Vec2>& chain, std::size_t exit) {
    for (;;) {
      double lf = 0, lb = 0;
      const long f = usable(exit, true, lf), b = usable(exit, false, lb);
      if (f < 0 && b < 0) return exit;
      const bool forward = f >= 0 && (b < 0 || lf <= lb);
      const std::size_t entry = static_cast<std::size_t>(forward ? f : b);
      ends.connector(exit, entry, forward, chain);
      if (stats) stats->connector_length += forward ? lf : lb;
      ends.append_line(chain, entry);
      used[entry / 2] = 1;
      exit = entry ^ 1;
    }
  };
  for (std::size_t i = 0; i < n; ++i) {
    if (used[i] || lines[i].size() < 2) continue;
    used[i] = 1;
    // Start from the end with fewer ways on, so the chain walks away from a dead end.
    const std::size_t entry = options(2 * i + 1) < options(2 * i) ? 2 * i + 1 : 2 * i;
    std::vector<Vec2> chain;
    ends.append_line(chain, entry);
    extend(chain, entry ^ 1);
    if (options(entry) > 0) {  // and backwards from where it began
      std::reverse(chain.begin(), chain.end());
      extend(chain, entry);
    }
    chains.push_back(std::move(chain));
  }
  if (stats) stats->chains += chains.size();
  return chains;
}

std::vector<std::vector<Vec2>> pair_fill(const std::vector<std::vector<Vec2>>& lines,
                                         const Regions& region, double max_connector,
                                         std::vector<std::vector<Vec2>>* rest,
                                         std::vector<std::vector<std::size_t>>* odd_runs,
                                         double tolerance) {
  const std::size_t n = lines.size();
  const FillEnds ends(lines, region, tolerance);
  // Line i's possible partners j: an end of j neighbours i's first point along the boundary and
  // j's other end neighbours i's last point, both within max_connector (two lines side by side
  // whose ends can be turned into each other on both sides).
  struct Partner {
    std::size_t j;
    std::size_t near_first, near_last;  // j's ends beside i's first and last point
    bool first_forward, last_forward;   // the way along the boundary from i's end to them
  };
  std::vector<std::vector<Partner>> partners(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (lines[i].size() < 2) continue;
    for (const bool f0 : {true, false}) {
      double l0 = 0;
      const long a = ends.neighbour(2 * i, f0, l0);
      if (a < 0 || static_cast<std::size_t>(a) / 2 == i || !(l0 <= max_connector)) continue;
      const std::size_t b = static_cast<std::size_t>(a) ^ 1;
      for (const bool f1 : {true, false}) {
        double l1 = 0;
        if (ends.neighbour(2 * i + 1, f1, l1) != static_cast<long>(b) || !(l1 <= max_connector))
          continue;
        const std::size_t j = b / 2;
        if (std::none_of(partners[i].begin(), partners[i].end(),
                         [&](const Partner& p) { return p.j == j; }))
          partners[i].push_back({j, static_cast<std::size_t>(a), b, f0, f1});
      }
    }
  }
  // Partners make paths and cycles (a line has at most two, its neighbours on either side);
  // each paired from one end, alternately, so a run of k lines makes k/2 loops.
  std::vector<char> done(n, 0);
  std::vector<std::vector<Vec2>> loops;
  auto make = [&](std::size_t i, const Partner& p) {
    // Line i first to last, the boundary to j, j back, the boundary to i's first point.
    std::vector<Vec2> loop;
    ends.append_line(loop, 2 * i);
    ends.connector(2 * i + 1, p.near_last, p.last_forward, loop);
    ends.append_line(loop, p.near_last);
    ends.connector(p.near_first, 2 * i, !p.first_forward, loop);
    loop.push_back(loop.front());
    done[i] = done[p.j] = 1;
    loops.push_back(std::move(loop));
  };
  auto mutual = [&](std::size_t i, std::size_t j) {
    return std::any_of(partners[j].begin(), partners[j].end(),
                       [&](const Partner& p) { return p.j == i; });
  };
  // The partner of i in a run other than `from` (SIZE_MAX: none).
  auto next_in_run = [&](std::size_t i, std::size_t from) {
    for (const Partner& p : partners[i])
      if (p.j != from && mutual(i, p.j)) return p.j;
    return SIZE_MAX;
  };
  auto line_length = [&](std::size_t i) {
    double l = 0;
    for (std::size_t k = 1; k < lines[i].size(); ++k) l += len(lines[i][k] - lines[i][k - 1]);
    return l;
  };
  // Pairs the run (a path of lines) in order, the first with the second, …
  auto pair_run = [&](const std::vector<std::size_t>& run) {
    for (std::size_t k = 0; k + 1 < run.size(); k += 2)
      for (const Partner& p : partners[run[k]])
        if (p.j == run[k + 1]) {
          make(run[k], p);
          break;
        }
  };
  std::vector<char> seen(n, 0);
  // The lines of a run from line i on, each partner to the next, none seen twice.
  auto walk_run = [&](std::size_t i) {
    std::vector<std::size_t> run{i};
    seen[i] = 1;
    for (std::size_t prev = SIZE_MAX, at = i;;) {
      const std::size_t nx = next_in_run(at, prev);
      if (nx == SIZE_MAX || seen[nx]) break;
      seen[nx] = 1;
      run.push_back(nx);
      prev = at, at = nx;
    }
    return run;
  };
  for (std::size_t i = 0; i < n; ++i) {
    // Runs from their ends (a line with one partner); an odd run leaves its shorter end line.
    std::size_t count = 0;
    for (const Partner& p : partners[i]) count += mutual(i, p.j);
    if (seen[i] || count != 1) continue;
    std::vector<std::size_t> run = walk_run(i);
    if (run.size() % 2 == 1 && line_length(run.front()) < line_length(run.back()))
      std::reverse(run.begin(), run.end());
    if (odd_runs && run.size() % 2 == 1 && run.size() > 1) odd_runs->push_back(run);
    pair_run(run);
  }
  for (std::size_t i = 0; i < n; ++i) {
    // Cycles: from any line round.
    if (seen[i] || partners[i].empty()) continue;
    std::vector<std::size_t> run = walk_run(i);
    if (odd_runs && run.size() % 2 == 1 && run.size() > 1) odd_runs->push_back(run);
    pair_run(run);
  }
  if (rest)
    for (std::size_t i = 0; i < n; ++i)
      if (!done[i]) rest->push_back(lines[i]);
  return loops;
}

// ---------------------------------------------------------------- seams

std::size_t seam_vertex(const std::vector<Vec2>& ring, Seam seam, Vec2 from, std::uint64_t seed,
                        std::uint64_t key) {
  const std::size_t n = ring.size();
  if (n == 0) return 0;
  auto rear = [&](std::size_t a, std::size_t b) {  // a behind b
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
  switch (seam) {
    case Seam::Nearest: {
      std::size_t best = 0;
      double bd = 1e300;
      for (std::size_t i = 0; i < n; ++i)
        if (const double d = dist2(ring[i], from); d < bd) bd = d, best = i;
      return best;
    }
    case Seam::Rear:
      return rear_most();
    case Seam::Random:
      return static_cast<std::size_t>(Rng::stream(seed, key).uniform_index(n));
    case Seam::Aligned:
      break;
  }
  // Turn at each vertex between the chords to the points `reach` before and after it along the
  // ring (a corner rounded by offsetting still counts as one corner); positive = convex (the
  // rings run with the material on their left).
  double perimeter = 0;
  std::vector<double> cum(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) cum[i + 1] = cum[i] + len(ring[(i + 1) % n] - ring[i]);
  perimeter = cum[n];
  if (!(perimeter > 0)) return rear_most();
  const double reach = std::min(0.8, perimeter / 8);
  // The point at arc length s, for s in [-reach, perimeter + reach] (wrapped as fmod would: s
  // below 0 is taken + perimeter, s from perimeter on - perimeter, exact by Sterbenz's lemma as
  // reach <= perimeter / 8). `at` is the last edge found: s moves on steadily from vertex to
  // vertex, so the edge (the last cum <= s, as upper_bound finds it) is a step or two away.
  auto point_at = [&](double s, std::size_t& at) {
    if (s < 0)
      s += perimeter;
    else if (s >= perimeter)
      s -= perimeter;
    std::size_t i = at;
    while (i < n && cum[i + 1] <= s) ++i;
    while (i > 0 && cum[i] > s) --i;
    at = i;
    const std::size_t k = std::min(i, n - 1);
    const double l = cum[k + 1] - cum[k];
    const double t = l > 0 ? (s - cum[k]) / l : 0;
    return ring[k] + (ring[(k + 1) % n] - ring[k]) * t;
  };
  // Only turns sharper than 25° concave or 55° convex can be picked below (corners beyond 30°
  // and 60°, or within 5° of the sharpest): a turn known to lie between -20° and +48° (its tangent
  // within bounds, a compare with margin) is left 0 without atan2.
  std::vector<double> turn(n, 0.0);
  std::size_t before = 0, after = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 a = point_at(cum[i] - reach, before), b = ring[i],
               c = point_at(cum[i] + reach, after);
    const Vec2 u = b - a, v = c - b;
    if (len(u) < 1e-9 || len(v) < 1e-9) continue;
    const double sine = cross(u, v), cosine = u.x * v.x + u.y * v.y;
    if (cosine > 0 && sine < 1.1 * cosine && -sine < 0.36 * cosine) continue;  // tan 47.7°, 19.8°
    turn[i] = std::atan2(sine, cosine) * 180 / std::numbers::pi;
  }
  // The sharpest corner of a kind beyond `limit` degrees; corners within 5° of the sharpest
  // count as equal and the rear-most of them wins, so rounding does not move the seam.
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

// ---------------------------------------------------------------- travel inside

struct Comb::Impl {
  Regions inside, route;
  std::vector<const std::vector<Vec2>*> inside_rings, route_rings;
  RingRuns inside_edges;
  // Built by the first travel that cannot go straight (most islands have none; not for several
  // threads at once).
  mutable std::optional<RingRuns> route_runs;
  mutable std::optional<CellWalk> route_cells;  // the order of a travel's crossings
  Impl(Regions in, Regions r)
      : inside(std::move(in)),
        route(std::move(r)),
        inside_rings(ring_pointers(inside)),
        route_rings(ring_pointers(route)),
        inside_edges(inside_rings) {}

  bool crosses(Vec2 a, Vec2 b) const { return inside_edges.crosses(a, b); }
  bool straight(Vec2 a, Vec2 b) const {
    return inside_edges.inside(a) && inside_edges.inside(b) && !crosses(a, b);
  }
};

Comb::Comb(Regions inside, Regions route)
    : impl_(std::make_shared<Impl>(std::move(inside), std::move(route))) {}

bool Comb::contains(Vec2 p) const {
  return impl_->inside_edges.inside(p);
}

bool Comb::straight(Vec2 a, Vec2 b) const {
  return impl_->straight(a, b);
}

bool Comb::route(Vec2 a, Vec2 b, double max_length, std::vector<Vec2>& via) const {
  via.clear();
  const Impl& c = *impl_;
  if (!c.inside_edges.inside(a) || !c.inside_edges.inside(b)) return false;
  if (!c.crosses(a, b)) return len(b - a) <= max_length;
  // Crossings of a-b with the route's rings (and a, b themselves where they lie on one), in
  // order along a-b; between two crossings the line is inside or outside the route region.
  struct Hit {
    double t;
    std::uint32_t edge;
    double u;
    std::uint32_t ring, index;
  };
  std::vector<Hit> hits;
  if (!c.route_runs) c.route_runs.emplace(c.route_rings), c.route_cells.emplace(c.route_rings);
  const RingRuns& rr = *c.route_runs;
  const CellWalk& cw = *c.route_cells;
  if (rr.edges() == 0) return false;
  // The crossings in the order of the first cell along a-b holding their edge (then in edge
  // order), as an edge grid gives them.
  std::vector<std::pair<long, long>> walk;
  cw.walk(a, b, walk);
  std::vector<std::pair<long, Hit>> found;
  rr.near_segment(a, b,
                  [&](std::uint32_t e, std::uint32_t ring, std::uint32_t index, Vec2 ea, Vec2 eb) {
                    double t = 0, u = 0;
                    if (!segments_cross(a, b, ea, eb, t, u)) return;
                    if (const long k = cw.first_cell(walk, ea, eb); k >= 0)
                      found.push_back({k, {t, e, u, ring, index}});
                  });
  std::sort(found.begin(), found.end(), [](const auto& x, const auto& y) {
    return x.first != y.first ? x.first < y.first : x.second.edge < y.second.edge;
  });
  for (const auto& f : found) hits.push_back(f.second);
  // An end on a ring: the nearest edge within 1e-6 held by its cell, the last of equals.
  auto on_ring = [&](Vec2 p, double t) {
    double best = 1e-6;
    long edge = -1;
    double at = 0;
    std::uint32_t er = 0, ei = 0;
    walk.clear();
    cw.each_cell(p, p, [&](long cx, long cy) {
      if (cw.in_grid(cx, cy)) walk.push_back({cx, cy});
    });
    if (walk.empty()) return;
    rr.near_point(
        p, best, [&](std::uint32_t e, std::uint32_t ring, std::uint32_t index, Vec2 ea, Vec2 eb) {
          double u = 0;
          const double d = distance_to_segment({p.x, p.y, 0}, {ea.x, ea.y, 0}, {eb.x, eb.y, 0}, &u);
          if (d <= best && cw.first_cell(walk, ea, eb) == 0)
            best = d, edge = e, at = u, er = ring, ei = index;
        });
    if (edge >= 0) hits.push_back({t, static_cast<std::uint32_t>(edge), at, er, ei});
  };
  on_ring(a, 0);
  on_ring(b, 1);
  std::sort(hits.begin(), hits.end(), [](const Hit& x, const Hit& y) { return x.t < y.t; });
  std::vector<Vec2> path{a};
  const double total = len(b - a);
  for (std::size_t k = 0; k + 1 < hits.size(); ++k) {
    const Hit& h0 = hits[k];
    const Hit& h1 = hits[k + 1];
    if ((h1.t - h0.t) * total < 1e-7) continue;
    const Vec2 mid = a + (b - a) * (0.5 * (h0.t + h1.t));
    if (c.route_runs->inside(mid)) continue;
    // Outside the route region between h0 and h1: around its ring, the shorter way.
    if (h0.ring != h1.ring) return false;
    const auto& ring = *c.route_rings[h0.ring];
    const std::size_t m = ring.size();
    const std::size_t e0 = h0.index, e1 = h1.index;
    auto arc = [&](bool forward, std::vector<Vec2>& pts) {
      pts.clear();
      pts.push_back(a + (b - a) * h0.t);
      std::size_t count = forward ? (e1 + m - e0) % m : (e0 + m - e1) % m;
      if (count == 0 && (forward ? h1.u < h0.u : h1.u > h0.u)) count = m;
      for (std::size_t s = 0; s < count; ++s)
        pts.push_back(forward ? ring[(e0 + 1 + s) % m] : ring[(e0 + m - s) % m]);
      pts.push_back(a + (b - a) * h1.t);
      double l = 0;
      for (std::size_t s = 1; s < pts.size(); ++s) l += len(pts[s] - pts[s - 1]);
      return l;
    };
    std::vector<Vec2> fwd, back;
    const double lf = arc(true, fwd), lb = arc(false, back);
    const auto& pick = lf <= lb ? fwd : back;
    path.insert(path.end(), pick.begin(), pick.end());
  }
  path.push_back(b);
  // Shortened: from each kept point, on to the last point still in straight sight.
  std::vector<Vec2> kept{path.front()};
  std::size_t i = 0;
  while (i + 1 < path.size()) {
    std::size_t j = i + 1;
    while (j + 1 < path.size() && !c.crosses(path[i], path[j + 1])) ++j;
    if (c.crosses(path[i], path[j])) return false;  // the route itself leaves the inside
    kept.push_back(path[j]);
    i = j;
  }
  double length = 0;
  for (std::size_t s = 1; s < kept.size(); ++s) length += len(kept[s] - kept[s - 1]);
  if (length > max_length) return false;
  via.assign(kept.begin() + 1, kept.end() - 1);
  return true;
}

// ---------------------------------------------------------------- a layer

namespace {

Path make_path(const std::vector<Vec2>& pts, double z, PathRole role, double width, double height,
               bool closed) {
  Path p;
  p.role = role;
  p.width = width;
  p.height = height;
  p.points.reserve(pts.size() + 1);
  for (const Vec2 v : pts) p.points.push_back({v.x, v.y, z});
  if (closed && !pts.empty()) p.points.push_back({pts[0].x, pts[0].y, z});
  return p;
}

std::vector<Vec2> rotated(const std::vector<Vec2>& ring, std::size_t start) {
  std::vector<Vec2> out(ring.begin() + static_cast<long>(start), ring.end());
  out.insert(out.end(), ring.begin(), ring.begin() + static_cast<long>(start));
  return out;
}

// Closed loops (concentric rings, gyroid curves) joined ring to ring: each loop is printed
// whole from where the last one ended (closed at its start), then a straight connector to the
// nearest vertex of the nearest loop left, when it is within `reach` and its middle inside the
// region; else a new chain begins.
std::vector<std::vector<Vec2>> chain_loops(const std::vector<std::vector<Vec2>>& loops,
                                           const Regions& region, double reach,
                                           double& connector_length) {
  std::vector<std::vector<Vec2>> chains;
  std::vector<char> used(loops.size(), 0);
  auto inside = [&](Vec2 p) {
    return std::any_of(region.begin(), region.end(),
                       [&](const Polygon2& poly) { return trellis::contains(poly, p, 1e-6); });
  };
  for (std::size_t first = 0; first < loops.size(); ++first) {
    if (used[first] || loops[first].size() < 3) continue;
    std::vector<Vec2> chain;
    std::size_t at = first, seam = 0;
    for (;;) {
      used[at] = 1;
      const auto& loop = loops[at];
      for (std::size_t k = 0; k <= loop.size(); ++k)
        chain.push_back(loop[(seam + k) % loop.size()]);
      const Vec2 end = chain.back();
      double best = reach * reach;
      std::size_t next = loops.size(), next_seam = 0;
      for (std::size_t j = 0; j < loops.size(); ++j) {
        if (used[j] || loops[j].size() < 3) continue;
        for (std::size_t k = 0; k < loops[j].size(); ++k)
          if (const double d = dist2(loops[j][k], end); d < best) best = d, next = j, next_seam = k;
      }
      if (next == loops.size() || !inside((end + loops[next][next_seam]) * 0.5)) break;
      connector_length += std::sqrt(best);
      at = next;
      seam = next_seam;
    }
    chains.push_back(std::move(chain));
  }
  return chains;
}

}  // namespace

void link_layer(const std::vector<IslandPieces>& islands, const LinkOptions& o, double z,
                double layer_height, std::uint64_t key, Vec2& cursor, bool cursor_known,
                std::vector<Path>& paths, LinkStats& stats) {
  // Aligned and rear seams depend on the ring alone: found once for each wall loop, for the
  // island's entry and its walls.
  const bool fixed_seams = o.seam == Seam::Aligned || o.seam == Seam::Rear;
  std::vector<std::vector<std::vector<std::size_t>>> fixed_seam(fixed_seams ? islands.size() : 0);
  for (std::size_t i = 0; i < fixed_seam.size(); ++i) {
    fixed_seam[i].resize(islands[i].walls.size());
    for (std::size_t l = 0; l < islands[i].walls.size(); ++l)
      for (const auto& ring : islands[i].walls[l])
        fixed_seam[i][l].push_back(seam_vertex(ring, o.seam, cursor, o.seed, 0));
  }
  // Islands in travel order, each entered at its first wall's seam (or first fill point).
  auto entry_of = [&](std::size_t island) -> Vec2 {
    const IslandPieces& is = islands[island];
    for (std::size_t l = 0; l < is.walls.size(); ++l)
      for (std::size_t r = 0; r < is.walls[l].size(); ++r) {
        const auto& ring = is.walls[l][r];
        if (ring.size() < 3) continue;
        return ring[fixed_seams ? fixed_seam[island][l][r]
                                : seam_vertex(ring, o.seam, cursor, o.seed, key)];
      }
    for (const auto& f : is.fills) {
      if (!f.lines.empty() && !f.lines.front().empty()) return f.lines.front().front();
      if (!f.loops.empty() && !f.loops.front().empty()) return f.loops.front().front();
    }
    return is.outline.outer.empty() ? Vec2{} : is.outline.outer.front();
  };
  std::vector<OrderItem> items;
  for (std::size_t i = 0; i < islands.size(); ++i) {
    const Vec2 e = entry_of(i);
    items.push_back({{e.x, e.y, 0}, {e.x, e.y, 0}, false});
  }
  const auto island_order = order_by_travel(items, {cursor.x, cursor.y, 0});
  std::uint64_t ring_key = key * 0x100000001B3ull;
  for (const OrderStep& step : island_order) {
    const IslandPieces& is = islands[step.item];
    const double w = is.bead_width;
    // The island's inside for travel: its outline, routed along its outer wall's centre line.
    std::unique_ptr<Comb> comb;
    if (o.comb) {
      Regions route = is.route.empty() ? offset(Regions{is.outline}, -0.5 * w) : is.route;
      if (!route.empty()) comb = std::make_unique<Comb>(Regions{is.outline}, std::move(route));
    }
    bool first_in_island = true;
    // Appends a path with its travel from the cursor.
    auto emit = [&](Path p) {
      const Vec2 start = p.points.front().xy();
      if (cursor_known) {
        ++stats.travels;
        std::vector<Vec2> via;
        double straight = len(start - cursor);
        bool inside = false;
        if (comb && (!first_in_island || comb->contains(cursor)))
          inside = comb->route(cursor, start, o.comb_detour * straight + w, via);
        double travel = 0;
        Vec2 at = cursor;
        for (const Vec2 v : via) travel += len(v - at), at = v;
        travel += len(start - at);
        if (inside) {
          ++stats.inside_travels;
          p.inside = true;
          for (const Vec2 v : via) p.via.push_back({v.x, v.y, z});
        }
        stats.travel_length += inside ? travel : straight;
      }
      first_in_island = false;
      cursor = p.points.back().xy();
      cursor_known = true;
      ++stats.starts;
      paths.push_back(std::move(p));
    };
    // Walls: the loops around each boundary ring (the island's outline, each hole) printed
    // together, from the inside out (walls[0] first, the last level the outer wall), so the hop
    // between two of them is a bead; the groups in travel order. A loop belongs to the nearest
    // loop one level further out.
    {
      const std::size_t levels = is.walls.size();
      std::vector<std::vector<std::size_t>> seam(levels);
      for (std::size_t l = 0; l < levels; ++l) {
        seam[l].assign(is.walls[l].size(), 0);
        if (fixed_seams)
          seam[l] = fixed_seam[step.item][l];
        else if (o.seam != Seam::Nearest)
          for (std::size_t r = 0; r < is.walls[l].size(); ++r)
            seam[l][r] = seam_vertex(is.walls[l][r], o.seam, cursor, o.seed, ring_key + r);
        ring_key += is.walls[l].size();
      }
      // group[l][r]: the outermost loop (index in the last level) the loop belongs to.
      std::vector<std::vector<std::size_t>> group(levels);
      if (levels > 0) {
        const auto& outer = is.walls.back();
        group.back().resize(outer.size());
        for (std::size_t r = 0; r < outer.size(); ++r) group.back()[r] = r;
        for (std::size_t l = levels - 1; l-- > 0;) {
          const auto& out = is.walls[l + 1];
          group[l].resize(is.walls[l].size());
          for (std::size_t r = 0; r < is.walls[l].size(); ++r) {
            const Vec2 p = is.walls[l][r].front();
            double best = 1e300;
            std::size_t parent = 0;
            for (std::size_t q = 0; q < out.size(); ++q)
              for (const Vec2 v : out[q])
                if (const double d = dist2(v, p); d < best) best = d, parent = q;
            group[l][r] = out.empty() ? 0 : group[l + 1][parent];
          }
        }
      }
      const std::size_t groups = levels > 0 ? is.walls.back().size() : 0;
      std::vector<char> group_done(groups, 0);
      std::vector<std::vector<char>> done(levels);
      for (std::size_t l = 0; l < levels; ++l) done[l].assign(is.walls[l].size(), 0);
      // The nearest loop not printed (of `only` group, or any), from the innermost level out.
      auto nearest = [&](long only, std::size_t& level, std::size_t& ring, std::size_t& at) {
        for (std::size_t l = 0; l < levels; ++l) {
          double bd = 1e300;
          bool found = false;
          for (std::size_t r = 0; r < is.walls[l].size(); ++r) {
            if (done[l][r] || is.walls[l][r].size() < 3) continue;
            if (only >= 0 && group[l][r] != static_cast<std::size_t>(only)) continue;
            const std::size_t sv = o.seam == Seam::Nearest
                                       ? seam_vertex(is.walls[l][r], o.seam, cursor, o.seed, 0)
                                       : seam[l][r];
            const double d = dist2(is.walls[l][r][sv], cursor);
            if (d < bd) bd = d, level = l, ring = r, at = sv, found = true;
          }
          if (found) return true;
        }
        return false;
      };
      std::size_t l = 0, r = 0, sv = 0;
      while (nearest(-1, l, r, sv)) {
        const std::size_t g = group[l][r];
        do {
          done[l][r] = 1;
          ++stats.lower_bound;
          emit(make_path(rotated(is.walls[l][r], sv), z, PathRole::Perimeter, w, layer_height,
                         true));
        } while (nearest(static_cast<long>(g), l, r, sv));
        if (g < groups) group_done[g] = 1;
      }
    }
    // Fill: each region's lines joined into chains; all chains (and loops) of the island in
    // travel order from the last wall.
    struct Piece {
      std::vector<Vec2> pts;
      PathRole role;
      bool loop;
    };
    std::vector<Piece> pieces;
    for (const auto& f : is.fills) {
      stats.fill_lines += f.lines.size();
      ConnectStats cs;
      // Unconnected, the lines are connected with no connector allowed (the same bound).
      auto chains = connect_fill(f.lines, f.region, o.connect ? o.connect_max * f.spacing : 0, &cs);
      if (!f.lines.empty()) stats.lower_bound += cs.regions;
      stats.connector_length += cs.connector_length;
      stats.fill_chains += chains.size();
      for (auto& c : chains)
        if (c.size() >= 2) pieces.push_back({std::move(c), f.role, false});
      if (f.loops.empty()) continue;
      if (o.connect) {
        double joined = 0;
        auto loop_chains = chain_loops(f.loops, f.region, 1.5 * f.spacing, joined);
        stats.connector_length += joined;
        for (auto& c : loop_chains) pieces.push_back({std::move(c), f.role, false});
      } else {
        for (const auto& l : f.loops)
          if (l.size() >= 3) pieces.push_back({l, f.role, true});
      }
      // Each polygon holding a loop needs a start of its own.
      std::size_t holding = 0;
      for (const auto& poly : f.region)
        if (std::any_of(f.loops.begin(), f.loops.end(), [&](const auto& l) {
              return !l.empty() && trellis::contains(poly, l.front(), 1e-6);
            }))
          ++holding;
      stats.lower_bound += f.lines.empty() ? holding : 0;
    }
    std::vector<OrderItem> fill_items;
    for (const auto& pc : pieces) {
      const Vec2 a = pc.pts.front(), b = pc.loop ? pc.pts.front() : pc.pts.back();
      fill_items.push_back({{a.x, a.y, 0}, {b.x, b.y, 0}, !pc.loop});
    }
    for (const OrderStep& s : order_by_travel(fill_items, {cursor.x, cursor.y, 0})) {
      Piece& pc = pieces[s.item];
      if (pc.loop) {
        const std::size_t seam = seam_vertex(pc.pts, Seam::Nearest, cursor, o.seed, 0);
        emit(make_path(rotated(pc.pts, seam), z, pc.role, w, layer_height, true));
        continue;
      }
      if (s.reversed) std::reverse(pc.pts.begin(), pc.pts.end());
      emit(make_path(pc.pts, z, pc.role, w, layer_height, false));
    }
  }
}

}  // namespace trellis
