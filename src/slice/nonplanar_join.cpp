// Serpentines of a non-planar layer: its lines' pieces joined by nearest neighbour, each
// serpentine starting at an outer line, connectors laid on the surface between neighbouring
// lines (around a hole's edge when the straight way crosses one), travels elsewhere.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "nonplanar_internal.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis::nonplanar_detail {

namespace {

// A connector from a (the path's end) to b (the next piece's start) on the surface, its inner
// points appended to `path`: straight along the surface, or (between neighbouring lines) along
// a hole's edge. False when neither lies on the surface.
bool connect(const SurfacePoint& sp, const HeightField& surface, const NonplanarParams& prm,
             bool neighbours, Vec3 a, Vec3 b, std::vector<Vec3>& path, NonplanarLayerReport& rep) {
  auto conn = sample_curve(sp, a.xy(), b.xy(), prm.chord_tolerance * 0.5,
                           std::clamp(prm.width / 4, 0.01, 0.1));
  // Its ends must meet the pieces' in 3D too, and its chords lie on the surface: two
  // ends over a step of the surface lie one above the other, and a connector along
  // the step can reach the far side only by a chord through the air.
  auto on_surface = [&](const std::vector<Vec3>& c) {
    for (std::size_t i = 1; i < c.size(); ++i) {
      const Vec3 m = (c[i - 1] + c[i]) * 0.5;
      if (!(std::abs(sp(m.xy()).z - m.z) <= 2 * prm.chord_tolerance)) return false;
    }
    return true;
  };
  if (conn.size() == 1 && distance(conn[0].front(), a) < 1e-6 &&
      distance(conn[0].back(), b) < 1e-6 && on_surface(conn[0])) {
    auto c = simplify_polyline(conn[0], prm.chord_tolerance * 0.5);
    double clen = 0;
    for (std::size_t i = 1; i < c.size(); ++i) clen += distance(c[i - 1], c[i]);
    rep.connector_length += clen;
    path.insert(path.end(), c.begin() + 1, c.end() - 1);
    return true;
  } else if (neighbours && path.size() >= 2 &&
             hole_ahead(sp, a, path[path.size() - 2], surface.domain(), prm.width)) {
    // Around a hole: hug its edge, pushed back the way the last piece came.
    const double ang = rep.angle * std::numbers::pi / 180;
    const Vec2 d{std::cos(ang), std::sin(ang)};
    const Vec3 t = path.back() - path[path.size() - 2];
    const Vec2 away = (t.x * d.x + t.y * d.y) > 0 ? d * -1.0 : d;
    auto c = hug_connector(sp, a, b, away, std::clamp(prm.width / 4, 0.01, 0.1),
                           std::max(10 * distance_xy(a, b), 10 * prm.width), prm.chord_tolerance);
    if (!c.empty() && on_surface(c)) {
      double clen = 0;
      for (std::size_t i = 1; i < c.size(); ++i) clen += distance(c[i - 1], c[i]);
      rep.connector_length += clen;
      ++rep.hole_joins;
      path.insert(path.end(), c.begin() + 1, c.end() - 1);
      return true;
    }
  }
  return false;
}

}  // namespace

void join_layer(const HeightField& surface, const NonplanarParams& prm, const HeightField::Eval& f,
                double max_join, std::vector<Line>& lines, Vec3& cursor, NonplanarLayerReport& rep,
                Layer& layer, double& max_descent_deg) {
  std::vector<std::vector<Vec3>> pieces;
  std::vector<char> extreme;  // pieces of the first and last line that has any
  std::vector<long> line_of;  // line index of each piece
  {
    long first = -1, last = -1;
    for (std::size_t i = 0; i < lines.size(); ++i)
      if (!lines[i].pieces.empty()) {
        if (first < 0) first = static_cast<long>(i);
        last = static_cast<long>(i);
      }
    for (std::size_t i = 0; i < lines.size(); ++i) rep.jumps += lines[i].jumps;
    for (std::size_t i = 0; i < lines.size(); ++i)
      for (auto& p : lines[i].pieces) {
        pieces.push_back(std::move(p));
        line_of.push_back(static_cast<long>(i));
        extreme.push_back(static_cast<long>(i) == first || static_cast<long>(i) == last);
      }
  }
  rep.lines = pieces.size();
  if (pieces.empty()) return;
  std::vector<char> used(pieces.size(), 0);
  const SurfacePoint sp{f, prm.offset, rep.offset};
  Path cur;
  auto flush = [&] {
    if (cur.points.size() >= 2) {
      cur.role = PathRole::Nonplanar;
      cur.tool = rep.tool;
      cur.width = prm.width;
      cur.height = prm.layer_height;
      cur.speed = prm.speed;
      layer.paths.push_back(std::move(cur));
    }
    cur = Path{};
  };
  std::size_t next = 0;
  long cur_line = -10;
  bool reverse = false;
  // The unused piece end nearest to `from` (among outer lines' pieces if `outer_only`),
  // another line's before one of `avoid_line`: the rest of the line just printed lies beyond
  // a gap or a jump of the surface, always a travel away. Returns false when none is left.
  auto nearest = [&](Vec3 from, bool outer_only, long avoid_line = -10) {
    double best = 1e300;
    bool other_line = false;
    for (std::size_t i = 0; i < pieces.size(); ++i) {
      if (used[i] || (outer_only && !extreme[i])) continue;
      const bool other = line_of[i] != avoid_line;
      if (other_line && !other) continue;
      for (int e = 0; e < 2; ++e) {
        // Horizontal distance; of two ends over a step of the surface (one above the other)
        // the one on the same side is the nearer.
        const Vec3 end = e ? pieces[i].back() : pieces[i].front();
        const double dd = distance_xy(from, end) + 0.01 * std::abs(end.z - from.z);
        if (dd < best || (other && !other_line))
          best = dd, next = i, reverse = e == 1, other_line = other_line || other;
      }
    }
    return best < 1e300;
  };
  // A serpentine starts at an outer line (otherwise nearest-neighbour strands the lines on
  // one side), at the end nearest to where the previous layer ended.
  if (is_finite(cursor)) nearest(cursor, true);
  for (std::size_t done = 0; done < pieces.size(); ++done) {
    auto piece = std::move(pieces[next]);
    used[next] = 1;
    if (reverse) std::reverse(piece.begin(), piece.end());
    bool joined = false;
    if (!cur.points.empty()) {
      const Vec3 a = cur.points.back(), b = piece.front();
      // A connector between neighbouring lines stays in the strip between them, where no
      // other line runs, so any length is fine; others only up to max_join.
      const bool neighbours = std::abs(line_of[next] - cur_line) == 1;
      if (neighbours || distance_xy(a, b) <= max_join)
        joined = connect(sp, surface, prm, neighbours, a, b, cur.points, rep);
      if (!joined && !extreme[next]) {
        // A travel it is: start the next serpentine at an outer line instead, as a layer
        // starts, so that one travel crosses a surface step rather than one per line.
        const std::size_t taken = next;
        const bool was_reversed = reverse;
        if (nearest(a, true)) {
          if (was_reversed) std::reverse(piece.begin(), piece.end());
          pieces[taken] = std::move(piece);
          used[taken] = 0;
          piece = std::move(pieces[next]);
          used[next] = 1;
          if (reverse) std::reverse(piece.begin(), piece.end());
        }
      }
      if (!joined) flush();
    }
    cur_line = line_of[next];
    if (!joined) {
      cur.points = std::move(piece);
    } else {
      const bool same = distance(cur.points.back(), piece.front()) < 1e-9;
      cur.points.insert(cur.points.end(), piece.begin() + (same ? 1 : 0), piece.end());
    }
    nearest(cur.points.back(), false, cur_line);
  }
  cursor = cur.points.back();
  flush();
  rep.paths = layer.paths.size();
  rep.travel_moves = rep.paths - 1;
  for (const auto& p : layer.paths) rep.length += p.length();
  for (const auto& p : layer.paths)
    for (std::size_t i = 1; i < p.points.size(); ++i) {
      const Vec3 s = p.points[i] - p.points[i - 1];
      if (s.z < 0)
        max_descent_deg = std::max(max_descent_deg,
                                   std::atan2(-s.z, std::hypot(s.x, s.y)) * 180 / std::numbers::pi);
    }
}

}  // namespace trellis::nonplanar_detail
