// Colour faces of a graded layer: the sets {fraction <= level} contoured on a grid of each
// material's fraction (evaluated once a node), their chords refined onto the iso-lines, the
// slabs between levels and the palette's zones (bands, or triangles for three materials), cut
// by the layer's outline.
#include <algorithm>
#include <cmath>
#include <string>

#include "fgm_internal.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/contour.hpp"

namespace trellis {

namespace fgm {

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

}  // namespace

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

namespace {

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

}  // namespace

void padded_box(const Regions& r, double pad, Vec2& lo, Vec2& hi) {
  BBox3 b;
  for (const auto& p : r)
    for (const Vec2 q : p.outer) b.add({q.x, q.y, 0});
  lo = {b.min.x - pad, b.min.y - pad};
  hi = {b.max.x + pad, b.max.y + pad};
}

void require_materials(const Field& field, const Palette& palette) {
  palette.check();
  if (field.materials().size() < static_cast<std::size_t>(palette.materials))
    throw GeometryError("gradient slicing with a " + std::to_string(palette.materials) +
                        "-material palette needs a design with " +
                        std::to_string(palette.materials) + " materials (an fgrade node)");
}

}  // namespace fgm

std::vector<Regions> level_slabs(const Field& field, Evaluator& ev, double z, Vec2 lo, Vec2 hi,
                                 const std::vector<double>& levels, double resolution,
                                 double chord_tolerance) {
  if (field.materials().size() < 2)
    throw GeometryError("gradient slicing needs a design with two materials (an fgrade node)");
  return fgm::rect_slabs(ev, z, lo, hi, 0, levels, resolution, chord_tolerance);
}

std::vector<ColorFace> palette_zones(const Field& field, Evaluator& ev, double z, Vec2 lo, Vec2 hi,
                                     const Palette& palette, double resolution,
                                     double chord_tolerance) {
  fgm::require_materials(field, palette);
  const int d = palette.divisions();
  std::vector<double> levels;
  for (int k = 1; k < d; ++k) levels.push_back(palette.level(k));
  std::vector<ColorFace> zones;
  if (palette.materials == 2) {
    auto slabs = fgm::rect_slabs(ev, z, lo, hi, 0, levels, resolution, chord_tolerance);
    for (std::size_t k = 0; k < slabs.size(); ++k)
      if (!slabs[k].empty()) zones.push_back({static_cast<int>(k), std::move(slabs[k])});
    return zones;
  }
  // Three materials: triangle (i, j, k) = {i ≤ a·d < i+1} ∩ {j ≤ b·d < j+1} ∩ {k ≤ c·d < k+1}.
  std::vector<Regions> slabs[3];
  for (std::size_t m = 0; m < 3; ++m)
    slabs[m] = fgm::rect_slabs(ev, z, lo, hi, m, levels, resolution, chord_tolerance);
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
  fgm::require_materials(field, palette);
  std::vector<ColorFace> faces;
  if (outline.empty()) return faces;
  Vec2 lo, hi;
  fgm::padded_box(outline, 2 * resolution, lo, hi);
  for (auto& zone : palette_zones(field, ev, z, lo, hi, palette, resolution, chord_tolerance)) {
    Regions r = intersection(outline, zone.region);
    if (!r.empty()) faces.push_back({zone.color, std::move(r)});
  }
  return faces;
}

}  // namespace trellis
