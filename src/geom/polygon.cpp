#include "trellis/geom/polygon.hpp"

#include <algorithm>
#include <clipper.hpp>
#include <cmath>
#include <map>
#include <numbers>

#include "clipper_util.hpp"

namespace trellis {

namespace cl = ClipperLib;

Polygon2 make_rectangle(Vec2 c, double w, double h) {
  return {{{c.x - w / 2, c.y - h / 2},
           {c.x + w / 2, c.y - h / 2},
           {c.x + w / 2, c.y + h / 2},
           {c.x - w / 2, c.y + h / 2}},
          {}};
}

Polygon2 make_circle(Vec2 c, double d, double max_error) {
  const double r = d / 2;
  // Sagitta r(1 - cos(pi/n)) <= max_error.
  const double half = std::acos(std::max(-1.0, 1.0 - max_error / r));
  const int n = std::max(16, static_cast<int>(std::ceil(std::numbers::pi / half)));
  Polygon2 p;
  for (int i = 0; i < n; ++i) {
    const double t = 2 * std::numbers::pi * i / n;
    p.outer.push_back({c.x + r * std::cos(t), c.y + r * std::sin(t)});
  }
  return p;
}

using clipper_util::to_int;
using clipper_util::to_path;

std::vector<Segment2> clip_segments(const std::vector<Segment2>& segments, const Polygon2& region) {
  std::map<std::pair<cl::cInt, cl::cInt>, Vec2> exact;
  cl::Clipper clipper;
  cl::Paths subjects;
  subjects.reserve(segments.size());
  for (const auto& s : segments) {
    const auto a = to_int(s.a), b = to_int(s.b);
    if (a == b) continue;
    exact.emplace(std::make_pair(a.X, a.Y), s.a);
    exact.emplace(std::make_pair(b.X, b.Y), s.b);
    subjects.push_back({a, b});
  }
  clipper.AddPaths(subjects, cl::ptSubject, false);
  cl::Paths clip{to_path(region.outer)};
  for (const auto& h : region.holes) clip.push_back(to_path(h));
  clipper.AddPaths(clip, cl::ptClip, true);
  cl::PolyTree tree;
  clipper.Execute(cl::ctIntersection, tree, cl::pftEvenOdd, cl::pftEvenOdd);
  cl::Paths open;
  cl::OpenPathsFromPolyTree(tree, open);
  // Cut points carry Clipper's integer rounding (about a unit); project them back onto the
  // region's boundary so they lie on it to double precision.
  auto snap = [&](Vec2 q) {
    double best = 4 / kClipperScale;
    Vec2 out = q;
    auto ring = [&](const std::vector<Vec2>& r) {
      for (std::size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
        double t;
        const Vec3 a{r[j].x, r[j].y, 0}, b{r[i].x, r[i].y, 0};
        const double d = distance_to_segment({q.x, q.y, 0}, a, b, &t);
        if (d < best) {
          best = d;
          out = {a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t};
        }
      }
    };
    ring(region.outer);
    for (const auto& h : region.holes) ring(h);
    return out;
  };
  auto back = [&](const cl::IntPoint& p) {
    auto it = exact.find({p.X, p.Y});
    return it != exact.end() ? it->second : snap({p.X / kClipperScale, p.Y / kClipperScale});
  };
  std::vector<Segment2> out;
  for (const auto& path : open)
    for (std::size_t i = 1; i < path.size(); ++i)
      if (!(path[i - 1] == path[i])) out.push_back({back(path[i - 1]), back(path[i])});
  return out;
}

bool inside_ring(const std::vector<Vec2>& ring, Vec2 p) {
  bool in = false;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    const Vec2 a = ring[j], b = ring[i];
    if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) in = !in;
  }
  return in;
}

BeadRaster::BeadRaster(BBox2 box, double pixel) : box_(box), pixel_(pixel) {
  nx_ = std::max(1L, static_cast<long>(std::ceil(box.width() / pixel)));
  ny_ = std::max(1L, static_cast<long>(std::ceil(box.height() / pixel)));
  cells_.assign(static_cast<std::size_t>(nx_ * ny_), 0);
}

void BeadRaster::paint(Vec2 a, Vec2 b, double r) {
  // In pieces at most two pixels long, so a long diagonal does not scan its whole box.
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  const int pieces = std::max(1, static_cast<int>(std::ceil(len / (2 * pixel_))));
  for (int k = 0; k < pieces; ++k) {
    const Vec2 s0 = a + (b - a) * (static_cast<double>(k) / pieces);
    const Vec2 s1 = a + (b - a) * (static_cast<double>(k + 1) / pieces);
    const Vec3 A{s0.x, s0.y, 0}, B{s1.x, s1.y, 0};
    const long x0 =
        std::max(0L, static_cast<long>((std::min(s0.x, s1.x) - r - box_.min.x) / pixel_));
    const long x1 =
        std::min(nx_ - 1, static_cast<long>((std::max(s0.x, s1.x) + r - box_.min.x) / pixel_));
    const long y0 =
        std::max(0L, static_cast<long>((std::min(s0.y, s1.y) - r - box_.min.y) / pixel_));
    const long y1 =
        std::min(ny_ - 1, static_cast<long>((std::max(s0.y, s1.y) + r - box_.min.y) / pixel_));
    for (long iy = y0; iy <= y1; ++iy)
      for (long ix = x0; ix <= x1; ++ix) {
        char& c = cells_[static_cast<std::size_t>(iy * nx_ + ix)];
        if (c) continue;
        const Vec2 q = centre(ix, iy);
        if (distance_to_segment({q.x, q.y, 0}, A, B) <= r) c = 1;
      }
  }
}

bool contains(const Polygon2& region, Vec2 p, double tol) {
  // Strictly inside (crossing tests alone, no distances): the common case, decided cheaply.
  if (!region.outer.empty() && inside_ring(region.outer, p) &&
      std::none_of(region.holes.begin(), region.holes.end(),
                   [&](const auto& h) { return !h.empty() && inside_ring(h, p); }))
    return true;
  auto inside_ring = [&](const std::vector<Vec2>& ring) {
    bool in = false;
    for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
      const Vec2 a = ring[j], b = ring[i];
      if (distance_to_segment({p.x, p.y, 0}, {a.x, a.y, 0}, {b.x, b.y, 0}) <= tol) return true;
      if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x)
        in = !in;
    }
    return in;
  };
  if (!inside_ring(region.outer)) return false;
  for (const auto& h : region.holes) {
    bool on_edge = false;
    for (std::size_t i = 0, j = h.size() - 1; i < h.size(); j = i++)
      on_edge |=
          distance_to_segment({p.x, p.y, 0}, {h[j].x, h[j].y, 0}, {h[i].x, h[i].y, 0}) <= tol;
    if (!on_edge && inside_ring(h)) return false;
  }
  return true;
}

std::vector<std::vector<Vec2>> rings_with_points(const Polygon2& region,
                                                 const std::vector<Vec2>& points, double tol) {
  std::vector<const std::vector<Vec2>*> rings{&region.outer};
  for (const auto& h : region.holes) rings.push_back(&h);
  std::vector<std::vector<Vec2>> out;
  for (const auto* ring : rings) {
    const std::size_t n = ring->size();
    std::vector<std::vector<std::pair<double, Vec2>>> on_edge(n);
    for (auto p : points) {
      double best = tol, best_t = 0;
      std::size_t best_i = n;
      for (std::size_t i = 0; i < n; ++i) {
        const Vec2 a = (*ring)[i], b = (*ring)[(i + 1) % n];
        double t;
        const double d = distance_to_segment({p.x, p.y, 0}, {a.x, a.y, 0}, {b.x, b.y, 0}, &t);
        if (d <= best) {
          best = d;
          best_t = t;
          best_i = i;
        }
      }
      if (best_i < n) on_edge[best_i].emplace_back(best_t, p);
    }
    std::vector<Vec2> loop;
    for (std::size_t i = 0; i < n; ++i) {
      loop.push_back((*ring)[i]);
      auto& hits = on_edge[i];
      std::sort(hits.begin(), hits.end(), [](auto& x, auto& y) { return x.first < y.first; });
      for (auto& [t, p] : hits) loop.push_back(p);
    }
    out.push_back(std::move(loop));
  }
  return out;
}

}  // namespace trellis
