#include "trellis/slice/fgm.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "fgm_fill.hpp"
#include "fgm_order.hpp"
#include "fgm_outline.hpp"
#include "fgm_tower.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/link.hpp"
#include "trellis/toolpath/order.hpp"

namespace trellis {

void Palette::check() const {
  if (materials != 2 && materials != 3)
    throw SettingError("gradient palettes mix two or three materials (the design has " +
                       std::to_string(materials) + ")");
  if (colors < 1 || colors > 1000) throw SettingError("the palette needs 1 to 1000 colours");
  if (ends && (materials != 2 || colors < 2))
    throw SettingError("a tool palette has two materials and at least two colours");
  if (materials == 3) {
    const int d = divisions();
    if (d * d != colors || d < 1)
      throw SettingError("a three-material palette has d² colours (1, 4, 9, 16, 25, …), not " +
                         std::to_string(colors));
  }
}

int Palette::divisions() const {
  if (materials != 3) return colors;
  return static_cast<int>(std::lround(std::sqrt(static_cast<double>(std::max(colors, 1)))));
}

double Palette::band() const {
  if (ends && materials != 3) return colors > 1 ? 1.0 / (colors - 1) : 1.0;
  return 1.0 / divisions();
}

double Palette::level(int k) const {
  if (ends && materials != 3) return (k - 0.5) * band();
  return static_cast<double>(k) / divisions();
}

double Palette::error_bound() const {
  return (materials == 3 ? 2.0 / 3.0 : 0.5) * band();
}

Palette::Cell Palette::cell(int color) const {
  // Row r holds the triangles with i = r: up (r, 0), down (r, 0), up (r, 1), …, up (r, d-1-r),
  // 2(d - r) - 1 of them, walked left to right on even rows and back on odd ones.
  const int d = divisions();
  int r = 0, first = 0;
  while (r < d - 1 && color >= first + 2 * (d - r) - 1) first += 2 * (d - r) - 1, ++r;
  const int count = 2 * (d - r) - 1;
  int t = std::clamp(color - first, 0, count - 1);
  if (r % 2 == 1) t = count - 1 - t;
  Cell c;
  c.i = r;
  c.j = t / 2;
  c.up = t % 2 == 0;
  c.k = (c.up ? d - 1 : d - 2) - c.i - c.j;
  return c;
}

std::vector<double> Palette::mixture(int color) const {
  if (materials != 3) {
    const double m =
        ends ? (colors > 1 ? 1.0 * color / (colors - 1) : 0.5) : (color + 0.5) / colors;
    return {m, 1 - m};
  }
  const Cell c = cell(color);
  const double off = c.up ? 1.0 / 3.0 : 2.0 / 3.0, d = divisions();
  return {(c.i + off) / d, (c.j + off) / d, (c.k + off) / d};
}

int Palette::color_of(double f) const {
  if (ends) return std::clamp(static_cast<int>(std::floor(f * (colors - 1) + 0.5)), 0, colors - 1);
  return std::clamp(static_cast<int>(std::floor(f * colors)), 0, colors - 1);
}

int Palette::color_of(const std::vector<double>& f) const {
  if (materials != 3 || f.size() < 3) return color_of(f.empty() ? 0.0 : f[0]);
  const int d = divisions();
  const double a = std::clamp(f[0], 0.0, 1.0) * d, b = std::clamp(f[1], 0.0, 1.0) * d;
  const int i = std::clamp(static_cast<int>(std::floor(a)), 0, d - 1);
  int j = std::clamp(static_cast<int>(std::floor(b)), 0, d - 1 - i);
  const bool up = i + j == d - 1 || (a - i) + (b - j) < 1;
  return color_of_cell(i, j, up);
}

int Palette::color_of_cell(int i, int j, bool up) const {
  // Index of (i, j, up) along the snake.
  const int d = divisions();
  int first = 0;
  for (int r = 0; r < i; ++r) first += 2 * (d - r) - 1;
  const int count = 2 * (d - i) - 1;
  int t = 2 * j + (up ? 0 : 1);
  if (i % 2 == 1) t = count - 1 - t;
  return first + t;
}

namespace {

// One material's fraction on one layer's grid, evaluated once per node (every band-edge contour
// samples the same nodes); points off the grid (root refinement) are evaluated directly.
class FractionGrid {
 public:
  FractionGrid(Evaluator& ev, double z, Vec2 lo, Vec2 hi, double res, std::size_t material = 0)
      : ev_(ev), z_(z), lo_(lo), res_(res), material_(material) {
    nx_ = static_cast<std::size_t>(std::ceil((hi.x - lo.x) / res)) + 1;
    ny_ = static_cast<std::size_t>(std::ceil((hi.y - lo.y) / res)) + 1;
    values_.resize(nx_ * ny_);
    // A row of nodes at a time (the design's expressions evaluated over the row).
    const std::size_t m = ev.field().materials().size();
    std::vector<Vec3> row(nx_);
    std::vector<double> f(nx_ * m);
    for (std::size_t j = 0; j < ny_; ++j) {
      for (std::size_t i = 0; i < nx_; ++i)
        row[i] = {lo.x + static_cast<double>(i) * res, lo.y + static_cast<double>(j) * res, z};
      ev.fractions(row.data(), nx_, f.data());
      for (std::size_t i = 0; i < nx_; ++i)
        values_[j * nx_ + i] = material < m ? f[i * m + material] : 0.0;
    }
  }
  // The fraction at n points: nodes from the grid, the others (the contour's refinement
  // guesses) evaluated together.
  void at(const Vec2* p, std::size_t n, double* out) {
    off_.clear();
    off_at_.clear();
    for (std::size_t k = 0; k < n; ++k) {
      std::size_t i, j;
      if (node(p[k], i, j)) {
        out[k] = values_[j * nx_ + i];
      } else {
        off_.push_back({p[k].x, p[k].y, z_});
        off_at_.push_back(k);
      }
    }
    if (off_.empty()) return;
    const std::size_t m = ev_.field().materials().size();
    f_.resize(off_.size() * m);
    ev_.fractions(off_.data(), off_.size(), f_.data());
    for (std::size_t k = 0; k < off_.size(); ++k)
      out[off_at_[k]] = material_ < m ? f_[k * m + material_] : 0.0;
  }
  // Range of the node values in [a, b] (grid nodes only: what marching squares sees).
  Interval range(Vec2 a, Vec2 b) const {
    const auto i0 =
        static_cast<std::size_t>(std::max(0.0, std::floor((a.x - lo_.x) / res_ - 1e-9)));
    const auto j0 =
        static_cast<std::size_t>(std::max(0.0, std::floor((a.y - lo_.y) / res_ - 1e-9)));
    const auto i1 = std::min(
        nx_ - 1, static_cast<std::size_t>(std::max(0.0, std::ceil((b.x - lo_.x) / res_ + 1e-9))));
    const auto j1 = std::min(
        ny_ - 1, static_cast<std::size_t>(std::max(0.0, std::ceil((b.y - lo_.y) / res_ + 1e-9))));
    Interval r{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (std::size_t j = j0; j <= j1; ++j)
      for (std::size_t i = i0; i <= i1; ++i) {
        const double v = values_[j * nx_ + i];
        r.lo = std::min(r.lo, v);
        r.hi = std::max(r.hi, v);
      }
    return r;
  }

 private:
  bool node(Vec2 p, std::size_t& i, std::size_t& j) const {
    const double fx = (p.x - lo_.x) / res_, fy = (p.y - lo_.y) / res_;
    const double ix = std::floor(fx + 0.5), iy = std::floor(fy + 0.5);
    if (std::abs(fx - ix) > 1e-9 || std::abs(fy - iy) > 1e-9 || ix < 0 || iy < 0) return false;
    i = static_cast<std::size_t>(ix);
    j = static_cast<std::size_t>(iy);
    return i < nx_ && j < ny_;
  }
  Evaluator& ev_;
  double z_;
  Vec2 lo_;
  double res_;
  std::size_t material_;
  std::size_t nx_ = 0, ny_ = 0;
  std::vector<double> values_;
  std::vector<Vec3> off_;  // scratch of at(): the points off the grid, their indices, fractions
  std::vector<std::size_t> off_at_;
  std::vector<double> f_;
};

// max(f - level, distance outside the box): its zero set closes along the box. Blocks whose
// nodes are all on one side of the level are skipped by the contouring.
class BelowLevel : public PlaneFunction {
 public:
  BelowLevel(FractionGrid& grid, double level, Vec2 lo, Vec2 hi)
      : grid_(grid), level_(level), lo_(lo), hi_(hi) {}
  void sample(const Vec2* p, double* out, std::size_t n) override {
    grid_.at(p, n, out);
    for (std::size_t i = 0; i < n; ++i) {
      const double box = std::max({lo_.x - p[i].x, p[i].x - hi_.x, lo_.y - p[i].y, p[i].y - hi_.y});
      out[i] = std::max(out[i] - level_, box);
    }
  }
  Interval bound(Vec2 a, Vec2 b) override {
    // The box term's range over the rectangle, and the nodes' fraction range.
    const double box_lo = std::max({lo_.x - b.x, a.x - hi_.x, lo_.y - b.y, a.y - hi_.y});
    const double box_hi = std::max({lo_.x - a.x, b.x - hi_.x, lo_.y - a.y, b.y - hi_.y});
    const Interval f = grid_.range(a, b);
    return {std::max(f.lo - level_, box_lo), std::max(f.hi - level_, box_hi)};
  }

 private:
  FractionGrid& grid_;
  double level_;
  Vec2 lo_, hi_;
};

// Moves chord midpoints onto the zero set of f until they are within `tol` of it: a secant step
// along the chord's normal (the crossings at the chord's ends are on the zero set already), at
// most `depth` halvings. Contours from a coarse grid deviate from a curved iso-line by c²/8ρ in
// the middle of a chord; refined, the faces' edges follow the iso-lines to `tol` in fraction.
// Chords with an end on the border of [lo, hi] (where the contour follows the box) are kept.
// Every chord of the ring at one depth is refined together (three batches of samples a round,
// not three single points a chord), the same steps as refining each chord on its own.
void refine_chords(std::vector<Vec2>& ring, PlaneFunction& f, double tol, double min_chord, Vec2 lo,
                   Vec2 hi) {
  const double eps = 1e-3 * min_chord;
  auto on_border = [&](Vec2 p) {
    return p.x <= lo.x + eps || p.x >= hi.x - eps || p.y <= lo.y + eps || p.y >= hi.y - eps;
  };
  struct Chord {
    Vec2 a, b;
    int depth;
    Vec2 m{}, n{}, q{};
    double len = 0, fm = 0, step = 0;
    std::size_t left = 0, right = 0;  // the halves, when split (0: not split; chord 0 is a root)
  };
  std::vector<Chord> chords;
  std::vector<std::size_t> root(ring.size(), 0), active, next;
  for (std::size_t k = 0; k < ring.size(); ++k) {
    const Vec2 a = ring[k], b = ring[(k + 1) % ring.size()];
    if (on_border(a) || on_border(b)) continue;
    root[k] = chords.size() + 1;  // 1-based: 0 is no chord
    active.push_back(chords.size());
    chords.push_back({a, b, 8});
  }
  std::vector<Vec2> pts;
  std::vector<double> vals;
  // Samples f at the points `at(c)` of the chords `which` into vals (in that order).
  auto sample = [&](const std::vector<std::size_t>& which, auto at) {
    pts.resize(which.size());
    vals.resize(which.size());
    for (std::size_t k = 0; k < which.size(); ++k) pts[k] = at(chords[which[k]]);
    if (!which.empty()) f.sample(pts.data(), vals.data(), which.size());
  };
  while (!active.empty()) {
    std::size_t keep = 0;
    for (const std::size_t c : active) {
      Chord& ch = chords[c];
      const Vec2 d = ch.b - ch.a;
      ch.len = std::hypot(d.x, d.y);
      if (ch.depth <= 0 || ch.len < min_chord) continue;
      ch.m = (ch.a + ch.b) * 0.5;
      ch.n = {-d.y / ch.len, d.x / ch.len};
      ch.step = 1e-3 * ch.len;
      active[keep++] = c;
    }
    active.resize(keep);
    sample(active, [](const Chord& ch) { return ch.m; });
    keep = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      chords[active[k]].fm = vals[k];
      if (std::abs(vals[k]) > tol) active[keep++] = active[k];
    }
    active.resize(keep);
    sample(active, [](const Chord& ch) { return ch.m + ch.n * ch.step; });
    keep = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      Chord& ch = chords[active[k]];
      const double slope = (vals[k] - ch.fm) / ch.step;
      if (!(std::abs(slope) > 0)) continue;
      const double t = std::clamp(-ch.fm / slope, -0.5 * ch.len, 0.5 * ch.len);
      ch.q = ch.m + ch.n * t;
      active[keep++] = active[k];
    }
    active.resize(keep);
    sample(active, [](const Chord& ch) { return ch.q; });
    next.clear();
    for (std::size_t k = 0; k < active.size(); ++k) {
      const std::size_t c = active[k];
      if (!(std::abs(vals[k]) < std::abs(chords[c].fm))) continue;
      const Chord ch = chords[c];
      chords[c].left = chords.size();
      next.push_back(chords.size());
      chords.push_back({ch.a, ch.q, ch.depth - 1});
      chords[c].right = chords.size();
      next.push_back(chords.size());
      chords.push_back({ch.q, ch.b, ch.depth - 1});
    }
    active.swap(next);
  }
  // Each chord's points in order: its first half's, its new point, its second half's.
  std::vector<Vec2> out;
  out.reserve(ring.size() + chords.size() / 2);
  std::function<void(std::size_t)> emit = [&](std::size_t c) {
    const Chord& ch = chords[c];
    if (ch.left == 0) return;
    emit(ch.left);
    out.push_back(ch.q);
    emit(ch.right);
  };
  for (std::size_t k = 0; k < ring.size(); ++k) {
    out.push_back(ring[k]);
    if (root[k] > 0) emit(root[k] - 1);
  }
  ring = std::move(out);
}

// {f <= levels[k]} over the rectangle, one region per level, for one material's fraction.
std::vector<Regions> below_sets(Evaluator& ev, double z, Vec2 lo, Vec2 hi, std::size_t material,
                                const std::vector<double>& levels, double resolution,
                                double chord_tolerance) {
  std::vector<Regions> below(levels.size());
  if (levels.empty()) return below;
  const Vec2 glo{lo.x - 2 * resolution, lo.y - 2 * resolution};
  const Vec2 ghi{hi.x + 2 * resolution, hi.y + 2 * resolution};
  FractionGrid grid(ev, z, glo, ghi, resolution, material);
  MarchOptions mo;
  mo.resolution = resolution;
  // Chords follow the iso-lines to chord_tolerance of the smallest gap between levels.
  double gap = 1;
  for (std::size_t k = 0; k < levels.size(); ++k)
    gap = std::min(gap, k ? levels[k] - levels[k - 1] : levels[k]);
  const double tol = chord_tolerance * std::max(gap, 1e-3);
  mo.value_tolerance = 0.25 * tol;
  for (std::size_t k = 0; k < levels.size(); ++k) {
    BelowLevel f(grid, levels[k], lo, hi);
    ContourSet cs = march_squares(f, glo, ghi, 0.0, mo);
    for (auto& ring : cs.lines.loops) refine_chords(ring, f, tol, 1e-4, lo, hi);
    below[k] = nest_oriented_rings(cs.lines.loops);
  }
  return below;
}

// The rectangle cut at increasing levels of one material's fraction (see level_slabs).
std::vector<Regions> rect_slabs(Evaluator& ev, double z, Vec2 lo, Vec2 hi, std::size_t material,
                                const std::vector<double>& levels, double resolution,
                                double chord_tolerance) {
  std::vector<Regions> below =
      below_sets(ev, z, lo, hi, material, levels, resolution, chord_tolerance);
  below.push_back({make_rectangle((lo + hi) * 0.5, hi.x - lo.x, hi.y - lo.y)});
  std::vector<Regions> slabs(below.size());
  for (std::size_t k = 0; k < below.size(); ++k)
    slabs[k] = k == 0 ? below[k] : difference(below[k], below[k - 1]);
  return slabs;
}

// Splits polylines among the bands [a, b) of nested sets below[k] = {f <= level k}: band k lies
// between below[k-1] and below[k]. Bisects on the bands (one inside and one outside clip per
// level of the recursion), so every line is clipped about 2·log2(bands) times, not once per band.
void split_bands(std::vector<std::vector<Vec2>> lines, const std::vector<Regions>& below, int a,
                 int b, const std::function<void(int, std::vector<std::vector<Vec2>>&)>& emit) {
  if (lines.empty()) return;
  if (b - a <= 1) {
    emit(a, lines);
    return;
  }
  const int mid = (a + b) / 2;
  const Regions& cut = below[static_cast<std::size_t>(mid - 1)];
  split_bands(clip_polylines(lines, cut, true), below, a, mid, emit);
  split_bands(clip_polylines(lines, cut, false), below, mid, b, emit);
}

void padded_box(const Regions& r, double pad, Vec2& lo, Vec2& hi) {
  BBox3 b;
  for (const auto& p : r)
    for (const Vec2 q : p.outer) b.add({q.x, q.y, 0});
  lo = {b.min.x - pad, b.min.y - pad};
  hi = {b.max.x + pad, b.max.y + pad};
}

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

void require_materials(const Field& field, const Palette& palette) {
  palette.check();
  if (field.materials().size() < static_cast<std::size_t>(palette.materials))
    throw GeometryError("gradient slicing with a " + std::to_string(palette.materials) +
                        "-material palette needs a design with " +
                        std::to_string(palette.materials) + " materials (an fgrade node)");
}

}  // namespace

std::vector<Regions> level_slabs(const Field& field, Evaluator& ev, double z, Vec2 lo, Vec2 hi,
                                 const std::vector<double>& levels, double resolution,
                                 double chord_tolerance) {
  if (field.materials().size() < 2)
    throw GeometryError("gradient slicing needs a design with two materials (an fgrade node)");
  return rect_slabs(ev, z, lo, hi, 0, levels, resolution, chord_tolerance);
}

std::vector<ColorFace> palette_zones(const Field& field, Evaluator& ev, double z, Vec2 lo, Vec2 hi,
                                     const Palette& palette, double resolution,
                                     double chord_tolerance) {
  require_materials(field, palette);
  const int d = palette.divisions();
  std::vector<double> levels;
  for (int k = 1; k < d; ++k) levels.push_back(palette.level(k));
  std::vector<ColorFace> zones;
  if (palette.materials == 2) {
    auto slabs = rect_slabs(ev, z, lo, hi, 0, levels, resolution, chord_tolerance);
    for (std::size_t k = 0; k < slabs.size(); ++k)
      if (!slabs[k].empty()) zones.push_back({static_cast<int>(k), std::move(slabs[k])});
    return zones;
  }
  // Three materials: triangle (i, j, k) = {i ≤ a·d < i+1} ∩ {j ≤ b·d < j+1} ∩ {k ≤ c·d < k+1}.
  std::vector<Regions> slabs[3];
  for (std::size_t m = 0; m < 3; ++m)
    slabs[m] = rect_slabs(ev, z, lo, hi, m, levels, resolution, chord_tolerance);
  for (int color = 0; color < palette.colors; ++color) {
    const Palette::Cell c = palette.cell(color);
    const auto& sa = slabs[0][static_cast<std::size_t>(c.i)];
    const auto& sb = slabs[1][static_cast<std::size_t>(c.j)];
    const auto& sc = slabs[2][static_cast<std::size_t>(c.k)];
    if (sa.empty() || sb.empty() || sc.empty()) continue;
    Regions r = intersection(intersection(sa, sb), sc);
    if (!r.empty()) zones.push_back({color, std::move(r)});
  }
  return zones;
}

std::vector<ColorFace> color_faces(const Field& field, Evaluator& ev, double z,
                                   const Regions& outline, const Palette& palette,
                                   double resolution, double chord_tolerance) {
  require_materials(field, palette);
  std::vector<ColorFace> faces;
  if (outline.empty()) return faces;
  Vec2 lo, hi;
  padded_box(outline, 2 * resolution, lo, hi);
  for (auto& zone : palette_zones(field, ev, z, lo, hi, palette, resolution, chord_tolerance)) {
    Regions r = intersection(outline, zone.region);
    if (!r.empty()) faces.push_back({zone.color, std::move(r)});
  }
  return faces;
}

namespace {

// Strategy 1's zones: a colour's band, or with zippering the overlap band around a colour
// boundary, where pieces alternate between the two neighbouring colours.
struct Zone {
  int a = 0, b = 0;       // colours (a == b: a plain face)
  std::size_t count = 0;  // pieces so far (for alternating)
};

// The zones a path order cuts paths at, over [zlo, zhi] at z: zone k lies between level k-1
// and level k (two materials: of the first fraction, with zippering β > 0 the overlap bands
// around each band edge as zones of their own; three: the palette's triangles, found by
// splitting on the first, second and third fractions), below[m][k] = {fraction m <= level k}.
struct PathZones {
  std::vector<double> levels;
  std::vector<Zone> zones;
  std::vector<Regions> below[3];
};
PathZones path_zones(Evaluator& ev, double z, Vec2 zlo, Vec2 zhi, const FgmOptions& o,
                     double beta) {
  const double res = std::max(o.material_resolution, o.bead_width / 2);
  PathZones pz;
  const int d = o.palette.divisions();
  for (int k = 1; k < d; ++k) {
    if (beta > 0) {
      pz.levels.push_back(o.palette.level(k) - beta / 2);
      pz.levels.push_back(o.palette.level(k) + beta / 2);
    } else {
      pz.levels.push_back(o.palette.level(k));
    }
  }
  if (o.palette.materials == 3) {
    pz.zones.resize(static_cast<std::size_t>(o.palette.colors));
    for (int c = 0; c < o.palette.colors; ++c) pz.zones[static_cast<std::size_t>(c)] = {c, c, 0};
    for (std::size_t m = 0; m < 3; ++m)
      pz.below[m] = below_sets(ev, z, zlo, zhi, m, pz.levels, res, 1e-4);
  } else {
    for (std::size_t k = 0; k <= pz.levels.size(); ++k) {
      const int c = beta > 0 ? static_cast<int>(k / 2) : static_cast<int>(k);
      pz.zones.push_back({c, beta > 0 && k % 2 ? c + 1 : c, 0});  // odd with β: overlap c | c+1
    }
    pz.below[0] = below_sets(ev, z, zlo, zhi, 0, pz.levels, res, 1e-4);
  }
  return pz;
}

// One layer in path order (FgmOrder::Paths): the planar paths cut where they cross the zones'
// edges (the contours of the sets below[m][k] = {fraction m <= level k}), each run coloured by
// the design at its middle (two materials: the zone between the levels; three: the palette's
// triangle), short runs merged along their bead, a tool changer's pieces grouped by tool.
std::vector<fgm::Piece> path_order_layer(const Layer& planar,
                                         const std::vector<Regions> (&below)[3],
                                         const std::vector<double>& levels,
                                         std::vector<Zone>& zones, Evaluator& ev, double z,
                                         std::size_t g, const FgmOptions& o, Vec2 zlo, Vec2 zhi,
                                         FgmStats& shorts) {
  std::vector<std::vector<Vec2>> rings;
  for (const auto& sets : below)
    for (const Regions& r : sets)
      for (auto& ring : rings_of(r)) rings.push_back(std::move(ring));
  fgm::EdgeGrid edges(rings, zlo, zhi);
  const bool three = o.palette.materials == 3;
  const std::size_t nm = ev.field().materials().size();
  std::vector<Vec3> q;
  std::vector<double> f, fk;
  auto zones_at = [&](const std::vector<Vec2>& p, std::vector<int>& out) {
    q.resize(p.size());
    for (std::size_t k = 0; k < p.size(); ++k) q[k] = {p[k].x, p[k].y, z};
    f.resize(p.size() * nm);
    ev.fractions(q.data(), q.size(), f.data());
    out.resize(p.size());
    for (std::size_t k = 0; k < p.size(); ++k) {
      const double* fr = f.data() + k * nm;
      if (three) {
        fk.assign(fr, fr + nm);
        out[k] = o.palette.color_of(fk);
      } else {
        const double v = nm == 0 ? 0.0 : fr[0];
        out[k] =
            static_cast<int>(std::lower_bound(levels.begin(), levels.end(), v) - levels.begin());
      }
    }
  };
  auto colour_of = [&](int zone) {
    Zone& zn = zones[static_cast<std::size_t>(zone)];
    return zn.count++ % 2 ? zn.b : zn.a;
  };
  auto pieces = fgm::split_paths(planar.paths, edges, zones_at, colour_of, o.palette);
  if (o.min_segment > 0)
    // The faces' edges follow the iso-lines to 1e-4 of a band (below_sets): a run that only
    // grazes the next band is within the bound to that tolerance.
    fgm::merge_short_runs(pieces, ev, z, o.palette, o.min_segment, 1e-4 * o.palette.band(), shorts);
  if (o.tool_changer && !pieces.empty()) {
    Vec2 cursor = pieces.front().path.points.front().xy();
    fgm::group_by_tool(pieces, g % 2 == 1, cursor);
  }
  shorts.short_kept = shorts.short_beads = 0;
  if (o.min_segment > 0)
    for (std::size_t k = 0; k < pieces.size(); ++k) {
      const bool short_piece = pieces[k].path.length() < o.min_segment;
      const bool bead =
          !pieces[k].path.joined && (k + 1 == pieces.size() || !pieces[k + 1].path.joined);
      shorts.short_kept += short_piece;
      shorts.short_beads += short_piece && bead;
    }
  return pieces;
}

// Strategy 2 in path order, one layer: each island filled whole (fgm_outline.hpp), the beads
// cut where they cross the colour zones' edges into joined pieces with their colour's mixture
// (path_order_layer, Strategy 1's cutter; no zippering).
void outline_layer(Evaluator& ev, const LayerOutline& lo, std::size_t g, const FgmOptions& o,
                   Layer& layer, std::vector<int>& colours, std::size_t& faces, FgmStats& shorts) {
  const double res = std::max(o.material_resolution, o.bead_width / 2);
  fgm::OutlineBeads beads = fgm::layer_beads(ev, lo, g, o);
  Layer uncut;
  uncut.z = layer.z;
  uncut.paths = std::move(beads.paths);
  if (uncut.paths.empty()) return;
  BBox3 box;
  for (const auto& p : uncut.paths)
    for (const auto& q : p.points) box.add({q.x, q.y, 0});
  const Vec2 zlo{box.min.x - 2 * res, box.min.y - 2 * res};
  const Vec2 zhi{box.max.x + 2 * res, box.max.y + 2 * res};
  PathZones pz = path_zones(ev, lo.z, zlo, zhi, o, 0);
  FgmOptions po = o;
  po.zipper = 0;
  auto pieces =
      path_order_layer(uncut, pz.below, pz.levels, pz.zones, ev, lo.z, g, po, zlo, zhi, shorts);
  fgm::apply_flow(pieces, beads.flow, o.bead_width);
  for (auto& piece : pieces) {
    colours.push_back(piece.color);
    layer.paths.push_back(std::move(piece.path));
  }
  for (const auto& zone : pz.zones) faces += zone.count > 0;
}

}  // namespace

Toolpath plan_fgm_strategy2(const Field& field, const std::vector<LayerOutline>& layers,
                            const FgmOptions& o, FgmStats* stats) {
  if (!(o.bead_width > 0) || !(o.resolution > 0))
    throw SettingError("bead width and resolution must be positive");
  require_materials(field, o.palette);
  // Layers are independent: planned in parallel (oneTBB), one evaluator per thread, each
  // layer's paths paired with their colours.
  struct Planned {
    Layer layer;
    std::vector<int> colors;
    std::size_t faces = 0;
    FgmStats shorts;  // short_* only
  };
  std::vector<Planned> planned(layers.size());
  // Path order on a machine that changes the mixture along a bead: each island filled whole
  // and cut at the colour zones (outline_layer); the paper's face-by-face fill otherwise.
  const bool outline_route = o.order == FgmOrder::Paths && !o.tool_changer && !o.concentric;
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::parallel_for(std::size_t{0}, layers.size(), [&](std::size_t li) {
    Evaluator& ev = evaluators.local();
    const LayerOutline& lo = layers[li];
    Planned& out = planned[li];
    Layer& layer = out.layer;
    const std::size_t g = o.first_layer + li;  // the part's layer (a shard plans a range)
    // As the planar slicer: the nozzle at the top of layer i, counted from the bed.
    layer.z = static_cast<double>(g + 1) * o.layer_height;
    if (outline_route) {
      outline_layer(ev, lo, g, o, out.layer, out.colors, out.faces, out.shorts);
      return;
    }
    // Material iso-lines on their own grid (half a bead at the finest: a face narrower than
    // that cannot be printed); crossings are refined on the field.
    // Paths stay half a bead inside their face: its edges need not follow the iso-lines closer
    // than a hundredth of a band (a tighter fit only adds vertices to the rings).
    auto faces = color_faces(field, ev, lo.z, lo.regions, o.palette,
                             std::max(o.material_resolution, o.bead_width / 2), 1e-2);
    out.faces = faces.size();
    // Palette order, reversed every other layer so a layer starts where the last one ended.
    if (g % 2 == 1) std::reverse(faces.begin(), faces.end());
    const double fixed_angle = o.angle_deg + (g % 2 ? 90.0 : 0.0);
    Vec2 cursor{0, 0};
    // The iso-line directions over the layer, on the material grid.
    std::optional<fgm::IsoDirections> directions;
    if (!o.fixed_angle && !faces.empty()) {
      Vec2 dlo, dhi;
      padded_box(lo.regions, 2 * o.bead_width, dlo, dhi);
      directions.emplace(ev, lo.z, dlo, dhi, std::max(o.material_resolution, o.bead_width / 2),
                         fixed_angle);
    }
    std::vector<std::vector<std::vector<Vec2>>> face_lines(faces.size());
    std::vector<Regions> inners(faces.size());
    std::vector<std::size_t> outer_rings(faces.size(), 0);  // face_lines[fi]'s first ones
    for (std::size_t fi = 0; fi < faces.size(); ++fi) {
      const ColorFace& face = faces[fi];
      // One ring half a bead inside the face (its bead reaches the face's edge, not beyond),
      // then concentric rings, or 100 % rectilinear lines inside the ring.
      Regions& inner = inners[fi];
      // Sharp corners (mitred up to 20 half-beads): the ring and the gap fill reach as far into
      // an acute corner as a round bead can without leaving the face.
      inner = offset(face.region, -o.bead_width / 2, 0.002, 20);
      std::vector<std::vector<Vec2>>& lines = face_lines[fi];
      auto add_rings = [&](const Regions& r) {
        for (auto ring : rings_of(r)) {
          if (ring.size() < 2) continue;
          ring.push_back(ring.front());
          lines.push_back(std::move(ring));
        }
      };
      add_rings(inner);
      outer_rings[fi] = lines.size();
      // Rings inward a bead apart (concentric: until none fits; rectilinear: the paper's palette
      // plates have 3 perimeters and 100 % infill, §7.5, so a face narrower than that is printed
      // along its iso-lines by rings alone). Where the next ring does not fit, the gap under a
      // bead and a quarter left in the middle gets one ring 3/4 of a bead further in (a sliver's
      // ring runs there and back: keep_uncovered keeps one way), and no lines.
      Regions last = inner;
      bool centre_filled = false;
      for (int k = 1; o.concentric || k < o.perimeters; ++k) {
        Regions r = offset(last, -o.bead_width);
        // Less than 1/8 bead beyond the next ring's centre line: its ring would run around a
        // sliver (or split into specks); the 3/4 ring covers the centre instead.
        if (r.empty() || offset(last, -1.125 * o.bead_width).empty()) {
          add_rings(offset(last, -0.75 * o.bead_width));
          centre_filled = true;
          break;
        }
        add_rings(r);
        last = std::move(r);
      }
      if (!o.concentric && !centre_filled) {
        // The lines reach into the innermost ring's bead by the overlap (what it covers already
        // is trimmed below).
        const Regions fill = offset(last, -o.bead_width * (1 - o.fill_overlap));
        // The paper's Strategy 2 prints perpendicular to the gradient: the lines run along the
        // iso-lines, or at a fixed angle, +90° a layer, if asked. A part of the fill whose
        // iso-lines keep one direction (their spread at least orient_agree) is hatched at that
        // direction; a curved one by sectors of directions, each sector's lines continued across
        // the sector's edges into lanes. They are chained into beads after the material balance.
        std::vector<std::vector<Vec2>> runs;
        auto hatch_at = [&](const Regions& r, double angle) {
          for (const auto& seg : hatch(r, angle, o.bead_width))
            if (std::hypot(seg.b.x - seg.a.x, seg.b.y - seg.a.y) >= 0.05)
              runs.push_back({seg.a, seg.b});
        };
        if (o.fixed_angle) {
          hatch_at(fill, fixed_angle);
        } else {
          for (const auto& poly : fill) {
            const Regions one{poly};
            double spread = 0, coherence = 0;
            const double angle = directions->mean_angle(one, &spread, &coherence);
            // One direction where the iso-lines keep one, or where they have none (three
            // materials' iso-lines crossing: sectors would cut the lines every way).
            if (spread >= o.orient_agree || coherence < 0.5) {
              hatch_at(one, angle);
              continue;
            }
            for (auto& lane : fgm::join_lanes(fgm::sector_lines(one, *directions, o.orient_sector,
                                                                o.bead_width, 0.05, angle),
                                              0.75 * o.bead_width, 1.5 * o.orient_sector))
              runs.push_back(std::move(lane));
          }
        }
        for (auto& run : runs) lines.push_back(std::move(run));
      }
    }
    // Material balance (the paper: "no additional material or time regardless of palette
    // size"): every face's outer ring, then its fill, then the gap fill, each kept only where its
    // bead mostly covers what no bead covers yet (keep_uncovered), so the volume extruded is the
    // faces' area × layer height at any palette size: fill lines end at the ring, a line beside
    // the ring nearer than half a bead goes, a ring of a face narrower than two beads does not
    // run back over itself.
    std::unique_ptr<BeadRaster> raster = layer_raster(faces, o.bead_width);
    if (raster) {
      const double min_piece = o.bead_width;
      std::vector<std::vector<std::vector<Vec2>>> kept(faces.size());
      auto keep = [&](std::size_t fi, const std::vector<Vec2>& line) {
        for (auto& piece : keep_uncovered(line, *raster, o.bead_width, min_piece))
          kept[fi].push_back(std::move(piece));
      };
      for (std::size_t fi = 0; fi < faces.size(); ++fi)
        for (std::size_t k = 0; k < outer_rings[fi]; ++k) keep(fi, face_lines[fi][k]);
      for (std::size_t fi = 0; fi < faces.size(); ++fi)
        for (std::size_t k = outer_rings[fi]; k < face_lines[fi].size(); ++k)
          keep(fi, face_lines[fi][k]);
      if (o.gap_fill) {
        const auto gaps = gap_lines(faces, inners, *raster, o.bead_width);
        for (std::size_t fi = 0; fi < faces.size(); ++fi)
          for (const auto& line : gaps[fi]) keep(fi, line);
      }
      face_lines = std::move(kept);
    }
    // Each face's rings whole, ring to ring, its lines into serpentines, its gap fill where it
    // is near: connectors up to three beads long inside the face (half a bead in from its edge),
    // longer ones (up to ten beads) along a boundary the lines meet at a shallow angle.
    fgm::ChainOptions chain;
    chain.max_connector = 3 * o.bead_width;
    chain.max_boundary_connector = 10 * o.bead_width;
    chain.bead = o.bead_width;
    chain.raster = raster.get();
    std::vector<std::pair<std::vector<Vec2>, int>> chains;  // (points, colour) in print order
    if (o.order == FgmOrder::Paths && !o.tool_changer) {
      // Path order: island by island (each polygon of a face's inner region with its pieces),
      // the next the island nearest where the last chain ended, whatever its colour (a mixing
      // hotend or a temperature change runs the look-ahead ahead of the nozzle; the palette
      // order would travel from island to island of one colour across the part).
      auto isles = fgm::islands(faces, inners, std::move(face_lines));
      std::vector<char> done(isles.size(), 0);
      for (std::size_t n = 0; n < isles.size(); ++n) {
        std::size_t pick = 0;
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < isles.size(); ++k)
          if (!done[k]) {
            const double d = fgm::island_distance(isles[k], cursor);
            if (d < best) best = d, pick = k;
          }
        done[pick] = 1;
        auto& island = isles[pick];
        for (auto& c : fgm::chain_pieces(std::move(island.pieces), {island.region}, chain, cursor))
          chains.push_back({std::move(c), island.colour});
      }
      // The layer's beads reordered for the least travel (nearest neighbour, then 2-opt).
      std::vector<OrderItem> items;
      for (const auto& c : chains)
        items.push_back({{c.first.front().x, c.first.front().y, 0},
                         {c.first.back().x, c.first.back().y, 0},
                         true});
      std::vector<std::pair<std::vector<Vec2>, int>> ordered;
      for (const OrderStep& step : order_by_travel(items, {0, 0, 0})) {
        auto& c = chains[step.item];
        if (step.reversed) std::reverse(c.first.begin(), c.first.end());
        ordered.push_back(std::move(c));
      }
      chains = std::move(ordered);
    } else {
      for (std::size_t fi = 0; fi < faces.size(); ++fi)
        for (auto& c : fgm::chain_pieces(std::move(face_lines[fi]), inners[fi], chain, cursor))
          chains.push_back({std::move(c), faces[fi].color});
    }
    for (const auto& [line, colour] : chains) {
      Path p;
      p.role = PathRole::Infill;
      p.mixture = o.palette.mixture(colour);
      p.width = o.bead_width;
      p.height = o.layer_height;
      for (const Vec2 q : line) p.points.push_back({q.x, q.y, layer.z});
      if (!(p.length() > 0)) continue;
      layer.paths.push_back(std::move(p));
      out.colors.push_back(colour);
    }
    merge_short_pieces(layer.paths, out.colors, ev, lo.z, o.palette, o.min_segment, out.shorts);
    // Travel between the beads kept inside the part where a route inside is short (the linking
    // stage's Comb: within a quarter bead outside the outline's outer bead), so the writer
    // neither retracts nor lifts for it.
    const Regions route = offset(lo.regions, -0.5 * o.bead_width);
    if (!route.empty()) {
      const Comb comb(offset(lo.regions, -0.25 * o.bead_width), route);
      for (std::size_t k = 1; k < layer.paths.size(); ++k) {
        Path& p = layer.paths[k];
        const Vec2 a = layer.paths[k - 1].points.back().xy(), b = p.points.front().xy();
        std::vector<Vec2> via;
        if (!p.joined &&
            comb.route(a, b, 3 * std::hypot(b.x - a.x, b.y - a.y) + o.bead_width, via)) {
          p.inside = true;
          for (const Vec2 v : via) p.via.push_back({v.x, v.y, layer.z});
        }
      }
    }
  });
  Toolpath tp;
  FgmStats st;
  st.shortest_path = std::numeric_limits<double>::infinity();
  int last_color = -1;
  std::vector<double> last_mixture;
  st.min_segment = o.min_segment;
  for (auto& pl : planned) {
    st.faces += pl.faces;
    st.short_merged += pl.shorts.short_merged;
    st.short_kept += pl.shorts.short_kept;
    st.short_kept_bound += pl.shorts.short_kept_bound;
    // Face by face every path is a bead; in path order pieces of a bead are counted apart.
    st.short_beads += outline_route ? pl.shorts.short_beads : pl.shorts.short_kept;
    for (std::size_t i = 0; i < pl.layer.paths.size(); ++i) {
      const Path& path = pl.layer.paths[i];
      if (pl.colors[i] != last_color && last_color >= 0) ++st.colour_changes;
      last_color = pl.colors[i];
      st.abrupt_changes += abrupt_start(last_mixture, path, o.palette);
      last_mixture = path.mixture;
      st.joined += path.joined;
      ++st.paths;
    }
    st.shortest_path = std::min(st.shortest_path, shortest_piece(pl.layer));
    if (!pl.layer.paths.empty()) tp.layers.push_back(std::move(pl.layer));
  }
  if (st.paths == 0) st.shortest_path = 0;
  if (stats) *stats = st;
  return tp;
}

void merge_short_pieces(std::vector<Path>& paths, std::vector<int>& colours, Evaluator& ev,
                        double z, const Palette& palette, double min, FgmStats& st) {
  if (!(min > 0) || paths.empty()) return;
  // α/2 (2α/3 for three materials), with a rounding allowance: a piece along a band's edge is
  // exactly α/2 from both colours.
  const double bound = palette.error_bound() + 1e-9;
  constexpr double touch = 1e-6;  // cut points of one line coincide
  auto near = [&](const Vec3& a, const Vec3& b) {
    return std::abs(a.x - b.x) <= touch && std::abs(a.y - b.y) <= touch;
  };
  auto samples = [&](const Path& p) { return fgm::design_along(ev, z, p); };
  const auto& error = fgm::mixture_error;
  // Pieces by their ends, on a grid of `touch` cells (a lookup checks the 3 x 3 cells around).
  auto key = [&](const Vec3& a) {
    return std::pair<long long, long long>{std::llround(a.x / touch), std::llround(a.y / touch)};
  };
  std::map<std::pair<long long, long long>, std::vector<std::size_t>> ends;
  auto add_ends = [&](std::size_t j) {
    if (paths[j].points.size() < 2) return;
    ends[key(paths[j].points.front())].push_back(j);
    ends[key(paths[j].points.back())].push_back(j);
  };
  for (std::size_t j = 0; j < paths.size(); ++j) add_ends(j);
  std::vector<char> dead(paths.size(), 0);
  for (std::size_t i = 0; i < paths.size(); ++i) {
    Path& p = paths[i];
    if (dead[i] || p.points.size() < 2 || !(p.length() < min)) continue;
    // Pieces of another colour and the same role touching an end of this one.
    std::vector<std::size_t> touching;
    for (const Vec3& end : {p.points.front(), p.points.back()}) {
      const auto k = key(end);
      for (long long dx = -1; dx <= 1; ++dx)
        for (long long dy = -1; dy <= 1; ++dy) {
          const auto it = ends.find({k.first + dx, k.second + dy});
          if (it == ends.end()) continue;
          for (std::size_t j : it->second) {
            const Path& q = paths[j];
            if (j == i || dead[j] || colours[j] == colours[i] || q.role != p.role ||
                q.points.size() < 2 ||
                std::find(touching.begin(), touching.end(), j) != touching.end())
              continue;
            if (near(end, q.points.front()) || near(end, q.points.back())) touching.push_back(j);
          }
        }
    }
    std::sort(touching.begin(), touching.end());
    if (touching.empty()) continue;
    const auto f = samples(p);
    std::size_t best = touching.front();
    double best_mean = std::numeric_limits<double>::infinity();
    for (std::size_t j : touching) {
      const double m = error(f, palette.mixture(colours[j]), false);
      if (m < best_mean) best_mean = m, best = j;
    }
    if (error(f, palette.mixture(colours[best]), true) > bound) {
      ++st.short_kept_bound;
      continue;
    }
    // Join: the neighbour's line runs on through this piece.
    Path& q = paths[best];
    std::vector<Vec3> pts = p.points;
    for (auto& v : pts) v.z = q.points.front().z;
    if (near(q.points.back(), pts.front())) {
      q.points.insert(q.points.end(), pts.begin() + 1, pts.end());
    } else if (near(q.points.back(), pts.back())) {
      q.points.insert(q.points.end(), pts.rbegin() + 1, pts.rend());
    } else if (near(q.points.front(), pts.back())) {
      q.points.insert(q.points.begin(), pts.begin(), pts.end() - 1);
    } else {
      q.points.insert(q.points.begin(), pts.rbegin(), pts.rend() - 1);
    }
    dead[i] = 1;
    add_ends(best);
    ++st.short_merged;
  }
  std::size_t n = 0;
  for (std::size_t i = 0; i < paths.size(); ++i) {
    if (dead[i]) continue;
    if (paths[i].length() < min) ++st.short_kept;
    if (n != i) {
      paths[n] = std::move(paths[i]);
      colours[n] = colours[i];
    }
    ++n;
  }
  paths.resize(n);
  colours.resize(n);
}

std::vector<GradientErrorSum> gradient_error_sums(const Field& field, const Toolpath& tp,
                                                  const std::vector<LayerOutline>& layers, double h,
                                                  std::size_t first_layer) {
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  std::vector<GradientErrorSum> acc(tp.layers.size());
  tbb::parallel_for(std::size_t{0}, tp.layers.size(), [&](std::size_t li) {
    const Layer& l = tp.layers[li];
    const auto idx = static_cast<std::size_t>(std::llround(l.z / h)) - 1 - first_layer;
    if (idx >= layers.size()) return;
    acc[li] = layer_gradient_error(evaluators.local(), l, layers[idx].z);
  });
  return acc;
}

GradientErrorSum layer_gradient_error(Evaluator& ev, const Layer& l, double z) {
  GradientErrorSum a;
  // Each path's points at once (the design's expressions evaluated over the path).
  const std::size_t nm = ev.field().materials().size();
  std::vector<Vec3> pts;
  std::vector<double> fr;
  for (const auto& p : l.paths) {
    if (p.mixture.empty() || p.role == PathRole::Other || p.role == PathRole::Purge) continue;
    if (nm == 0) continue;
    pts.resize(p.points.size());
    for (std::size_t k = 0; k < p.points.size(); ++k) pts[k] = {p.points[k].x, p.points[k].y, z};
    fr.resize(pts.size() * nm);
    ev.fractions(pts.data(), pts.size(), fr.data());
    for (std::size_t k = 0; k < p.points.size(); ++k) {
      const Vec3& q = p.points[k];
      const double* f = fr.data() + k * nm;
      double e = 0;
      for (std::size_t m = 0; m < nm && m < p.mixture.size(); ++m)
        e = std::max(e, std::abs(std::clamp(f[m], 0.0, 1.0) - p.mixture[m]));
      // The point's share of the path: half of each segment it ends.
      double w = 0;
      if (k > 0) w += 0.5 * distance(p.points[k - 1], q);
      if (k + 1 < p.points.size()) w += 0.5 * distance(q, p.points[k + 1]);
      a.sum += e * w;
      a.length += w;
      a.max = std::max(a.max, e);
      ++a.n;
    }
  }
  return a;
}

double shortest_piece(const Layer& layer) {
  double best = std::numeric_limits<double>::infinity(), run = 0;
  const Path* prev = nullptr;
  for (const Path& p : layer.paths) {
    const bool continues = prev && p.joined && p.mixture == prev->mixture;
    if (prev && !continues) best = std::min(best, run), run = 0;
    run += p.length();
    prev = &p;
  }
  if (prev) best = std::min(best, run);
  return best;
}

bool deposit_start_mixtures(Toolpath& tp, double lookahead) {
  if (!(lookahead > 0)) return false;
  // The mixture of the last graded path starting within the first `lookahead` mm (as the writer
  // counts printed length: paths of two points or more).
  const std::vector<double>* last = nullptr;
  double s = 0;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) {
      if (p.points.size() < 2) continue;
      if (s > lookahead) break;
      if (!p.mixture.empty()) last = &p.mixture;
      s += p.length();
    }
  if (!last) return false;
  const std::vector<double> held = *last;
  bool changed = false;
  s = 0;
  for (auto& l : tp.layers)
    for (auto& p : l.paths) {
      if (p.points.size() < 2) continue;
      if (s > lookahead) return changed;
      if (!p.mixture.empty() && p.mixture != held) p.mixture = held, changed = true;
      s += p.length();
    }
  return changed;
}

void measure_gradient_error(const Field& field, const Toolpath& tp,
                            const std::vector<LayerOutline>& layers, double h, FgmStats& st) {
  // One sum per layer, added in layer order: the report is the same for any thread count
  // (per-thread sums would be added in whatever order the threads ran).
  double sum = 0;
  st.error_max = 0;
  st.error_samples = 0;
  st.error_length = 0;
  for (const auto& a : gradient_error_sums(field, tp, layers, h)) {
    sum += a.sum;
    st.error_max = std::max(st.error_max, a.max);
    st.error_samples += a.n;
    st.error_length += a.length;
  }
  st.error_mean = st.error_length > 0 ? sum / st.error_length : 0;
}

double purge_length(double volume, double h, double w) {
  const double area = h * (w - h) + 3.14159265358979323846 * h * h / 4;
  return area > 0 ? volume / area : 0;
}

namespace tower {

PrimeTower::PrimeTower(const FgmOptions& o, const PurgeOptions& purge)
    : o_(o),
      purge_(purge),
      length_(purge.melt_volume > 0 ? purge_length(purge.melt_volume, o.layer_height, o.bead_width)
                                    : 0),
      part_{{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()},
            {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}} {}

bool PrimeTower::purges(int before, int after) const {
  if (before < 0 || after == before) return false;
  // The mixture change: the largest change of any material's share.
  const auto from = o_.palette.mixture(before), to = o_.palette.mixture(after);
  double change = 0;
  for (std::size_t m = 0; m < to.size(); ++m) change = std::max(change, std::abs(to[m] - from[m]));
  return change > purge_.threshold;
}

void PrimeTower::observe(const Layer& layer) {
  const std::size_t li = observed_++;
  if (!(purge_.melt_volume > 0)) return;
  std::size_t count = 0;
  for (const Path& p : layer.paths) {
    for (const auto& q : p.points) {
      part_.min = {std::min(part_.min.x, q.x), std::min(part_.min.y, q.y)};
      part_.max = {std::max(part_.max.x, q.x), std::max(part_.max.y, q.y)};
    }
    const int colour = colour_of(p);
    if (colour < 0) continue;
    if (first_colour_ < 0) first_colour_ = colour;
    count += purges(seen_, colour);
    seen_ = colour;
  }
  most_ = std::max(most_, count);
  if (count > 0) last_purge_layer_ = static_cast<long>(li);
}

bool PrimeTower::plan(FgmStats& st) {
  st.purges = 0;
  st.purge_length = st.purge_volume = 0;
  st.tower = {};
  if (!(purge_.melt_volume > 0) || last_purge_layer_ < 0) return false;
  // The footprint of the beads, not of their centre lines.
  const BBox2 beads{{part_.min.x - o_.bead_width / 2, part_.min.y - o_.bead_width / 2},
                    {part_.max.x + o_.bead_width / 2, part_.max.y + o_.bead_width / 2}};
  block_ = plan_tower(beads, most_, length_, o_.bead_width, purge_);
  st.tower.built = true;
  st.tower.x = block_->centre().x;
  st.tower.y = block_->centre().y;
  st.tower.side = std::max(block_->size_x(), block_->size_y());
  st.tower.size_x = block_->size_x();
  st.tower.size_y = block_->size_y();
  st.tower.purge_path = length_;
  st.tower.layers = static_cast<std::size_t>(last_purge_layer_) + 1;
  return true;
}

Path PrimeTower::tower_path(std::vector<Vec2> pts, int colour, double z) {
  Path p;
  p.role = PathRole::Purge;
  p.mixture = o_.palette.mixture(colour);
  p.width = o_.bead_width;
  p.height = o_.layer_height;
  for (const Vec2 q : pts) p.points.push_back({q.x, q.y, z});
  TowerColour& c = colours_[colour];
  c.color = colour;
  c.mixture = p.mixture;
  c.length += p.length();
  return p;
}

void PrimeTower::add(std::size_t li, Layer& layer) {
  if (!block_) return;
  const Block& sq = *block_;
  // Which paths purge (the colour before a layer's first path is the last of the layer below).
  std::vector<char> purge_before(layer.paths.size(), 0);
  long count = 0;
  for (int last = last_, i = 0; i < static_cast<int>(layer.paths.size()); ++i) {
    const int colour = colour_of(layer.paths[static_cast<std::size_t>(i)]);
    if (colour < 0) continue;
    if (purges(last, colour)) purge_before[static_cast<std::size_t>(i)] = 1, ++count;
    last = colour;
  }
  std::vector<Path> out;
  const bool across = li % 2 == 1;  // lines cross the layer below's
  const int k = sq.lines_for(length_, across);
  int used = 0;
  if (static_cast<long>(li) <= last_purge_layer_) {
    // Wall and sparse lines in the colour already loaded, around the lines the purges use.
    const int base = last_ >= 0 ? last_ : first_colour_;
    out.push_back(tower_path(sq.wall(), base, layer.z));
    auto sparse = sq.sparse(static_cast<int>(count) * k, across);
    if (sparse.size() >= 2) out.push_back(tower_path(std::move(sparse), base, layer.z));
  }
  for (std::size_t i = 0; i < layer.paths.size(); ++i) {
    const int colour = colour_of(layer.paths[i]);
    if (purge_before[i]) {
      Path p = tower_path(sq.zigzag(used, k, across), colour, layer.z);
      used += k;
      purge_length_ += p.length();
      ++purges_;
      ++colours_[colour].purges;
      out.push_back(std::move(p));
    }
    if (colour >= 0) last_ = colour;
    out.push_back(std::move(layer.paths[i]));
  }
  layer.paths = std::move(out);
}

void PrimeTower::finish(FgmStats& st) const {
  if (!block_) return;
  st.purges = purges_;
  st.purge_length = purge_length_;
  const double bead_area = o_.layer_height * (o_.bead_width - o_.layer_height) +
                           3.14159265358979323846 * o_.layer_height * o_.layer_height / 4;
  st.purge_volume = st.purge_length * bead_area;
  for (auto [colour, c] : colours_) {
    c.volume = c.length * bead_area;
    double density = 0;
    for (std::size_t m = 0; m < c.mixture.size(); ++m)
      density += c.mixture[m] * (m < purge_.density.size() ? purge_.density[m] : 1.0);
    c.mass = c.volume * 1e-3 * density;
    c.time = purge_.speed > 0 ? c.length / purge_.speed : 0;
    st.tower.length += c.length;
    st.tower.volume += c.volume;
    st.tower.mass += c.mass;
    st.tower.time += c.time;
    st.tower.colours.push_back(c);
  }
}

}  // namespace tower

void add_prime_tower(Toolpath& tp, const FgmOptions& o, const PurgeOptions& purge, FgmStats& st) {
  tower::PrimeTower t(o, purge);
  for (const Layer& l : tp.layers) t.observe(l);
  if (!t.plan(st)) return;
  for (std::size_t li = 0; li < tp.layers.size(); ++li) t.add(li, tp.layers[li]);
  t.finish(st);
}

const char* to_string(FgmOrder order) {
  return order == FgmOrder::Paths ? "paths" : "faces";
}

bool abrupt_start(const std::vector<double>& before, const Path& path, const Palette& palette) {
  if (path.joined || before.empty() || path.mixture.size() != before.size()) return false;
  double change = 0;
  for (std::size_t m = 0; m < before.size(); ++m)
    change = std::max(change, std::abs(path.mixture[m] - before[m]));
  return change > palette.band() + 1e-9;
}

Toolpath plan_fgm_strategy1(const Field& field, const std::vector<LayerOutline>& layers,
                            const Toolpath& planar, const FgmOptions& o, const PurgeOptions& purge,
                            FgmStats* stats) {
  if (!(o.bead_width > 0) || !(o.layer_height > 0))
    throw SettingError("bead width and layer height must be positive");
  if (!(o.zipper >= 0) || o.zipper >= o.palette.band())
    throw SettingError("the zipper overlap must be in [0, one colour band) of the gradient");
  require_materials(field, o.palette);
  if (o.zipper > 0 && o.palette.materials != 2)
    throw SettingError("zippering interlocks two neighbouring colours of a two-material palette");
  using fgm::Piece;
  std::vector<std::vector<Piece>> per(planar.layers.size());
  std::vector<std::size_t> faces_per(planar.layers.size(), 0);
  std::vector<FgmStats> shorts_per(planar.layers.size());  // short_* only
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::parallel_for(std::size_t{0}, planar.layers.size(), [&](std::size_t li) {
    Evaluator& ev = evaluators.local();
    const Layer& pl = planar.layers[li];
    // The outline this layer was planned from: nozzle z = (g + 1) h for the part's layer g
    // (a shard's outlines start at first_layer).
    const auto g = static_cast<std::size_t>(std::llround(pl.z / o.layer_height)) - 1;
    if (g < o.first_layer) return;
    const std::size_t idx = g - o.first_layer;
    if (idx >= layers.size()) return;
    // Zones: a colour's band, or with zippering the overlap band around each colour boundary
    // (|f - k/N| < β/2), where pieces alternate between the two neighbouring colours.
    const double res = std::max(o.material_resolution, o.bead_width / 2);
    const double beta = o.zipper;
    const double z = layers[idx].z;
    // The planar paths lie inside the outline: the zones need not be cut by it (the outline's
    // many vertices would make every clip slower), only cover the paths' box.
    BBox3 box;
    for (const auto& p : pl.paths)
      for (const auto& q : p.points) box.add({q.x, q.y, 0});
    if (box.empty()) return;
    // Two cells of margin: chords ending on the zones' border are not refined onto the iso-lines.
    const Vec2 zlo{box.min.x - 2 * res, box.min.y - 2 * res};
    const Vec2 zhi{box.max.x + 2 * res, box.max.y + 2 * res};
    const int d = o.palette.divisions();
    PathZones pz = path_zones(ev, z, zlo, zhi, o, beta);
    const std::vector<double>& levels = pz.levels;
    std::vector<Zone>& zones = pz.zones;
    const std::vector<Regions>(&below)[3] = pz.below;
    const int bands = static_cast<int>(levels.size()) + 1;
    if (o.order == FgmOrder::Paths) {
      per[li] = path_order_layer(pl, below, levels, zones, ev, z, g, o, zlo, zhi, shorts_per[li]);
      for (const auto& zone : zones) faces_per[li] += zone.count > 0;
      return;
    }

    // Paths of one role share their attributes: each role's paths are cut together (piece
    // order within a role follows Clipper's, not the planar order).
    std::vector<std::pair<PathRole, std::vector<std::size_t>>> roles;
    for (std::size_t k = 0; k < pl.paths.size(); ++k) {
      auto it = std::find_if(roles.begin(), roles.end(),
                             [&](const auto& r) { return r.first == pl.paths[k].role; });
      if (it == roles.end()) {
        roles.push_back({pl.paths[k].role, {}});
        it = roles.end() - 1;
      }
      it->second.push_back(k);
    }
    for (const auto& [role, ids] : roles) {
      std::vector<std::vector<Vec2>> lines;
      for (std::size_t k : ids) {
        std::vector<Vec2> line;
        for (const auto& q : pl.paths[k].points) line.push_back(q.xy());
        lines.push_back(std::move(line));
      }
      const Path& proto = pl.paths[ids.front()];  // role, width, height, speed
      auto emit = [&](int zone_index, std::vector<std::vector<Vec2>>& pieces) {
        Zone& zone = zones[static_cast<std::size_t>(zone_index)];
        for (auto& piece : pieces) {
          if (piece.size() < 2) continue;
          Path p;
          p.role = proto.role;
          p.width = proto.width;
          p.height = proto.height;
          p.speed = proto.speed;
          p.tool = proto.tool;
          for (const Vec2 q : piece) p.points.push_back({q.x, q.y, pl.z});
          if (p.length() <= 1e-9) continue;
          const int color = zone.count++ % 2 ? zone.b : zone.a;
          p.mixture = o.palette.mixture(color);
          per[li].push_back({std::move(p), color});
        }
      };
      if (o.palette.materials != 3) {
        split_bands(std::move(lines), below[0], 0, bands, emit);
        continue;
      }
      // Triangle (i, j): up if i + j = d - 1, else down where the third fraction is below
      // (d - 1 - i - j)/d.
      split_bands(
          std::move(lines), below[0], 0, d, [&](int i, std::vector<std::vector<Vec2>>& li_) {
            split_bands(
                std::move(li_), below[1], 0, d, [&](int j, std::vector<std::vector<Vec2>>& lj) {
                  j = std::min(j, d - 1 - i);
                  if (i + j >= d - 1) {
                    emit(o.palette.color_of_cell(i, j, true), lj);
                    return;
                  }
                  const Regions& cut = below[2][static_cast<std::size_t>(d - 2 - i - j)];
                  auto down = clip_polylines(lj, cut, true), up = clip_polylines(lj, cut, false);
                  emit(o.palette.color_of_cell(i, j, false), down);
                  emit(o.palette.color_of_cell(i, j, true), up);
                });
          });
    }
    // Faces: zones that some path crosses.
    for (const auto& zone : zones) faces_per[li] += zone.count > 0;
    if (o.min_segment > 0) {
      std::vector<Path> paths;
      std::vector<int> colours;
      for (auto& piece : per[li]) {
        paths.push_back(std::move(piece.path));
        colours.push_back(piece.color);
      }
      merge_short_pieces(paths, colours, ev, z, o.palette, o.min_segment, shorts_per[li]);
      per[li].clear();
      for (std::size_t k = 0; k < paths.size(); ++k)
        per[li].push_back({std::move(paths[k]), colours[k]});
    }
    // Colour by colour in palette order (reversed every other layer), the planar order within.
    std::stable_sort(per[li].begin(), per[li].end(), [&](const Piece& a, const Piece& b) {
      return g % 2 ? a.color > b.color : a.color < b.color;
    });
    if (o.min_segment > 0) {
      // Pieces of one colour and role printed one after the other where one ends and the next
      // begins (a line cut only by a merged piece) are one piece: count the printed ones.
      std::vector<Piece> joined;
      for (auto& piece : per[li]) {
        if (!joined.empty()) {
          Path& last = joined.back().path;
          const Vec3 a = last.points.back(), b = piece.path.points.front();
          if (joined.back().color == piece.color && last.role == piece.path.role &&
              last.width == piece.path.width && last.speed == piece.path.speed &&
              std::abs(a.x - b.x) <= 1e-6 && std::abs(a.y - b.y) <= 1e-6) {
            last.points.insert(last.points.end(), piece.path.points.begin() + 1,
                               piece.path.points.end());
            continue;
          }
        }
        joined.push_back(std::move(piece));
      }
      per[li] = std::move(joined);
      shorts_per[li].short_kept = 0;
      for (const auto& piece : per[li])
        shorts_per[li].short_kept += piece.path.length() < o.min_segment;
      shorts_per[li].short_beads = shorts_per[li].short_kept;  // face order: every piece a bead
    }
  });
  Toolpath tp;
  FgmStats st;
  st.shortest_path = std::numeric_limits<double>::infinity();
  int last = -1;
  std::vector<double> last_mixture;
  st.min_segment = o.min_segment;
  for (std::size_t li = 0; li < per.size(); ++li) {
    st.faces += faces_per[li];
    st.short_merged += shorts_per[li].short_merged;
    st.short_kept += shorts_per[li].short_kept;
    st.short_kept_bound += shorts_per[li].short_kept_bound;
    st.short_beads += shorts_per[li].short_beads;
    Layer layer;
    layer.z = planar.layers[li].z;
    for (auto& piece : per[li]) {
      if (last >= 0 && piece.color != last) ++st.colour_changes;
      st.abrupt_changes += abrupt_start(last_mixture, piece.path, o.palette);
      last = piece.color;
      last_mixture = piece.path.mixture;
      st.shortest_path = std::min(st.shortest_path, piece.path.length());
      ++st.paths;
      st.joined += piece.path.joined;
      layer.paths.push_back(std::move(piece.path));
    }
    if (!layer.paths.empty()) tp.layers.push_back(std::move(layer));
  }
  if (o.order == FgmOrder::Faces || o.tool_changer) add_prime_tower(tp, o, purge, st);
  if (st.paths == 0) st.shortest_path = 0;
  if (stats) *stats = st;
  return tp;
}

}  // namespace trellis
