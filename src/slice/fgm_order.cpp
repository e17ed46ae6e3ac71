// Strategy 1 in path order: paths cut at the colour zones' edges into joined pieces
// (src/slice/fgm_order.hpp).
#include "fgm_order.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace trellis::fgm {

namespace {

double cross(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}
double len2(Vec2 a, Vec2 b) {
  return std::hypot(b.x - a.x, b.y - a.y);
}

}  // namespace

EdgeGrid::EdgeGrid(const std::vector<std::vector<Vec2>>& rings, Vec2 lo, Vec2 hi) {
  const double eps = 1e-7 * std::max({1.0, hi.x - lo.x, hi.y - lo.y});
  auto on_border = [&](Vec2 a, Vec2 b) {
    return (std::abs(a.x - lo.x) <= eps && std::abs(b.x - lo.x) <= eps) ||
           (std::abs(a.x - hi.x) <= eps && std::abs(b.x - hi.x) <= eps) ||
           (std::abs(a.y - lo.y) <= eps && std::abs(b.y - lo.y) <= eps) ||
           (std::abs(a.y - hi.y) <= eps && std::abs(b.y - hi.y) <= eps);
  };
  Vec2 bmin{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  Vec2 bmax{-bmin.x, -bmin.y};
  for (const auto& ring : rings)
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const Vec2 a = ring[i], b = ring[(i + 1) % ring.size()];
      if (on_border(a, b) || (a.x == b.x && a.y == b.y)) continue;
      edges_.push_back({a, b});
      bmin = {std::min({bmin.x, a.x, b.x}), std::min({bmin.y, a.y, b.y})};
      bmax = {std::max({bmax.x, a.x, b.x}), std::max({bmax.y, a.y, b.y})};
    }
  if (edges_.empty()) return;
  // About two edges a cell.
  const double w = bmax.x - bmin.x, h = bmax.y - bmin.y;
  cell_ = std::clamp(std::sqrt(std::max(w * h, 1e-6) / static_cast<double>(edges_.size()) * 2),
                     0.25, 20.0);
  origin_ = bmin;
  nx_ = static_cast<long>(w / cell_) + 1;
  ny_ = static_cast<long>(h / cell_) + 1;
  std::vector<std::size_t> count(static_cast<std::size_t>(nx_ * ny_) + 1, 0);
  for (const Edge& e : edges_) visit_cells(e.a, e.b, [&](std::size_t c) { ++count[c + 1]; });
  for (std::size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
  first_ = count;
  ids_.resize(count.back());
  for (std::size_t k = 0; k < edges_.size(); ++k)
    visit_cells(edges_[k].a, edges_[k].b, [&](std::size_t c) { ids_[count[c]++] = k; });
  stamp_.assign(edges_.size(), 0);
}

// The cells of the box around a-b, clamped to the grid.
template <class Visit>
void EdgeGrid::visit_cells(Vec2 a, Vec2 b, const Visit& visit) const {
  auto index = [&](double v, double o, long n) {
    return std::clamp(static_cast<long>(std::floor((v - o) / cell_)), 0L, n - 1);
  };
  const long i0 = index(std::min(a.x, b.x), origin_.x, nx_),
             i1 = index(std::max(a.x, b.x), origin_.x, nx_);
  const long j0 = index(std::min(a.y, b.y), origin_.y, ny_),
             j1 = index(std::max(a.y, b.y), origin_.y, ny_);
  for (long j = j0; j <= j1; ++j)
    for (long i = i0; i <= i1; ++i) visit(static_cast<std::size_t>(j * nx_ + i));
}

void EdgeGrid::crossings(Vec2 a, Vec2 b, std::vector<double>& ts) {
  if (edges_.empty()) return;
  const Vec2 d = b - a;
  const double len = std::hypot(d.x, d.y);
  if (!(len > 0)) return;
  ++query_;
  // Long segments in steps of a cell, so each step's box covers a few cells only.
  const int steps = std::max(1, static_cast<int>(std::ceil(len / cell_)));
  constexpr double kSlack = 1e-12;
  for (int s = 0; s < steps; ++s) {
    const Vec2 p = a + d * (static_cast<double>(s) / steps);
    const Vec2 q = a + d * (static_cast<double>(s + 1) / steps);
    visit_cells(p, q, [&](std::size_t c) {
      for (std::size_t k = first_[c]; k < first_[c + 1]; ++k) {
        const std::size_t id = ids_[k];
        if (stamp_[id] == query_) continue;
        stamp_[id] = query_;
        const Edge& e = edges_[id];
        const Vec2 f = e.b - e.a;
        const double den = cross(d, f);
        if (std::abs(den) <= 1e-18 * len * std::hypot(f.x, f.y)) continue;  // parallel
        const Vec2 g = e.a - a;
        const double t = cross(g, f) / den, u = cross(g, d) / den;
        if (t >= -kSlack && t <= 1 + kSlack && u >= -kSlack && u <= 1 + kSlack)
          ts.push_back(std::clamp(t, 0.0, 1.0));
      }
    });
  }
}

std::vector<Piece> split_paths(
    const std::vector<Path>& paths, EdgeGrid& edges,
    const std::function<void(const std::vector<Vec2>&, std::vector<int>&)>& zones_at,
    const std::function<int(int)>& colour_of, const Palette& palette) {
  std::vector<Piece> out;
  std::vector<double> ts;
  struct Cut {
    std::size_t seg;  // the cut lies on segment seg (points seg, seg + 1) at t
    double t, s;      // s: arc length from the path's start
  };
  std::vector<Cut> cuts;
  std::vector<double> at;  // arc length at each vertex
  std::vector<Vec2> mids;  // each run's middle and zone
  std::vector<int> run_zones;
  for (const Path& path : paths) {
    const auto& pts = path.points;
    if (pts.size() < 2) continue;
    at.assign(pts.size(), 0.0);
    for (std::size_t i = 1; i < pts.size(); ++i)
      at[i] = at[i - 1] + len2(pts[i - 1].xy(), pts[i].xy());
    const double total = at.back();
    if (!(total > 0)) continue;
    cuts.assign(1, {0, 0.0, 0.0});
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
      const double l = at[i + 1] - at[i];
      if (!(l > 0)) continue;
      ts.clear();
      edges.crossings(pts[i].xy(), pts[i + 1].xy(), ts);
      std::sort(ts.begin(), ts.end());
      for (const double t : ts) {
        const double s = at[i] + t * l;
        // Crossings at the same place (a vertex shared by two segments, or an edge end) once.
        if (s - cuts.back().s > 1e-9 && total - s > 1e-9) cuts.push_back({i, t, s});
      }
    }
    cuts.push_back({pts.size() - 2, 1.0, total});
    auto point_at = [&](const Cut& c) {
      const Vec3 a = pts[c.seg], b = pts[c.seg + 1];
      return c.t <= 0 ? a : c.t >= 1 ? b : a + (b - a) * c.t;
    };
    // The zone of each run between cuts, from the design at its middle.
    auto middle = [&](const Cut& c0, const Cut& c1) {
      const double s = 0.5 * (c0.s + c1.s);
      std::size_t i =
          static_cast<std::size_t>(std::upper_bound(at.begin(), at.end(), s) - at.begin());
      i = std::clamp<std::size_t>(i, 1, pts.size() - 1) - 1;
      while (i + 1 < pts.size() - 1 && !(at[i + 1] > at[i])) ++i;
      const double l = at[i + 1] - at[i];
      const double t = l > 0 ? std::clamp((s - at[i]) / l, 0.0, 1.0) : 0.0;
      return (pts[i] + (pts[i + 1] - pts[i]) * t).xy();
    };
    // Piece boundaries: the cuts where the zone changes.
    mids.resize(cuts.size() - 1);
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) mids[k] = middle(cuts[k], cuts[k + 1]);
    zones_at(mids, run_zones);
    std::vector<std::size_t> bounds{0};
    std::vector<int> zones;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
      const int zone = run_zones[k];
      if (zones.empty() || zone != zones.back()) {
        if (!zones.empty()) bounds.push_back(k);
        zones.push_back(zone);
      }
    }
    bounds.push_back(cuts.size() - 1);
    Path proto = path;
    proto.points = {};
    for (std::size_t p = 0; p + 1 < bounds.size(); ++p) {
      const Cut& c0 = cuts[bounds[p]];
      const Cut& c1 = cuts[bounds[p + 1]];
      Piece piece{proto, colour_of(zones[p])};
      piece.path.mixture = palette.mixture(piece.color);
      piece.path.joined = p > 0 || path.joined;
      if (p > 0) piece.path.via.clear();  // the travel into the path is the first piece's
      auto& q = piece.path.points;
      q.push_back(point_at(c0));
      // The vertices strictly between the two cuts.
      for (std::size_t v = c0.seg + 1; v <= c1.seg && v < pts.size(); ++v)
        if (at[v] - c0.s > 1e-9 && c1.s - at[v] > 1e-9) q.push_back(pts[v]);
      q.push_back(point_at(c1));
      out.push_back(std::move(piece));
    }
  }
  return out;
}

std::vector<std::vector<double>> design_along(Evaluator& ev, double z, const Path& p) {
  std::vector<Vec3> q;
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    const Vec2 a = p.points[i].xy();
    q.push_back({a.x, a.y, z});
    if (i + 1 == p.points.size()) break;
    const Vec2 b = p.points[i + 1].xy(), d = b - a;
    const int n = static_cast<int>(std::ceil(std::hypot(d.x, d.y) / 0.1));
    for (int k = 1; k < n; ++k) {
      const Vec2 s = a + d * (static_cast<double>(k) / n);
      q.push_back({s.x, s.y, z});
    }
  }
  // All the samples at once.
  const std::size_t m = ev.field().materials().size();
  std::vector<double> f(q.size() * m);
  if (!q.empty()) ev.fractions(q.data(), q.size(), f.data());
  std::vector<std::vector<double>> out(q.size());
  for (std::size_t i = 0; i < q.size(); ++i)
    out[i].assign(f.begin() + static_cast<std::ptrdiff_t>(i * m),
                  f.begin() + static_cast<std::ptrdiff_t>((i + 1) * m));
  return out;
}

double mixture_error(const std::vector<std::vector<double>>& f, const std::vector<double>& mix,
                     bool worst) {
  double e = 0, sum = 0;
  for (const auto& s : f) {
    double es = 0;
    for (std::size_t m = 0; m < s.size() && m < mix.size(); ++m)
      es = std::max(es, std::abs(std::clamp(s[m], 0.0, 1.0) - mix[m]));
    e = std::max(e, es);
    sum += es;
  }
  return worst ? e : (f.empty() ? 0.0 : sum / static_cast<double>(f.size()));
}

void merge_short_runs(std::vector<Piece>& pieces, Evaluator& ev, double z, const Palette& palette,
                      double min, double tolerance, FgmStats& st) {
  if (!(min > 0) || pieces.empty()) return;
  const double bound = palette.error_bound() + tolerance;
  std::vector<Piece> out;
  out.reserve(pieces.size());
  std::vector<Piece> bead;
  auto append = [](Path& to, const Path& from) {
    to.points.insert(to.points.end(), from.points.begin() + 1, from.points.end());
  };
  auto flush = [&] {
    // One bead's pieces: each short one tried once, left to right.
    for (std::size_t i = 0; i < bead.size() && bead.size() > 1;) {
      if (!(bead[i].path.length() < min)) {
        ++i;
        continue;
      }
      const auto f = design_along(ev, z, bead[i].path);
      std::size_t best = i;
      double best_mean = std::numeric_limits<double>::infinity();
      for (const std::size_t j : {i - 1, i + 1}) {  // i - 1 wraps to SIZE_MAX at i = 0
        if (j >= bead.size()) continue;
        const double m = mixture_error(f, bead[j].path.mixture, false);
        if (m < best_mean) best_mean = m, best = j;
      }
      if (mixture_error(f, bead[best].path.mixture, true) > bound) {
        ++st.short_kept_bound;
        ++i;
        continue;
      }
      ++st.short_merged;
      if (best < i) {
        append(bead[best].path, bead[i].path);
      } else {
        Path& next = bead[best].path;
        next.points.insert(next.points.begin(), bead[i].path.points.begin(),
                           bead[i].path.points.end() - 1);
        next.joined = bead[i].path.joined;
        next.via = bead[i].path.via;  // the travel into the bead, if it began it
        next.inside = bead[i].path.inside;
      }
      bead.erase(bead.begin() + static_cast<long>(i));
      // The pieces on both sides of it may now be of one colour: one piece.
      const std::size_t l = best < i ? best : i - 1;
      if (i > 0 && l + 1 < bead.size() && bead[l].color == bead[l + 1].color) {
        append(bead[l].path, bead[l + 1].path);
        bead.erase(bead.begin() + static_cast<long>(l + 1));
      }
      // The piece now at i is next (a grown next piece, or the one after a grown previous).
    }
    for (auto& p : bead) out.push_back(std::move(p));
    bead.clear();
  };
  for (auto& p : pieces) {
    if (!p.path.joined) flush();
    bead.push_back(std::move(p));
  }
  flush();
  pieces = std::move(out);
}

void group_by_tool(std::vector<Piece>& pieces, bool reverse, Vec2& cursor) {
  std::vector<int> colours;
  for (const auto& p : pieces) colours.push_back(p.color);
  std::sort(colours.begin(), colours.end());
  colours.erase(std::unique(colours.begin(), colours.end()), colours.end());
  if (reverse) std::reverse(colours.begin(), colours.end());
  std::vector<Piece> out;
  out.reserve(pieces.size());
  std::vector<std::size_t> mine;
  for (const int c : colours) {
    mine.clear();
    for (std::size_t k = 0; k < pieces.size(); ++k)
      if (pieces[k].color == c) mine.push_back(k);
    std::vector<char> used(mine.size(), 0);
    for (std::size_t n = 0; n < mine.size(); ++n) {
      // The nearest entry: either end of an open piece, any vertex of a closed one.
      double best = std::numeric_limits<double>::infinity();
      std::size_t pick = 0, vertex = 0;
      for (std::size_t m = 0; m < mine.size(); ++m) {
        if (used[m]) continue;
        const auto& pts = pieces[mine[m]].path.points;
        const bool closed = pts.size() > 3 && len2(pts.front().xy(), pts.back().xy()) < 1e-9;
        auto consider = [&](std::size_t v) {
          const double d = len2(cursor, pts[v].xy());
          if (d < best) best = d, pick = m, vertex = v;
        };
        if (closed) {
          for (std::size_t v = 0; v + 1 < pts.size(); ++v) consider(v);
        } else {
          consider(0);
          consider(pts.size() - 1);
        }
      }
      used[pick] = 1;
      Piece p = std::move(pieces[mine[pick]]);
      auto& pts = p.path.points;
      const bool closed = pts.size() > 3 && len2(pts.front().xy(), pts.back().xy()) < 1e-9;
      if (closed && vertex > 0) {
        std::vector<Vec3> ring(pts.begin() + static_cast<long>(vertex), pts.end() - 1);
        ring.insert(ring.end(), pts.begin(), pts.begin() + static_cast<long>(vertex) + 1);
        pts = std::move(ring);
      } else if (!closed && vertex > 0) {
        std::reverse(pts.begin(), pts.end());
      }
      // Pieces that meet end to start (a wall cut at its seam) stay one bead.
      p.path.joined = !out.empty() && out.back().color == c &&
                      len2(out.back().path.points.back().xy(), pts.front().xy()) < 1e-9;
      // Reordered: the travel into it is no longer the one planned (a straight move).
      p.path.via.clear();
      p.path.inside = false;
      cursor = pts.back().xy();
      out.push_back(std::move(p));
    }
  }
  pieces = std::move(out);
}

}  // namespace trellis::fgm
