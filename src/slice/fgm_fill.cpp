// Strategy 2's fill of one colour face: iso-line sectors and chained beads
// (src/slice/fgm_fill.hpp).
#include "fgm_fill.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "fgm_order.hpp"
#include "fgm_potential.hpp"

namespace trellis::fgm {

namespace {

constexpr double kPi = 3.14159265358979323846;

double dist(Vec2 a, Vec2 b) {
  return std::hypot(b.x - a.x, b.y - a.y);
}

}  // namespace

IsoDirections::IsoDirections(Evaluator& ev, double z, Vec2 lo, Vec2 hi, double spacing,
                             double fallback)
    : lo_(lo), spacing_(spacing), fallback_(fallback) {
  const std::vector<std::vector<double>> f = sample_fractions(ev, z, lo, hi, spacing, nx_, ny_);
  const auto n = f.size();
  t_.resize(n);
  auto at = [&](long i, long j) -> const std::vector<double>& {
    return f[static_cast<std::size_t>(std::clamp(j, 0L, ny_ - 1) * nx_ +
                                      std::clamp(i, 0L, nx_ - 1))];
  };
  for (long j = 0; j < ny_; ++j)
    for (long i = 0; i < nx_; ++i) {
      // Central differences (one-sided at the border).
      const long i0 = std::max(i - 1, 0L), i1 = std::min(i + 1, nx_ - 1);
      const long j0 = std::max(j - 1, 0L), j1 = std::min(j + 1, ny_ - 1);
      const auto &fx0 = at(i0, j), &fx1 = at(i1, j), &fy0 = at(i, j0), &fy1 = at(i, j1);
      Tensor& t = t_[static_cast<std::size_t>(j * nx_ + i)];
      for (std::size_t m = 0; m < fx0.size() && m < 3; ++m) {
        const double gx = (fx1[m] - fx0[m]) / (static_cast<double>(i1 - i0) * spacing);
        const double gy = (fy1[m] - fy0[m]) / (static_cast<double>(j1 - j0) * spacing);
        t.xx += gx * gx, t.yy += gy * gy, t.xy += gx * gy;
      }
    }
}

IsoDirections::Tensor IsoDirections::at(Vec2 p) const {
  const double fx = std::clamp((p.x - lo_.x) / spacing_, 0.0, static_cast<double>(nx_ - 1));
  const double fy = std::clamp((p.y - lo_.y) / spacing_, 0.0, static_cast<double>(ny_ - 1));
  const long i = std::min(static_cast<long>(fx), nx_ - 2),
             j = std::min(static_cast<long>(fy), ny_ - 2);
  const double u = fx - static_cast<double>(i), v = fy - static_cast<double>(j);
  auto node = [&](long a, long b) { return t_[static_cast<std::size_t>(b * nx_ + a)]; };
  const Tensor a = node(i, j), b = node(i + 1, j), c = node(i, j + 1), d = node(i + 1, j + 1);
  auto mix = [&](double ta, double tb, double tc, double td) {
    return (1 - v) * ((1 - u) * ta + u * tb) + v * ((1 - u) * tc + u * td);
  };
  return {mix(a.xx, b.xx, c.xx, d.xx), mix(a.yy, b.yy, c.yy, d.yy), mix(a.xy, b.xy, c.xy, d.xy)};
}

double IsoDirections::angle_of(const Tensor& t) const {
  if (!(t.xx + t.yy > 1e-18)) return fallback_;
  double deg = 0.5 * std::atan2(2 * t.xy, t.xx - t.yy) * 180 / kPi + 90;
  deg = std::fmod(deg, 180.0);
  return deg < 0 ? deg + 180 : deg;
}

double IsoDirections::angle(Vec2 p) const {
  return angle_of(at(p));
}

double IsoDirections::angle_or(Vec2 p, double fallback, double coherence) const {
  const Tensor t = at(p);
  if (!(t.xx + t.yy > 1e-18) || !(std::hypot(t.xx - t.yy, 2 * t.xy) >= coherence * (t.xx + t.yy)))
    return fallback;
  return angle_of(t);
}

double IsoDirections::mean_angle(const Regions& region, double* spread, double* coherence) const {
  Tensor sum;
  double count = 0, coherent = 0;
  for (const auto& s : hatch(region, 0, spacing_ / 2)) {
    const double len = dist(s.a, s.b);
    const int m = std::max(1, static_cast<int>(std::ceil(len / (spacing_ / 2))));
    for (int k = 0; k <= m; ++k) {
      const Tensor t = at(s.a + (s.b - s.a) * (static_cast<double>(k) / m));
      // Each sample's direction with unit weight (a flat stretch counts as much as a steep one).
      const double n = std::hypot(t.xx - t.yy, 2 * t.xy);
      if (!(n > 0)) continue;
      sum.xx += (t.xx - t.yy) / n, sum.xy += 2 * t.xy / n;
      ++count;
      coherent += n / (t.xx + t.yy);
    }
  }
  if (spread) *spread = count > 0 ? std::hypot(sum.xx, sum.xy) / count : 0.0;
  if (coherence) *coherence = count > 0 ? coherent / count : 0.0;
  // sum.xx holds Σ cos 2φ, sum.xy Σ sin 2φ of the gradients' directions φ.
  if (!(std::hypot(sum.xx, sum.xy) > 0)) return fallback_;
  double deg = 0.5 * std::atan2(sum.xy, sum.xx) * 180 / kPi + 90;
  deg = std::fmod(deg, 180.0);
  return deg < 0 ? deg + 180 : deg;
}

std::vector<std::vector<Vec2>> sector_lines(const Regions& region, const IsoDirections& dirs,
                                            double sector, double spacing, double min_length,
                                            double fallback) {
  std::vector<std::vector<Vec2>> out;
  if (region.empty() || !(spacing > 0) || !(sector > 0)) return out;
  const int n = std::max(1, static_cast<int>(std::lround(180 / sector)));
  const double step = 180.0 / n;
  auto sector_of = [&](Vec2 p) {
    return static_cast<int>(std::lround(dirs.angle_or(p, fallback, 0.5) / step)) % n;
  };
  // The sectors the region meets: its directions sampled on lines half a line apart.
  std::set<int> used;
  for (const auto& s : hatch(region, 0, spacing / 2)) {
    const double len = dist(s.a, s.b);
    const int m = std::max(1, static_cast<int>(std::ceil(len / 0.5)));
    for (int k = 0; k <= m; ++k)
      used.insert(sector_of(s.a + (s.b - s.a) * (static_cast<double>(k) / m)));
  }
  constexpr double kSample = 0.25;  // mm between direction samples along a line
  for (const int q : used) {
    for (const auto& s : hatch(region, q * step, spacing)) {
      const Vec2 d = s.b - s.a;
      const double len = std::hypot(d.x, d.y);
      if (!(len > 0)) continue;
      auto mine = [&](double t) { return sector_of(s.a + d * t) == q; };
      const int m = std::max(1, static_cast<int>(std::ceil(len / kSample)));
      double start = mine(0) ? 0.0 : -1.0;
      bool in = start >= 0;
      for (int k = 1; k <= m; ++k) {
        const double t = static_cast<double>(k) / m;
        const bool now = mine(t);
        if (now == in) continue;
        // The change between the two samples, to a µm.
        double lo = static_cast<double>(k - 1) / m, hi = t;
        while ((hi - lo) * len > 1e-3) {
          const double mid = 0.5 * (lo + hi);
          (mine(mid) == in ? lo : hi) = mid;
        }
        const double cut = 0.5 * (lo + hi);
        if (in && (cut - start) * len >= min_length)
          out.push_back({s.a + d * start, s.a + d * cut});
        start = cut;
        in = now;
      }
      if (in && (1 - start) * len >= min_length) out.push_back({s.a + d * start, s.b});
    }
  }
  return out;
}

namespace {

// Pairs of ends e < f of different pieces (end 2k: piece k's first point, 2k + 1 its last)
// within `reach` of each other that `accept(e, f)` takes, shortest first (ties by index): found
// through a grid of `reach` cells.
struct EndPair {
  double d;
  std::size_t e, f;
};
template <class Accept>
std::vector<EndPair> end_pairs(const std::vector<Vec2>& at, double reach, Accept&& accept) {
  const double cell = std::max(reach, 1e-3);
  auto key = [&](Vec2 q) {
    return std::pair<long, long>{static_cast<long>(std::floor(q.x / cell)),
                                 static_cast<long>(std::floor(q.y / cell))};
  };
  std::map<std::pair<long, long>, std::vector<std::size_t>> grid;
  for (std::size_t e = 0; e < at.size(); ++e) grid[key(at[e])].push_back(e);
  std::vector<EndPair> pairs;
  for (std::size_t e = 0; e < at.size(); ++e) {
    const auto c = key(at[e]);
    for (long x = c.first - 1; x <= c.first + 1; ++x)
      for (long y = c.second - 1; y <= c.second + 1; ++y) {
        const auto it = grid.find({x, y});
        if (it == grid.end()) continue;
        for (const std::size_t f : it->second) {
          if (f <= e || f / 2 == e / 2) continue;
          const double d = dist(at[e], at[f]);
          if (d <= reach && accept(e, f)) pairs.push_back({d, e, f});
        }
      }
  }
  std::sort(pairs.begin(), pairs.end(), [](const EndPair& a, const EndPair& b) {
    return a.d < b.d || (a.d == b.d && (a.e < b.e || (a.e == b.e && a.f < b.f)));
  });
  return pairs;
}

}  // namespace

std::vector<std::vector<Vec2>> join_lanes(const std::vector<std::vector<Vec2>>& lines, double reach,
                                          double max_turn) {
  // End 2k is line k's first point, 2k + 1 its last; `out` its direction away from the line.
  const std::size_t n = lines.size();
  std::vector<Vec2> at(2 * n), out(2 * n);
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2 a = lines[k].front(), b = lines[k].back();
    const double l = std::max(dist(a, b), 1e-12);
    const Vec2 u{(b.x - a.x) / l, (b.y - a.y) / l};
    at[2 * k] = a, out[2 * k] = {-u.x, -u.y};
    at[2 * k + 1] = b, out[2 * k + 1] = u;
  }
  const double facing = -std::cos(max_turn * kPi / 180);
  // Pairs of ends that continue each other, nearest first, each end in one pair at most.
  const auto pairs = end_pairs(at, reach, [&](std::size_t e, std::size_t f) {
    return out[e].x * out[f].x + out[e].y * out[f].y <= facing;
  });
  std::vector<std::size_t> mate(2 * n, SIZE_MAX);
  for (const EndPair& p : pairs)
    if (mate[p.e] == SIZE_MAX && mate[p.f] == SIZE_MAX) mate[p.e] = p.f, mate[p.f] = p.e;
  // Lanes: from each line with a free end (then the closed ones), line to line through mates.
  std::vector<char> used(n, 0);
  std::vector<std::vector<Vec2>> lanes;
  auto walk = [&](std::size_t e) {  // enter at end e: the lane runs from e through its line
    std::vector<Vec2> lane;
    while (e != SIZE_MAX && !used[e / 2]) {
      const std::size_t k = e / 2;
      used[k] = 1;
      const std::size_t exit = e ^ 1;
      const auto& l = lines[k];
      if (e % 2 == 0) {
        lane.insert(lane.end(), l.begin(), l.end());
      } else {
        lane.insert(lane.end(), l.rbegin(), l.rend());
      }
      e = mate[exit];
    }
    lanes.push_back(std::move(lane));
  };
  for (std::size_t e = 0; e < 2 * n; ++e)
    if (!used[e / 2] && mate[e] == SIZE_MAX) walk(e);
  for (std::size_t k = 0; k < n; ++k)
    if (!used[k]) {
      walk(2 * k);
      lanes.back().push_back(lanes.back().front());  // round: closed
    }
  return lanes;
}

namespace {

// Whether a straight connector a-b stays inside the region: no crossing of its edges between
// the ends, and its middle inside.
class Inside {
 public:
  explicit Inside(const Regions& region)
      : region_(region), edges_(rings_of(region), {-1e18, -1e18}, {1e18, 1e18}) {}
  bool segment(Vec2 a, Vec2 b) {
    const double len = dist(a, b);
    if (!(len > 0)) return true;
    ts_.clear();
    edges_.crossings(a, b, ts_);
    const double eps = 1e-7 / len;
    for (const double t : ts_)
      if (t > eps && t < 1 - eps) return false;
    const Vec2 m = (a + b) * 0.5;
    for (const auto& poly : region_)
      if (contains(poly, m, 1e-6)) return true;
    return false;
  }

 private:
  const Regions& region_;
  EdgeGrid edges_;
  std::vector<double> ts_;
};

struct Entry {
  std::size_t piece;
  std::size_t at;  // open: 0 (front) or 1 (back); closed: the edge from point `at`
};

// Whether a connector may join two pieces (ChainOptions), painting those that do.
class Connectors {
 public:
  Connectors(const Regions& inner, const ChainOptions& o) : inside_(inner), o_(o) {}
  double reach() const {
    return std::max(o_.max_connector, o_.raster ? o_.max_boundary_connector : 0.0);
  }
  bool join(Vec2 a, Vec2 b) {
    const double d = dist(a, b);
    if (d > reach() || !(d <= o_.max_connector || mostly_uncovered(a, b)) || !inside_.segment(a, b))
      return false;
    if (o_.raster) o_.raster->paint(a, b, o_.bead / 2);
    return true;
  }

 private:
  // A long connector's centre line, half a bead in from both ends, at most half covered.
  bool mostly_uncovered(Vec2 a, Vec2 b) const {
    const double len = dist(a, b), px = o_.raster->pixel();
    const int n = static_cast<int>((len - o_.bead) / px);
    if (n <= 0) return true;
    int covered = 0;
    for (int k = 0; k < n; ++k) {
      const double t = (o_.bead / 2 + (k + 0.5) * (len - o_.bead) / n) / len;
      covered += o_.raster->covered_at(a + (b - a) * t);
    }
    return 2 * covered <= n;
  }
  Inside inside_;
  const ChainOptions& o_;
};

// Appends `p` to `chain`, without repeating a point where they meet.
void append(std::vector<Vec2>& chain, const std::vector<Vec2>& p) {
  const bool same = !chain.empty() && !p.empty() && dist(chain.back(), p.front()) <= 1e-9;
  chain.insert(chain.end(), p.begin() + (same ? 1 : 0), p.end());
}

// Closed rings chained nearest first from `cursor`: each entered at its point nearest the last
// end, a new chain where none is within reach with a connector that may join.
std::vector<std::vector<Vec2>> ring_chains(const std::vector<std::vector<Vec2>>& rings,
                                           Connectors& join, Vec2& cursor) {
  std::vector<std::vector<Vec2>> out;
  std::vector<char> used(rings.size(), 0);
  std::vector<Vec2> chain;
  Vec2 at = cursor;
  struct Point {
    std::size_t edge = 0;
    Vec2 q;
  };
  auto nearest = [&](std::size_t k, Vec2 from) {
    const auto& p = rings[k];
    Point best{0, p.front()};
    double bd = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i + 1 < p.size(); ++i) {
      const Vec2 a = p[i], d = p[i + 1] - a;
      const double l2 = d.x * d.x + d.y * d.y;
      const double t =
          l2 > 0 ? std::clamp(((from.x - a.x) * d.x + (from.y - a.y) * d.y) / l2, 0.0, 1.0) : 0.0;
      const Vec2 q = a + d * t;
      if (dist(from, q) < bd) bd = dist(from, q), best = {i, q};
    }
    return best;
  };
  for (std::size_t left = rings.size(); left > 0; --left) {
    std::vector<std::pair<double, std::size_t>> near;
    for (std::size_t k = 0; k < rings.size(); ++k)
      if (!used[k]) near.push_back({dist(at, nearest(k, at).q), k});
    std::sort(near.begin(), near.end());
    std::size_t pick = near.front().second;
    bool linked = false;
    if (!chain.empty())
      for (const auto& [d, k] : near) {
        if (d > join.reach()) break;
        if (join.join(at, nearest(k, at).q)) {
          pick = k, linked = true;
          break;
        }
      }
    if (!linked) {
      if (chain.size() >= 2) out.push_back(std::move(chain));
      chain.clear();
    }
    used[pick] = 1;
    // Round the ring from the entry: the points after its edge, back to the entry.
    const auto& p = rings[pick];
    const Point entry = nearest(pick, at);
    std::vector<Vec2> ring{entry.q};
    const std::size_t count = p.size() - 1;  // distinct points
    for (std::size_t k = 1; k <= count; ++k) {
      const Vec2 v = p[(entry.edge + k) % count];
      if (dist(v, ring.back()) > 1e-9) ring.push_back(v);
    }
    if (dist(ring.back(), entry.q) > 1e-9) ring.push_back(entry.q);
    append(chain, ring);
    at = chain.back();
  }
  if (chain.size() >= 2) out.push_back(std::move(chain));
  cursor = at;
  return out;
}

// Open pieces joined end to end into as few chains as the connectors allow: every pair of ends
// within reach, shortest first, joined where both ends are free, the two pieces are not yet in
// one chain and the connector may join (a greedy matching: serpentines along the boundaries).
std::vector<std::vector<Vec2>> match_ends(const std::vector<std::vector<Vec2>>& pieces,
                                          Connectors& join) {
  const std::size_t n = pieces.size();
  std::vector<Vec2> at(2 * n);
  for (std::size_t k = 0; k < n; ++k)
    at[2 * k] = pieces[k].front(), at[2 * k + 1] = pieces[k].back();
  const auto links = end_pairs(at, join.reach(), [](std::size_t, std::size_t) { return true; });
  std::vector<std::size_t> root(n), mate(2 * n, SIZE_MAX);
  for (std::size_t k = 0; k < n; ++k) root[k] = k;
  auto find = [&](std::size_t k) {
    while (root[k] != k) k = root[k] = root[root[k]];
    return k;
  };
  for (const EndPair& l : links) {
    if (mate[l.e] != SIZE_MAX || mate[l.f] != SIZE_MAX || find(l.e / 2) == find(l.f / 2)) continue;
    if (!join.join(at[l.e], at[l.f])) continue;
    mate[l.e] = l.f, mate[l.f] = l.e;
    root[find(l.e / 2)] = find(l.f / 2);
  }
  // Each chain from one of its free ends (no chain closes: joins never link one chain to itself).
  std::vector<std::vector<Vec2>> out;
  std::vector<char> used(n, 0);
  for (std::size_t e = 0; e < 2 * n; ++e) {
    if (used[e / 2] || mate[e] != SIZE_MAX) continue;
    std::vector<Vec2> chain;
    for (std::size_t in = e; in != SIZE_MAX;) {
      const std::size_t k = in / 2;
      used[k] = 1;
      if (in % 2 == 0) {
        append(chain, pieces[k]);
      } else {
        append(chain, std::vector<Vec2>(pieces[k].rbegin(), pieces[k].rend()));
      }
      in = mate[in ^ 1];
    }
    if (chain.size() >= 2) out.push_back(std::move(chain));
  }
  return out;
}

// Open pieces chained nearest first from `cursor`: the nearest end within reach whose
// connector may join (serpentines: the next line's end), else a new chain at the nearest end.
std::vector<std::vector<Vec2>> nearest_chains(std::vector<std::vector<Vec2>> pieces,
                                              Connectors& join, Vec2& cursor) {
  const std::size_t n = pieces.size();
  std::vector<Vec2> at(2 * n);
  for (std::size_t k = 0; k < n; ++k)
    at[2 * k] = pieces[k].front(), at[2 * k + 1] = pieces[k].back();
  const double reach = join.reach(), cell = std::max(reach, 1e-3);
  auto key = [&](Vec2 q) {
    return std::pair<long, long>{static_cast<long>(std::floor(q.x / cell)),
                                 static_cast<long>(std::floor(q.y / cell))};
  };
  std::map<std::pair<long, long>, std::vector<std::size_t>> grid;
  for (std::size_t e = 0; e < 2 * n; ++e) grid[key(at[e])].push_back(e);
  std::vector<char> used(n, 0);
  std::vector<std::vector<Vec2>> out;
  std::vector<Vec2> chain;
  Vec2 here = cursor;
  std::vector<std::pair<double, std::size_t>> near;
  auto take = [&](std::size_t e) {
    used[e / 2] = 1;
    const auto& p = pieces[e / 2];
    if (e % 2 == 0) {
      append(chain, p);
    } else {
      append(chain, std::vector<Vec2>(p.rbegin(), p.rend()));
    }
    here = chain.back();
  };
  for (std::size_t left = n; left > 0; --left) {
    near.clear();
    if (!chain.empty()) {
      const auto c = key(here);
      for (long x = c.first - 1; x <= c.first + 1; ++x)
        for (long y = c.second - 1; y <= c.second + 1; ++y) {
          const auto it = grid.find({x, y});
          if (it == grid.end()) continue;
          for (const std::size_t e : it->second)
            if (!used[e / 2] && dist(here, at[e]) <= reach) near.push_back({dist(here, at[e]), e});
        }
      std::sort(near.begin(), near.end());
    }
    bool linked = false;
    for (const auto& [d, e] : near)
      if (join.join(here, at[e])) {
        take(e);
        linked = true;
        break;
      }
    if (linked) continue;
    if (chain.size() >= 2) out.push_back(std::move(chain));
    chain.clear();
    double bd = std::numeric_limits<double>::infinity();
    std::size_t pick = 0;
    for (std::size_t e = 0; e < 2 * n; ++e)
      if (!used[e / 2] && dist(here, at[e]) < bd) bd = dist(here, at[e]), pick = e;
    take(pick);
  }
  if (chain.size() >= 2) out.push_back(std::move(chain));
  cursor = here;
  return out;
}

}  // namespace

std::vector<std::vector<Vec2>> chain_pieces(std::vector<std::vector<Vec2>> pieces,
                                            const Regions& inner, const ChainOptions& o,
                                            Vec2& cursor) {
  std::erase_if(pieces, [](const std::vector<Vec2>& p) { return p.size() < 2; });
  Connectors join(inner, o);
  std::vector<std::vector<Vec2>> rings, open;
  for (auto& p : pieces) {
    // A ring the material balance trimmed (where its end runs onto its start, or where it
    // pinches to less than two beads across) is closed again across the gap when that is a
    // short connector: a loop entered anywhere.
    const double gap = dist(p.front(), p.back());
    double len = 0;
    for (std::size_t k = 1; k < p.size(); ++k) len += dist(p[k - 1], p[k]);
    if (p.size() > 3 && gap > 1e-9 && gap <= o.max_connector && len > 8 * o.bead &&
        join.join(p.back(), p.front()))
      p.push_back(p.front());
    (p.size() > 3 && dist(p.front(), p.back()) < 1e-9 ? rings : open).push_back(std::move(p));
  }
  // Rings ring to ring (whole loops, each entered near where the last ended), then everything
  // open (rings so chained, lines, gap fill) joined end to end.
  Vec2 at = cursor;
  for (auto& c : ring_chains(rings, join, at)) open.push_back(std::move(c));
  // Nearest first (serpentines), then chains whose ends meet joined (one entered in the middle of
  // a row of lines leaves the rest of the row to another chain that begins beside it).
  auto chains = match_ends(nearest_chains(std::move(open), join, at), join);
  // The chains nearest first from the cursor, each from its nearer end.
  std::vector<std::vector<Vec2>> out;
  std::vector<char> used(chains.size(), 0);
  for (std::size_t n = 0; n < chains.size(); ++n) {
    double bd = std::numeric_limits<double>::infinity();
    std::size_t pick = 0;
    bool back = false;
    for (std::size_t k = 0; k < chains.size(); ++k) {
      if (used[k]) continue;
      if (dist(cursor, chains[k].front()) < bd)
        bd = dist(cursor, chains[k].front()), pick = k, back = false;
      if (dist(cursor, chains[k].back()) < bd)
        bd = dist(cursor, chains[k].back()), pick = k, back = true;
    }
    used[pick] = 1;
    if (back) std::reverse(chains[pick].begin(), chains[pick].end());
    cursor = chains[pick].back();
    out.push_back(std::move(chains[pick]));
  }
  return out;
}

std::vector<Island> islands(const std::vector<ColorFace>& faces, const std::vector<Regions>& inners,
                            std::vector<std::vector<std::vector<Vec2>>> pieces) {
  std::vector<Island> out;
  for (std::size_t fi = 0; fi < faces.size() && fi < inners.size() && fi < pieces.size(); ++fi) {
    const std::size_t first = out.size();
    for (const auto& poly : inners[fi]) out.push_back({poly, faces[fi].color, {}});
    for (auto& piece : pieces[fi]) {
      if (piece.empty()) continue;
      // The polygon that holds the piece (its first point lies on or inside it); the nearest
      // by its outline where rounding leaves it just outside all of them.
      std::size_t pick = first;
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t k = first; k < out.size(); ++k) {
        if (contains(out[k].region, piece.front(), 1e-6)) {
          pick = k;
          break;
        }
        for (const Vec2 v : out[k].region.outer) {
          const double d = dist(v, piece.front());
          if (d < best) best = d, pick = k;
        }
      }
      if (pick < out.size()) out[pick].pieces.push_back(std::move(piece));
    }
  }
  std::erase_if(out, [](const Island& i) { return i.pieces.empty(); });
  return out;
}

double island_distance(const Island& island, Vec2 p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& piece : island.pieces)
    for (const Vec2 v : piece) best = std::min(best, dist(v, p));
  return best;
}

}  // namespace trellis::fgm
