#include "trellis/geom/regions.hpp"

#include <algorithm>
#include <clipper.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "clipper_util.hpp"

namespace trellis {

namespace cl = ClipperLib;

namespace {

using clipper_util::from_int;
using clipper_util::nest_paths;
using clipper_util::to_path;

cl::Paths to_paths(const Regions& regions) {
  cl::Paths out;
  for (const auto& p : regions) {
    if (p.outer.size() >= 3) out.push_back(to_path(p.outer));
    for (const auto& h : p.holes)
      if (h.size() >= 3) out.push_back(to_path(h));
  }
  return out;
}
Regions boolean(const Regions& a, const Regions& b, cl::ClipType type) {
  cl::Clipper clipper;
  clipper.AddPaths(to_paths(a), cl::ptSubject, true);
  clipper.AddPaths(to_paths(b), cl::ptClip, true);
  cl::Paths out;
  clipper.Execute(type, out, cl::pftEvenOdd, cl::pftEvenOdd);
  return nest_paths(out);
}

// Douglas-Peucker over the points at(0) .. at(m - 1) in XY: keep[k] set for the points kept. The
// arithmetic of simplify_polyline on these points with z = 0, term for term (the z terms add
// +0.0, which only the dot product of the projection can need: a -0.0 there), so the same
// points are kept.
template <class At>
void douglas_peucker_xy(std::size_t m, const At& at, double tol, std::vector<char>& keep,
                        std::vector<std::pair<std::size_t, std::size_t>>& stack) {
  keep.assign(m, 0);
  keep.front() = keep.back() = 1;
  stack.assign(1, {0, m - 1});
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    const Vec2 a = at(i), ab = at(j) - a;
    const double len2 = ab.x * ab.x + ab.y * ab.y;
    double best = -1;
    std::size_t k = i;
    for (std::size_t q = i + 1; q < j; ++q) {
      const Vec2 p = at(q), pa = p - a;
      double t = len2 > 0 ? (pa.x * ab.x + pa.y * ab.y + 0.0) / len2 : 0.0;
      t = std::clamp(t, 0.0, 1.0);
      const Vec2 c = p - (a + ab * t);
      const double d = std::sqrt(c.x * c.x + c.y * c.y);
      if (d > best) best = d, k = q;
    }
    if (best > tol) {
      keep[k] = 1;
      stack.push_back({i, k});
      stack.push_back({k, j});
    }
  }
}

std::vector<Vec2> simplify_ring(const std::vector<Vec2>& ring, double tol) {
  const std::size_t n = ring.size();
  if (n < 4 || tol <= 0) return ring;
  // Split at the point farthest from point 0 (the first of the farthest by std::hypot),
  // simplify both halves. Squared distances first: only points within 1e-9 of the largest can
  // be the farthest by hypot (their rounding is some 1e-16), so hypot runs for those alone.
  double most = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double dx = ring[i].x - ring[0].x, dy = ring[i].y - ring[0].y;
    most = std::max(most, dx * dx + dy * dy);
  }
  const double near_most = most * (1 - 1e-9);
  std::size_t far = 0;
  double best = -1;
  for (std::size_t i = 1; i < n; ++i) {
    const double dx = ring[i].x - ring[0].x, dy = ring[i].y - ring[0].y;
    if (!(dx * dx + dy * dy >= near_most)) continue;
    const double d = std::hypot(dx, dy);
    if (d > best) {
      best = d;
      far = i;
    }
  }
  if (far == 0) {  // no squared distance compares (NaN): as before, hypot for every point
    for (std::size_t i = 1; i < n; ++i) {
      const double d = std::hypot(ring[i].x - ring[0].x, ring[i].y - ring[0].y);
      if (d > best) best = d, far = i;
    }
  }
  // The two open halves, 0..far and far..0 (point n is point 0 again), each simplified on its
  // own, in place.
  thread_local std::vector<char> keep_a, keep_b;
  thread_local std::vector<std::pair<std::size_t, std::size_t>> stack;
  douglas_peucker_xy(
      far + 1, [&](std::size_t k) { return ring[k]; }, tol, keep_a, stack);
  douglas_peucker_xy(
      n - far + 1, [&](std::size_t k) { return ring[far + k == n ? 0 : far + k]; }, tol, keep_b,
      stack);
  std::vector<Vec2> out;
  for (std::size_t i = 0; i <= far; ++i)
    if (keep_a[i]) out.push_back(ring[i]);
  for (std::size_t k = 1; k + 1 < keep_b.size(); ++k)
    if (keep_b[k]) out.push_back(ring[far + k]);
  return out.size() >= 3 ? out : ring;
}

}  // namespace

double signed_area(const std::vector<Vec2>& ring) {
  double a = 0;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
    a += (ring[j].x * ring[i].y - ring[i].x * ring[j].y);
  return ring.size() < 3 ? 0.0 : 0.5 * a;
}
double area(const Polygon2& p) {
  double a = std::abs(signed_area(p.outer));
  for (const auto& h : p.holes) a -= std::abs(signed_area(h));
  return a;
}
double area(const Regions& regions) {
  double a = 0;
  for (const auto& p : regions) a += area(p);
  return a;
}

Regions offset(const Regions& regions, double delta, double arc_tolerance, double miter_limit) {
  // Orientation must be consistent for the offsetter: outer CCW, holes CW (our invariant).
  cl::Paths rings;
  for (const auto& p : regions) {
    if (p.outer.size() >= 3) {
      cl::Path& path = rings.emplace_back(to_path(p.outer));
      if (!cl::Orientation(path)) cl::ReversePath(path);
    }
    for (const auto& h : p.holes) {
      if (h.size() < 3) continue;
      cl::Path& path = rings.emplace_back(to_path(h));
      if (cl::Orientation(path)) cl::ReversePath(path);
    }
  }
  cl::Paths out;
  // Most offsets of a slice need no clean-up; those that do go through ClipperOffset.
  if (clipper_util::offset_directly(rings, delta * kClipperScale, miter_limit, out))
    return nest_paths(out);
  cl::ClipperOffset off(miter_limit, std::max(arc_tolerance, 1e-6) * kClipperScale);
  off.AddPaths(rings, cl::jtMiter, cl::etClosedPolygon);
  off.Execute(out, delta * kClipperScale);
  return nest_paths(out);
}

Regions stroke(const std::vector<std::vector<Vec2>>& lines, double width, double arc_tolerance) {
  cl::ClipperOffset off(2.0, std::max(arc_tolerance, 1e-6) * kClipperScale);
  for (const auto& l : lines) {
    if (l.size() < 2) continue;
    const bool closed = l.size() >= 4 && l.front().x == l.back().x && l.front().y == l.back().y;
    cl::Path path = to_path(l);
    if (closed) path.pop_back();
    off.AddPath(path, cl::jtMiter, closed ? cl::etClosedLine : cl::etOpenRound);
  }
  cl::Paths out;
  off.Execute(out, 0.5 * width * kClipperScale);
  return nest_paths(out);
}

namespace {

// The rings as regions, united under one fill rule.
Regions union_of_rings(const std::vector<std::vector<Vec2>>& rings, cl::PolyFillType rule) {
  cl::Paths paths;
  for (const auto& r : rings)
    if (r.size() >= 3) paths.push_back(to_path(r));
  cl::Clipper clipper;
  clipper.AddPaths(paths, cl::ptSubject, true);
  cl::Paths out;
  clipper.Execute(cl::ctUnion, out, rule, rule);
  return nest_paths(out);
}

}  // namespace

Regions nest_rings(const std::vector<std::vector<Vec2>>& rings) {
  return union_of_rings(rings, cl::pftEvenOdd);
}

Regions unite_oriented_rings(const std::vector<std::vector<Vec2>>& rings) {
  return union_of_rings(rings, cl::pftPositive);
}

Regions nest_oriented_rings(std::vector<std::vector<Vec2>> rings) {
  struct Ring {
    std::vector<Vec2> pts;
    double area;
    double x0, y0, x1, y1;
  };
  std::vector<Ring> outers, holes;
  double total = 0;
  std::vector<double> areas(rings.size());
  for (std::size_t i = 0; i < rings.size(); ++i) {
    areas[i] = rings[i].size() >= 3 ? signed_area(rings[i]) : 0.0;
    total += areas[i];
  }
  const bool flip = total < 0;
  for (std::size_t i = 0; i < rings.size(); ++i) {
    double a = flip ? -areas[i] : areas[i];
    if (std::abs(a) < 1e-14) continue;
    if (flip) std::reverse(rings[i].begin(), rings[i].end());
    Ring r{std::move(rings[i]), a, 1e300, 1e300, -1e300, -1e300};
    for (auto p : r.pts) {
      r.x0 = std::min(r.x0, p.x);
      r.y0 = std::min(r.y0, p.y);
      r.x1 = std::max(r.x1, p.x);
      r.y1 = std::max(r.y1, p.y);
    }
    (a > 0 ? outers : holes).push_back(std::move(r));
  }
  auto inside = [](const std::vector<Vec2>& ring, Vec2 p) { return inside_ring(ring, p); };
  Regions out(outers.size());
  for (auto& h : holes) {
    // A vertex of the hole is inside its outer ring (rings do not cross).
    const Vec2 probe = h.pts.front();
    std::size_t best = outers.size();
    for (std::size_t i = 0; i < outers.size(); ++i) {
      const Ring& o = outers[i];
      if (o.x0 > h.x0 || o.y0 > h.y0 || o.x1 < h.x1 || o.y1 < h.y1) continue;
      if (best < outers.size() && o.area >= outers[best].area) continue;
      if (inside(o.pts, probe)) best = i;
    }
    if (best < outers.size()) out[best].holes.push_back(std::move(h.pts));
  }
  // (Moved once the holes have found their outer rings.)
  for (std::size_t i = 0; i < outers.size(); ++i) out[i].outer = std::move(outers[i].pts);
  return out;
}

Regions unite(const Regions& a, const Regions& b) {
  return boolean(a, b, cl::ctUnion);
}
Regions difference(const Regions& a, const Regions& b) {
  return boolean(a, b, cl::ctDifference);
}
Regions intersection(const Regions& a, const Regions& b) {
  return boolean(a, b, cl::ctIntersection);
}

std::vector<Vec3> simplify_polyline(const std::vector<Vec3>& pts, double tol) {
  if (pts.size() <= 2) return pts;
  std::vector<char> keep(pts.size(), 0);
  keep.front() = keep.back() = 1;
  std::vector<std::pair<std::size_t, std::size_t>> stack{{0, pts.size() - 1}};
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    double best = -1;
    std::size_t k = i;
    for (std::size_t t = i + 1; t < j; ++t) {
      const double d = distance_to_segment(pts[t], pts[i], pts[j]);
      if (d > best) best = d, k = t;
    }
    if (best > tol) {
      keep[k] = 1;
      stack.push_back({i, k});
      stack.push_back({k, j});
    }
  }
  std::vector<Vec3> out;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (keep[i]) out.push_back(pts[i]);
  return out;
}

Regions simplify(const Regions& regions, double tolerance) {
  Regions out;
  out.reserve(regions.size());
  for (const auto& p : regions) {
    Polygon2 q;
    q.outer = simplify_ring(p.outer, tolerance);
    for (const auto& h : p.holes) q.holes.push_back(simplify_ring(h, tolerance));
    out.push_back(std::move(q));
  }
  return out;
}

std::vector<std::vector<Vec2>> clip_polylines(const std::vector<std::vector<Vec2>>& lines,
                                              const Regions& region, bool inside) {
  std::vector<std::vector<Vec2>> out;
  if (lines.empty()) return out;
  if (region.empty()) {
    if (!inside)
      for (const auto& l : lines)
        if (l.size() >= 2) out.push_back(l);
    return out;
  }
  cl::Clipper clipper;
  cl::Paths subjects;
  for (const auto& l : lines)
    if (l.size() >= 2) subjects.push_back(to_path(l));
  clipper.AddPaths(subjects, cl::ptSubject, false);
  clipper.AddPaths(to_paths(region), cl::ptClip, true);
  cl::PolyTree tree;
  clipper.Execute(inside ? cl::ctIntersection : cl::ctDifference, tree, cl::pftEvenOdd,
                  cl::pftEvenOdd);
  cl::Paths open;
  cl::OpenPathsFromPolyTree(tree, open);
  for (const auto& path : open) {
    std::vector<Vec2> l;
    l.reserve(path.size());
    for (const auto& p : path) l.push_back(from_int(p));
    if (l.size() >= 2) out.push_back(std::move(l));
  }
  return out;
}

std::vector<std::vector<Vec2>> rings_of(const Regions& regions) {
  std::vector<std::vector<Vec2>> out;
  for (const auto& p : regions) {
    out.push_back(p.outer);
    for (const auto& h : p.holes) out.push_back(h);
  }
  return out;
}

std::vector<Segment2> hatch(const Regions& regions, double angle_deg, double spacing, Vec2 origin) {
  std::vector<Segment2> out;
  if (!(spacing > 0)) return out;
  const double a = angle_deg * std::numbers::pi / 180;
  const Vec2 u{std::cos(a), std::sin(a)}, v{-std::sin(a), std::cos(a)};  // along, across
  // Edges in (s, t) = (along, across) coordinates relative to origin, with the first line that
  // reaches them. Lines at t = k·spacing; a line exactly on a vertex counts edges half-open
  // [t0, t1), tested on the line's own t so rounding cannot move an edge to a neighbour's line.
  // Edges between two lines are left out (most of a finely sampled outline's: its edges are
  // much shorter than the spacing).
  struct Edge {
    double t0, t1, s0, s1;  // t0 < t1
    long long k;            // the first line with t0 <= k·spacing (< t1)
  };
  auto line_t = [&](long long k) { return static_cast<double>(k) * spacing; };
  // The first line at or after t (estimated from the inverse spacing, corrected on the lines'
  // own t).
  const double inv_spacing = 1 / spacing;
  auto first_line = [&](double t) {
    auto k = static_cast<long long>(t * inv_spacing);
    while (line_t(k - 1) >= t) --k;
    while (line_t(k) < t) ++k;
    return k;
  };
  std::vector<Edge> edges;
  std::size_t vertices = 0;
  for (const auto& p : regions) {
    vertices += p.outer.size();
    for (const auto& h : p.holes) vertices += h.size();
  }
  edges.reserve(vertices);
  long long k0 = std::numeric_limits<long long>::max();
  double tmax = -1e300;
  // Each vertex's across coordinate and first line are worked out once, for both its edges: an
  // edge with the same first line at both ends lies between two lines.
  auto add_ring = [&](const std::vector<Vec2>& ring) {
    Vec2 p = ring.back() - origin;
    double tp = p.x * v.x + p.y * v.y;
    long long kp = first_line(tp);
    for (const Vec2& r : ring) {
      const Vec2 q = r - origin;
      const double tq = q.x * v.x + q.y * v.y;
      const long long kq = first_line(tq);
      if (kp != kq) {  // a line in [min(tp, tq), max(tp, tq))
        // (Built in place: swapping the ends through memory and copying the edge stalled on
        // store forwarding.)
        Edge& e = edges.emplace_back();
        const double sp = p.x * u.x + p.y * u.y, sq = q.x * u.x + q.y * u.y;
        const bool up = tp < tq;
        e.t0 = up ? tp : tq;
        e.t1 = up ? tq : tp;
        e.s0 = up ? sp : sq;
        e.s1 = up ? sq : sp;
        e.k = up ? kp : kq;
        k0 = std::min(k0, e.k);
        tmax = std::max(tmax, e.t1);
      }
      p = q;
      tp = tq;
      kp = kq;
    }
  };
  for (const auto& p : regions) {
    if (p.outer.size() >= 3) add_ring(p.outer);
    for (const auto& h : p.holes)
      if (h.size() >= 3) add_ring(h);
  }
  if (edges.empty()) return out;
  const long long k1 = first_line(tmax) - 1;  // the last line before tmax
  // Edges bucketed by their first line: a counting sort instead of sorting.
  const std::size_t lines = static_cast<std::size_t>(k1 - k0 + 1);
  std::vector<std::size_t> bucket(lines + 1, 0);
  for (const Edge& e : edges) ++bucket[static_cast<std::size_t>(e.k - k0)];
  std::size_t sum = 0;
  for (auto& b : bucket) sum += std::exchange(b, sum);  // bucket[i]: start of line i's edges
  std::vector<std::size_t> order(edges.size());
  for (std::size_t e = 0; e < edges.size(); ++e)
    order[bucket[static_cast<std::size_t>(edges[e].k - k0)]++] = e;
  std::vector<std::size_t> active;
  std::size_t next = 0;
  std::vector<double> xs;
  for (long long k = k0; k <= k1; ++k) {
    const double t = line_t(k);
    while (next < edges.size() && edges[order[next]].k == k) active.push_back(order[next++]);
    xs.clear();
    std::size_t w = 0;
    for (std::size_t idx : active) {
      const Edge& e = edges[idx];
      if (e.t1 <= t) continue;  // finished: drop
      active[w++] = idx;
      if (t < e.t0) continue;
      xs.push_back(e.s0 + (e.s1 - e.s0) * (t - e.t0) / (e.t1 - e.t0));
    }
    active.resize(w);
    std::sort(xs.begin(), xs.end());
    for (std::size_t i = 0; i + 1 < xs.size(); i += 2) {
      if (xs[i + 1] - xs[i] <= 1e-9) continue;
      const Vec2 pa = origin + u * xs[i] + v * t, pb = origin + u * xs[i + 1] + v * t;
      out.push_back({pa, pb});
    }
  }
  return out;
}

}  // namespace trellis
