// Strategy 2's material balance on a bead raster: each line kept only where its bead adds area
// no bead covers yet (so the volume extruded is the faces' at any palette size), and the gap
// fill of what the kept beads leave uncovered.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "fgm_internal.hpp"

namespace trellis::fgm {

// The layer's bead raster for Strategy 2 (hand-written: a raster is far cheaper than the union of
// thousands of overlapping beads as polygons): pixels an eighth of a bead wide over the faces'
// box (a bead of margin); null for a layer over 5 m² (not to exhaust memory).
std::unique_ptr<BeadRaster> layer_raster(const std::vector<ColorFace>& faces, double bead) {
  BBox2 box{{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()},
            {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}};
  for (const auto& f : faces)
    for (const auto& poly : f.region)
      for (const Vec2 q : poly.outer) {
        box.min = {std::min(box.min.x, q.x - bead), std::min(box.min.y, q.y - bead)};
        box.max = {std::max(box.max.x, q.x + bead), std::max(box.max.y, q.y + bead)};
      }
  if (!(box.max.x > box.min.x) || !(box.max.y > box.min.y)) return nullptr;
  const double px = bead / 8;
  if ((box.width() / px + 1) * (box.height() / px + 1) > 400e6) return nullptr;
  return std::make_unique<BeadRaster>(box, px);
}

namespace {

// Paints the pixels whose centre lies in the rectangle of half-width r along a-b (a bead as E
// deposits it: no round caps, so a line's start does not cover its own end when it closes).
void paint_band(BeadRaster& raster, Vec2 a, Vec2 b, double r) {
  const Vec2 d = b - a;
  const double len = std::hypot(d.x, d.y);
  if (!(len > 0)) return;
  const Vec2 u{d.x / len, d.y / len};
  const double px = raster.pixel();
  const Vec2 o = raster.centre(0, 0);
  const long x0 = std::max(0L, static_cast<long>(std::floor((std::min(a.x, b.x) - r - o.x) / px)));
  const long x1 =
      std::min(raster.nx() - 1, static_cast<long>(std::ceil((std::max(a.x, b.x) + r - o.x) / px)));
  const long y0 = std::max(0L, static_cast<long>(std::floor((std::min(a.y, b.y) - r - o.y) / px)));
  const long y1 =
      std::min(raster.ny() - 1, static_cast<long>(std::ceil((std::max(a.y, b.y) + r - o.y) / px)));
  for (long iy = y0; iy <= y1; ++iy)
    for (long ix = x0; ix <= x1; ++ix) {
      const Vec2 q = raster.centre(ix, iy) - a;
      const double t = q.x * u.x + q.y * u.y, s = q.x * u.y - q.y * u.x;
      if (t >= 0 && t <= len && std::abs(s) <= r) raster.set(ix, iy);
    }
}

}  // namespace

// The parts of `line` whose bead mostly adds area not yet printed (Strategy 2's material
// balance): at every eighth of a bead along the line, the bead's cross-section (eight points
// across its width) is looked up in the raster; where more than half of it is covered already
// (a neighbouring bead nearer than half a bead, the ring a fill line runs into, a ring collapsing
// onto itself) the line is cut. A bead kept next to one nearer than a bead overlaps it by less
// than half a bead; one dropped leaves a gap under half a bead: on average they balance, so the
// volume extruded is the face's. Kept pieces of at least `min_len` are painted (the line's own
// beads half a bead behind, so a path running back over itself is cut too) and returned.
std::vector<std::vector<Vec2>> keep_uncovered(const std::vector<Vec2>& line, BeadRaster& raster,
                                              double bead, double min_len) {
  struct Sample {
    Vec2 p, u;
    double s;
  };
  std::vector<Sample> samples;
  const double step = raster.pixel();
  double s = 0;
  for (std::size_t k = 0; k + 1 < line.size(); ++k) {
    const Vec2 a = line[k], d = line[k + 1] - line[k];
    const double len = std::hypot(d.x, d.y);
    if (!(len > 0)) continue;
    const Vec2 u{d.x / len, d.y / len};
    const int n = std::max(1, static_cast<int>(std::ceil(len / step)));
    for (int i = 0; i < n; ++i)
      samples.push_back({a + d * (static_cast<double>(i) / n), u, s + len * i / n});
    s += len;
    if (k + 2 == line.size()) samples.push_back({line[k + 1], u, s});
  }
  std::vector<std::vector<Vec2>> out;
  if (samples.size() < 2) return out;
  std::vector<char> keep(samples.size(), 0);
  std::size_t painted = 0;  // samples [0, painted] are painted as far as kept
  auto paint_to = [&](std::size_t upto) {
    for (; painted + 1 <= upto; ++painted)
      if (keep[painted] && keep[painted + 1])
        paint_band(raster, samples[painted].p, samples[painted + 1].p, bead / 2);
  };
  for (std::size_t i = 0; i < samples.size(); ++i) {
    while (painted + 1 < i && samples[painted + 1].s <= samples[i].s - bead) paint_to(painted + 1);
    const Vec2 v{-samples[i].u.y, samples[i].u.x};
    int covered = 0;
    for (int k = 0; k < 8; ++k)
      covered += raster.covered_at(samples[i].p + v * (bead * ((k + 0.5) / 8 - 0.5)));
    keep[i] = covered <= 4;
  }
  // Runs of kept samples; a closed line kept across its start is one piece.
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t i = 0; i < samples.size();) {
    if (!keep[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j + 1 < samples.size() && keep[j + 1]) ++j;
    runs.push_back({i, j});
    i = j + 1;
  }
  const bool closed = line.size() > 2 && std::hypot(line.front().x - line.back().x,
                                                    line.front().y - line.back().y) < 1e-9;
  auto piece_of = [&](std::size_t i, std::size_t j) {
    std::vector<Vec2> piece;
    for (std::size_t k = i; k <= j; ++k) {
      // Only the line's own vertices and the run's ends: the samples between are collinear.
      const bool vertex = k == i || k == j || samples[k].u.x != samples[k - 1].u.x ||
                          samples[k].u.y != samples[k - 1].u.y;
      if (vertex) piece.push_back(samples[k].p);
    }
    return piece;
  };
  std::vector<std::vector<Vec2>> pieces;
  for (const auto& [i, j] : runs) pieces.push_back(piece_of(i, j));
  if (closed && runs.size() > 1 && runs.front().first == 0 &&
      runs.back().second + 1 == samples.size()) {
    auto& last = pieces.back();
    last.insert(last.end(), pieces.front().begin() + 1, pieces.front().end());
    pieces.erase(pieces.begin());
  }
  paint_to(samples.size() - 1);
  for (auto& piece : pieces) {
    double len = 0;
    for (std::size_t k = 1; k < piece.size(); ++k)
      len += std::hypot(piece[k].x - piece[k - 1].x, piece[k].y - piece[k - 1].y);
    if (len >= min_len && piece.size() >= 2) out.push_back(std::move(piece));
  }
  return out;
}

// Gap fill for Strategy 2: each face's pixels the beads painted into `raster` leave uncovered
// are grouped 4-connected; each group of 0.08 bead² or more gets lines a bead apart along its
// long axis (as many as its width holds, rounded), clipped to where a bead stays inside the face
// (`inners`), so no bead crosses into the next face; gaps no bead can reach (the tip of an acute
// corner) stay. Returns the candidate lines per face (keep_uncovered trims them).
std::vector<std::vector<std::vector<Vec2>>> gap_lines(const std::vector<ColorFace>& faces,
                                                      const std::vector<Regions>& inners,
                                                      const BeadRaster& raster, double bead) {
  std::vector<std::vector<std::vector<Vec2>>> lines(faces.size());
  const double px = raster.pixel();
  const long nx = raster.nx(), ny = raster.ny();
  const Vec2 origin = raster.centre(0, 0) - Vec2{px / 2, px / 2};
  const BBox2 box{origin, origin};
  auto centre = [&](long ix, long iy) { return raster.centre(ix, iy); };
  // Per face: its uncovered pixels (scanlines over its rings, even-odd; each edge's crossings
  // bucketed by row), then groups.
  std::vector<int> owner(static_cast<std::size_t>(nx * ny), -1);
  std::vector<std::vector<double>> rows;
  std::vector<long> stack, group;
  for (std::size_t fi = 0; fi < faces.size(); ++fi) {
    const auto rings = rings_of(faces[fi].region);
    double ylo = std::numeric_limits<double>::infinity(), yhi = -ylo;
    for (const auto& ring : rings)
      for (const Vec2 q : ring) ylo = std::min(ylo, q.y), yhi = std::max(yhi, q.y);
    const long r0 = std::max(0L, static_cast<long>((ylo - box.min.y) / px) - 1);
    const long r1 = std::min(ny - 1, static_cast<long>((yhi - box.min.y) / px) + 1);
    rows.assign(static_cast<std::size_t>(r1 - r0 + 1), {});
    for (const auto& ring : rings)
      for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
        const Vec2 a = ring[j], b = ring[i];
        if (a.y == b.y) continue;
        // Rows whose centre y lies in [min, max) of the edge.
        const double lo = std::min(a.y, b.y), hi = std::max(a.y, b.y);
        long first = static_cast<long>(std::ceil((lo - box.min.y) / px - 0.5));
        for (long iy = std::max(first, r0); iy <= r1; ++iy) {
          const double y = centre(0, iy).y;
          if (y >= hi) break;
          if (y < lo) continue;
          rows[static_cast<std::size_t>(iy - r0)].push_back(a.x +
                                                            (b.x - a.x) * (y - a.y) / (b.y - a.y));
        }
      }
    std::vector<long> mine;
    for (long iy = r0; iy <= r1; ++iy) {
      auto& xs = rows[static_cast<std::size_t>(iy - r0)];
      std::sort(xs.begin(), xs.end());
      for (std::size_t k = 0; k + 1 < xs.size(); k += 2)
        for (long ix = std::max(0L, static_cast<long>(std::ceil((xs[k] - box.min.x) / px - 0.5)));
             ix < nx && centre(ix, iy).x < xs[k + 1]; ++ix) {
          const long id = iy * nx + ix;
          if (raster.covered(ix, iy)) continue;
          owner[static_cast<std::size_t>(id)] = static_cast<int>(fi);
          mine.push_back(id);
        }
    }
    std::vector<std::vector<Vec2>> gap_lines;
    for (const long seed : mine) {
      if (owner[static_cast<std::size_t>(seed)] != static_cast<int>(fi)) continue;
      group.clear();
      stack.assign(1, seed);
      owner[static_cast<std::size_t>(seed)] = -2;
      while (!stack.empty()) {
        const long id = stack.back();
        stack.pop_back();
        group.push_back(id);
        const long ix = id % nx, iy = id / nx;
        for (const long nb : {ix > 0 ? id - 1 : -1L, ix + 1 < nx ? id + 1 : -1L,
                              iy > 0 ? id - nx : -1L, iy + 1 < ny ? id + nx : -1L})
          if (nb >= 0 && owner[static_cast<std::size_t>(nb)] == static_cast<int>(fi)) {
            owner[static_cast<std::size_t>(nb)] = -2;
            stack.push_back(nb);
          }
      }
      // Specks under 0.08 bead² (three pixels) are left: filling them would add a path (and a
      // travel) each for a few hundredths of a percent of coverage.
      if (static_cast<double>(group.size()) * px * px < 0.08 * bead * bead) continue;
      Vec2 c{0, 0};
      for (const long id : group) c = c + centre(id % nx, id / nx);
      c = c * (1.0 / static_cast<double>(group.size()));
      double sxx = 0, syy = 0, sxy = 0;
      for (const long id : group) {
        const Vec2 q = centre(id % nx, id / nx) - c;
        sxx += q.x * q.x, syy += q.y * q.y, sxy += q.x * q.y;
      }
      const double ang = 0.5 * std::atan2(2 * sxy, sxx - syy);
      const Vec2 u{std::cos(ang), std::sin(ang)}, v{-u.y, u.x};
      double s0 = 0, s1 = 0, t0 = 0, t1 = 0;
      for (const long id : group) {
        const Vec2 q = centre(id % nx, id / nx) - c;
        const double s = q.x * u.x + q.y * u.y, t = q.x * v.x + q.y * v.y;
        s0 = std::min(s0, s), s1 = std::max(s1, s), t0 = std::min(t0, t), t1 = std::max(t1, t);
      }
      // Beads a bead wide side by side across the group's width (pixel centres ± half a pixel).
      const double width = t1 - t0 + px;
      const int n = std::max(1, static_cast<int>(std::lround(width / bead)));
      for (int k = 0; k < n; ++k) {
        const double t = t0 - px / 2 + width * (k + 0.5) / n;
        gap_lines.push_back({c + u * (s0 - px) + v * t, c + u * (s1 + px) + v * t});
      }
    }
    if (gap_lines.empty()) continue;
    for (auto& piece : clip_polylines(gap_lines, inners[fi])) {
      double len = 0;
      for (std::size_t k = 1; k < piece.size(); ++k)
        len += std::hypot(piece[k].x - piece[k - 1].x, piece[k].y - piece[k - 1].y);
      if (len >= 0.25 * bead) lines[fi].push_back(std::move(piece));
    }
  }
  return lines;
}

}  // namespace trellis::fgm
