// Clipper's closed output nested into polygons with holes by us, not by a PolyTree: Clipper's
// PolyTree fixes up each split ring's owner by testing every other output ring
// (FixupFirstLefts1), quadratic in the rings: 29 % of slicing a plate with 900 holes.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>

#include "clipper_util.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis::clipper_util {

namespace cl = ClipperLib;

namespace {

// A ring's edges bucketed by height: where a point lies is worked out from the edges near its
// height, not from the whole ring (islands tested against a hole of thousands of vertices).
class RingIndex {
 public:
  explicit RingIndex(const cl::Path& ring) : ring_(ring) {
    const std::size_t n = ring.size();
    y0_ = ring[0].Y;
    cl::cInt y1 = ring[0].Y;
    for (const auto& p : ring) y0_ = std::min(y0_, p.Y), y1 = std::max(y1, p.Y);
    buckets_ = std::max<std::size_t>(1, n / 4);
    step_ = static_cast<double>(y1 - y0_ + 1) / static_cast<double>(buckets_);
    // Each edge in the buckets its height, widened by kNear, meets (a counting sort).
    start_.assign(buckets_ + 1, 0);
    for_each_bucket([&](std::size_t, std::size_t b) { ++start_[b + 1]; });
    for (std::size_t b = 0; b < buckets_; ++b) start_[b + 1] += start_[b];
    edges_.resize(start_.back());
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for_each_bucket(
        [&](std::size_t e, std::size_t b) { edges_[fill[b]++] = static_cast<std::uint32_t>(e); });
  }

  // 1 inside, 0 outside, -1 on the boundary or within kNear of it.
  int locate(const cl::IntPoint& p) const {
    if (p.Y < y0_ - kNear || p.Y > y0_ + static_cast<cl::cInt>(step_ * buckets_) + kNear) return 0;
    const std::size_t b = bucket(p.Y);
    bool in = false;
    for (std::size_t k = start_[b]; k < start_[b + 1]; ++k)
      if (!cross(ring_, edges_[k], p, in)) return -1;
    return in ? 1 : 0;
  }
  // The same from every edge (no index: for rings tested a few times).
  static int scan(const cl::Path& ring, const cl::IntPoint& p) {
    bool in = false;
    for (std::size_t e = 0; e < ring.size(); ++e)
      if (!cross(ring, e, p, in)) return -1;
    return in ? 1 : 0;
  }

 private:
  static constexpr cl::cInt kNear = 2;  // units (Clipper's rounding leaves touching rings apart)
  std::size_t bucket(cl::cInt y) const {
    const double k = std::floor(static_cast<double>(y - y0_) / step_);
    return static_cast<std::size_t>(std::clamp(k, 0.0, static_cast<double>(buckets_ - 1)));
  }
  template <class Fn>
  void for_each_bucket(Fn&& fn) const {
    for (std::size_t e = 0; e < ring_.size(); ++e) {
      const cl::cInt ya = ring_[e].Y, yb = ring_[(e + 1) % ring_.size()].Y;
      const std::size_t lo = bucket(std::min(ya, yb) - kNear),
                        hi = bucket(std::max(ya, yb) + kNear);
      for (std::size_t b = lo; b <= hi; ++b) fn(e, b);
    }
  }
  // Edge e against p: false when p lies within kNear of it; else `in` flips when the ray from p
  // towards +x crosses it.
  static bool cross(const cl::Path& ring, std::size_t e, const cl::IntPoint& p, bool& in) {
    const cl::IntPoint& a = ring[e];
    const cl::IntPoint& c = ring[e + 1 == ring.size() ? 0 : e + 1];
    // Beyond kNear of the edge's box (above, below or to its right), p is not near the edge
    // and its ray does not cross it: most edges of a scan, decided without a division.
    if (p.Y < std::min(a.Y, c.Y) - kNear || p.Y > std::max(a.Y, c.Y) + kNear ||
        p.X > std::max(a.X, c.X) + kNear)
      return true;
    const double dx = static_cast<double>(c.X - a.X), dy = static_cast<double>(c.Y - a.Y);
    const double px = static_cast<double>(p.X - a.X), py = static_cast<double>(p.Y - a.Y);
    const double len2 = dx * dx + dy * dy;
    const double t = len2 > 0 ? std::clamp((px * dx + py * dy) / len2, 0.0, 1.0) : 0.0;
    const double ex = px - t * dx, ey = py - t * dy;
    if (ex * ex + ey * ey <= static_cast<double>(kNear * kNear)) return false;
    if ((a.Y > p.Y) != (c.Y > p.Y)) {
      const __int128 side = static_cast<__int128>(c.X - a.X) * (p.Y - a.Y) -
                            static_cast<__int128>(p.X - a.X) * (c.Y - a.Y);
      if ((side > 0) == (c.Y > a.Y)) in = !in;
    }
    return true;
  }

  const cl::Path& ring_;
  cl::cInt y0_ = 0;
  std::size_t buckets_ = 1;
  double step_ = 1;
  std::vector<std::size_t> start_;
  std::vector<std::uint32_t> edges_;
};

struct Ring {
  const cl::Path* path;
  double area;  // > 0: an outer ring, else a hole
  cl::cInt x0, y0, x1, y1;
  std::size_t parent = std::numeric_limits<std::size_t>::max();  // none: at the top
  std::vector<std::size_t> children;                             // in output order
  std::size_t tests = 0;
  std::unique_ptr<RingIndex> index;  // made once the ring has been tested a few times
  int locate(const cl::IntPoint& p) {
    if (++tests <= 16) return RingIndex::scan(*path, p);
    if (!index) index = std::make_unique<RingIndex>(*path);
    return index->locate(p);
  }
};

Ring ring_of(const cl::Path& path) {
  Ring r{&path, cl::Area(path), path[0].X, path[0].Y, path[0].X, path[0].Y};
  for (const auto& p : path)
    r.x0 = std::min(r.x0, p.X), r.y0 = std::min(r.y0, p.Y), r.x1 = std::max(r.x1, p.X),
    r.y1 = std::max(r.y1, p.Y);
  return r;
}

// Votes of points of `path` against ring `out`: inside minus outside; points on or near its
// boundary abstain (where rings touch, Clipper's rounding leaves a vertex of one a unit off the
// other's edge, on either side). `stride` picks every stride-th vertex; `midpoints` takes the
// edges' middles instead.
long votes(const cl::Path& path, Ring& out, std::size_t stride, bool midpoints) {
  long sum = 0;
  for (std::size_t i = 0; i < path.size(); i += stride) {
    cl::IntPoint p = path[i];
    if (midpoints) {
      const cl::IntPoint& b = path[(i + 1) % path.size()];
      p = {p.X + (b.X - p.X) / 2, p.Y + (b.Y - p.Y) / 2};
    }
    const int where = out.locate(p);
    sum += where == 1 ? 1 : where == 0 ? -1 : 0;
  }
  return sum;
}

// Whether ring `in` lies inside ring `out` (rings do not cross; they may touch): the majority of a
// few vertices off `out`'s boundary decides, else of all of them, else of the edges' middles (a
// pocket whose corners all touch `out`); a ring that fills `out` lies inside it.
bool inside(const Ring& in, Ring& out) {
  if (in.x0 < out.x0 || in.y0 < out.y0 || in.x1 > out.x1 || in.y1 > out.y1) return false;
  const cl::Path& path = *in.path;
  constexpr std::size_t kSamples = 7;
  if (const long v = votes(path, out, std::max<std::size_t>(1, path.size() / kSamples), false))
    return v > 0;
  if (path.size() > kSamples)
    if (const long v = votes(path, out, 1, false)) return v > 0;
  if (const long v = votes(path, out, 1, true)) return v > 0;
  return true;
}

// The ring's points, turned to `want_ccw` (its area, ring_of's, says which way it runs: what
// cl::Orientation would compute again).
std::vector<Vec2> points_of(const Ring& r, bool want_ccw) {
  std::vector<Vec2> ring;
  ring.reserve(r.path->size());
  for (const auto& p : *r.path) ring.push_back(from_int(p));
  if ((r.area >= 0) != want_ccw) std::reverse(ring.begin(), ring.end());
  return ring;
}

// As a PolyTree is read: each outer ring with its holes, the islands inside a hole before the
// polygon whose hole it is.
void emit(const std::vector<Ring>& rings, std::size_t outer, Regions& out) {
  Polygon2 poly;
  poly.outer = points_of(rings[outer], true);
  for (const std::size_t hole : rings[outer].children) {
    poly.holes.push_back(points_of(rings[hole], false));
    for (const std::size_t island : rings[hole].children) emit(rings, island, out);
  }
  out.push_back(std::move(poly));
}

}  // namespace

Regions nest_paths(const cl::Paths& paths) {
  std::vector<Ring> rings;
  rings.reserve(paths.size());
  for (const auto& path : paths)
    if (path.size() >= 3) rings.push_back(ring_of(path));
  // Each ring's parent: the smallest ring of the other kind around it. Candidates by increasing
  // size, boxes first, so the search stops at the first ring around it (a ring nested in many
  // tests one).
  std::vector<std::size_t> by_size[2];  // [0] holes, [1] outer rings
  for (std::size_t i = 0; i < rings.size(); ++i) by_size[rings[i].area > 0].push_back(i);
  const auto size = [&](std::size_t i) { return std::abs(rings[i].area); };
  for (auto& v : by_size)
    std::stable_sort(v.begin(), v.end(),
                     [&](std::size_t a, std::size_t b) { return size(a) < size(b); });
  for (std::size_t i = 0; i < rings.size(); ++i) {
    const auto& others = by_size[rings[i].area > 0 ? 0 : 1];
    auto it = std::upper_bound(others.begin(), others.end(), size(i),
                               [&](double s, std::size_t j) { return s < size(j); });
    for (; it != others.end(); ++it)
      if (inside(rings[i], rings[*it])) {
        rings[i].parent = *it;
        break;
      }
  }
  // (A PolyTree lists a hole it finds no owner for at the top, read as an outer ring: so here.)
  std::vector<std::size_t> top;
  for (std::size_t i = 0; i < rings.size(); ++i) {
    if (rings[i].parent < rings.size())
      rings[rings[i].parent].children.push_back(i);
    else
      top.push_back(i);
  }
  Regions out;
  for (const std::size_t i : top) emit(rings, i, out);
  return out;
}

}  // namespace trellis::clipper_util
