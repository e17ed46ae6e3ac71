// fill_gaps: where the level lines leave part of a fill uncovered. Stroking every line two beads
// wide and uniting the strokes (which overlap their neighbours) is what cost Strategy 2 its time;
// a grid finds the few places a gap can be, and only the lines near them are stroked.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "fgm_outline.hpp"

namespace trellis::fgm {

namespace {

// A mask over square cells of side `c` from `origin`.
struct Grid {
  Vec2 origin;
  double c = 0;
  long nx = 0, ny = 0;
  std::vector<std::uint8_t> v;
  std::uint8_t& at(long i, long j) { return v[static_cast<std::size_t>(j * nx + i)]; }
  Vec2 centre(long i, long j) const {
    return {origin.x + (static_cast<double>(i) + 0.5) * c,
            origin.y + (static_cast<double>(j) + 0.5) * c};
  }
  long col(double x) const { return std::clamp(static_cast<long>((x - origin.x) / c), 0L, nx - 1); }
  long row(double y) const { return std::clamp(static_cast<long>((y - origin.y) / c), 0L, ny - 1); }
};

double segment_distance2(Vec2 p, Vec2 a, Vec2 b) {
  const Vec2 d = b - a;
  const double l2 = d.x * d.x + d.y * d.y;
  const double t = l2 > 0 ? std::clamp(((p.x - a.x) * d.x + (p.y - a.y) * d.y) / l2, 0.0, 1.0) : 0;
  const Vec2 q = a + d * t - p;
  return q.x * q.x + q.y * q.y;
}

// Cells within `k` cells (Chebyshev) of a set cell, by two sliding windows.
Grid dilate(const Grid& g, long k) {
  Grid rows = g, out = g;
  for (long j = 0; j < g.ny; ++j) {
    long count = 0;  // set cells in [i - k, i + k]
    for (long i = 0; i < std::min(k, g.nx); ++i) count += g.v[j * g.nx + i];
    for (long i = 0; i < g.nx; ++i) {
      if (i + k < g.nx) count += g.v[j * g.nx + i + k];
      if (i - k - 1 >= 0) count -= g.v[j * g.nx + i - k - 1];
      rows.at(i, j) = count > 0;
    }
  }
  for (long i = 0; i < g.nx; ++i) {
    long count = 0;
    for (long j = 0; j < std::min(k, g.ny); ++j) count += rows.v[j * g.nx + i];
    for (long j = 0; j < g.ny; ++j) {
      if (j + k < g.ny) count += rows.v[(j + k) * g.nx + i];
      if (j - k - 1 >= 0) count -= rows.v[(j - k - 1) * g.nx + i];
      out.at(i, j) = count > 0;
    }
  }
  return out;
}

Regions exact_gaps(const Regions& fill, const std::vector<std::vector<Vec2>>& lines, double r) {
  return offset(offset(difference(fill, stroke(lines, 2 * r)), -r), r);
}

}  // namespace

Regions fill_gaps(const Regions& fill, const std::vector<std::vector<Vec2>>& lines, double r) {
  if (fill.empty()) return {};
  BBox2 box{{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()},
            {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}};
  for (const auto& p : fill)
    for (const Vec2 q : p.outer) {
      box.min = {std::min(box.min.x, q.x), std::min(box.min.y, q.y)};
      box.max = {std::max(box.max.x, q.x), std::max(box.max.y, q.y)};
    }
  Grid g;
  g.c = r / 2;
  g.origin = box.min - Vec2{g.c, g.c};
  const double nx = std::ceil(box.width() / g.c) + 2, ny = std::ceil(box.height() / g.c) + 2;
  if (!(nx * ny < 5e7)) return exact_gaps(fill, lines, r);
  g.nx = static_cast<long>(nx);
  g.ny = static_cast<long>(ny);
  g.v.assign(static_cast<std::size_t>(g.nx * g.ny), 0);

  // A gap that holds a disk of radius r has that disk's centre more than r from every line: the
  // cell around it has its centre inside the fill and more than r - c/√2 from every line.
  Grid inside = g;
  for (long j = 0; j < g.ny; ++j) {
    const double y = g.centre(0, j).y;
    std::vector<double> xs;
    auto cross = [&](const std::vector<Vec2>& ring) {
      for (std::size_t k = 0, m = ring.size() - 1; k < ring.size(); m = k++)
        if ((ring[m].y <= y) != (ring[k].y <= y))
          xs.push_back(ring[m].x +
                       (y - ring[m].y) * (ring[k].x - ring[m].x) / (ring[k].y - ring[m].y));
    };
    for (const auto& p : fill) {
      if (p.outer.size() >= 3) cross(p.outer);
      for (const auto& h : p.holes)
        if (h.size() >= 3) cross(h);
    }
    std::sort(xs.begin(), xs.end());
    for (std::size_t k = 0; k + 1 < xs.size(); k += 2)
      for (long i = g.col(xs[k]); i <= g.col(xs[k + 1]); ++i) {
        const double x = g.centre(i, j).x;
        if (x >= xs[k] && x <= xs[k + 1]) inside.at(i, j) = 1;
      }
  }
  const double cover = r - g.c * std::sqrt(0.5);
  for (const auto& l : lines)
    for (std::size_t k = 1; k < l.size(); ++k) {
      const Vec2 a = l[k - 1], b = l[k];
      for (long j = g.row(std::min(a.y, b.y) - cover); j <= g.row(std::max(a.y, b.y) + cover); ++j)
        for (long i = g.col(std::min(a.x, b.x) - cover); i <= g.col(std::max(a.x, b.x) + cover);
             ++i)
          if (inside.at(i, j) && segment_distance2(g.centre(i, j), a, b) <= cover * cover)
            inside.at(i, j) = 0;
    }
  if (std::none_of(inside.v.begin(), inside.v.end(), [](std::uint8_t b) { return b; })) return {};

  // Every such disk lies within ceil(r/c) + 1 cells of its centre's cell; the near region keeps a
  // margin of two radii. A line's stroke reaches at most 2r from it (r, or a mitred corner): the
  // stretches of lines within that of the near region are stroked, cut where they leave it, so
  // inside the near region their strokes are the whole lines' strokes.
  const long two_radii = static_cast<long>(std::ceil(2 * r / g.c)) + 1;
  const Grid near = dilate(inside, two_radii);
  const Grid reach = dilate(near, two_radii);
  std::vector<std::vector<Vec2>> kept;
  for (const auto& l : lines) {
    std::vector<Vec2> run;
    for (std::size_t k = 1; k < l.size(); ++k) {
      const Vec2 a = l[k - 1], b = l[k];
      bool hit = false;
      for (long j = g.row(std::min(a.y, b.y)); j <= g.row(std::max(a.y, b.y)) && !hit; ++j)
        for (long i = g.col(std::min(a.x, b.x)); i <= g.col(std::max(a.x, b.x)) && !hit; ++i)
          hit = reach.v[j * g.nx + i];
      if (hit) {
        if (run.empty()) run.push_back(a);
        run.push_back(b);
      } else if (!run.empty()) {
        kept.push_back(std::move(run));
        run.clear();
      }
    }
    if (!run.empty()) kept.push_back(std::move(run));
  }
  std::vector<std::vector<Vec2>> cells;  // the near region as runs of cells along each row
  for (long j = 0; j < g.ny; ++j)
    for (long i = 0; i < g.nx; ++i) {
      if (!near.v[j * g.nx + i]) continue;
      long e = i;
      while (e + 1 < g.nx && near.v[j * g.nx + e + 1]) ++e;
      // Each run reaches a hundredth of a cell into its neighbours: overlapping, not touching,
      // so the union is one region (runs that only share an edge stay apart, and the opening
      // below would then erode each from the edge between them).
      const Vec2 lo = g.origin + Vec2{static_cast<double>(i) * g.c, static_cast<double>(j) * g.c} -
                      Vec2{0.01 * g.c, 0.01 * g.c};
      const Vec2 hi = Vec2{0.01 * g.c, 0.01 * g.c} + g.origin +
                      Vec2{static_cast<double>(e + 1) * g.c, static_cast<double>(j + 1) * g.c};
      cells.push_back({lo, {hi.x, lo.y}, hi, {lo.x, hi.y}});
      i = e;
    }
  return exact_gaps(intersection(fill, unite_oriented_rings(cells)), kept, r);
}

}  // namespace trellis::fgm
