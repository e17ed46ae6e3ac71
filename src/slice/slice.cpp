#include "trellis/slice/slice.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/link.hpp"

namespace trellis {

void FieldSection::sample(const Vec2* points, double* out, std::size_t n) {
  if (buffer_.size() < n) buffer_.resize(n);
  for (std::size_t i = 0; i < n; ++i) buffer_[i] = {points[i].x, points[i].y, z_};
  ev_.values(buffer_.data(), out, n);
}

Interval FieldSection::bound(Vec2 lo, Vec2 hi) {
  BBox3 b;
  b.add({lo.x, lo.y, z_});
  b.add({hi.x, hi.y, z_});
  return ev_.bound(b);
}

std::vector<double> layer_planes(double zmin, double zmax, double h) {
  std::vector<double> zs;
  if (!(h > 0) || !(zmax > zmin)) return zs;
  const auto n = static_cast<std::size_t>(std::ceil((zmax - zmin) / h - 1e-6));
  // A last, partial layer is cut just below the top so it is not empty.
  for (std::size_t i = 0; i < n; ++i)
    zs.push_back(std::min(zmin + (static_cast<double>(i) + 0.5) * h, zmax - 1e-3 * h));
  return zs;
}

MarchOptions FieldSliceOptions::march() const {
  MarchOptions m;
  m.resolution = resolution;
  return m;
}

namespace {

void require_finite_xy(const BBox3& e) {
  if (e.empty() || !std::isfinite(e.min.x) || !std::isfinite(e.max.x) || !std::isfinite(e.min.y) ||
      !std::isfinite(e.max.y))
    throw GeometryError(
        "the design has no finite extent in X and Y; give it a root((min),(max),(voxel)) box or "
        "intersect it with a solid");
}

}  // namespace

Regions contour_at(const Field& field, Evaluator& ev, double z, const FieldSliceOptions& options,
                   SliceStats* stats) {
  if (!(options.resolution > 0)) throw SettingError("resolution must be > 0");
  const BBox3 e = field.extent();
  require_finite_xy(e);
  const double pad = 2 * options.resolution;
  // Grid anchored on multiples of the resolution so layers share grid lines.
  const double h = options.resolution;
  const Vec2 lo{std::floor((e.min.x - pad) / h) * h, std::floor((e.min.y - pad) / h) * h};
  const Vec2 hi{std::ceil((e.max.x + pad) / h) * h, std::ceil((e.max.y + pad) / h) * h};
  const double cells = (hi.x - lo.x) / h * (hi.y - lo.y) / h;
  if (cells > 4e9)
    throw SettingError("resolution " + std::to_string(h) +
                       " mm is too fine for this design's size");
  FieldSection section(ev, z);
  const ContourSet set = march_squares(section, lo, hi, 0.0, options.march());
  if (stats) {
    stats->samples += set.samples;
    stats->blocks += set.blocks;
    stats->skipped_blocks += set.skipped_blocks;
  }
  return nest_oriented_rings(set.lines.loops);
}

std::vector<LayerOutline> slice_field(const Field& field, const std::vector<double>& zs,
                                      const FieldSliceOptions& options, SliceStats* stats,
                                      const RunContext& context) {
  const Progress& progress = context.progress;
  require_finite_xy(field.extent());
  std::vector<LayerOutline> out(zs.size());
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::enumerable_thread_specific<SliceStats> local;
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex;
  context.run([&] {
    tbb::parallel_for(std::size_t{0}, zs.size(), [&](std::size_t i) {
      progress.check("slicing");
      out[i].z = zs[i];
      out[i].regions = contour_at(field, evaluators.local(), zs[i], options, &local.local());
      const std::size_t d = ++done;
      if (progress.report && (d % 16 == 0 || d == zs.size())) {
        std::lock_guard lock(progress_mutex);
        progress("outlines", static_cast<double>(d) / static_cast<double>(zs.size()));
      }
    });
  });
  if (stats)
    for (const auto& s : local) {
      stats->samples += s.samples;
      stats->blocks += s.blocks;
      stats->skipped_blocks += s.skipped_blocks;
    }
  return out;
}

std::vector<LayerOutline> slice_mesh_layers(const TriangleMesh& mesh, const std::vector<double>& zs,
                                            double stitch_tolerance, bool overlapping) {
  std::vector<LayerOutline> out(zs.size());
  const auto buckets = triangles_by_plane(mesh, zs);
  tbb::parallel_for(std::size_t{0}, zs.size(), [&](std::size_t i) {
    out[i].z = zs[i];
    out[i].regions = slice_mesh(mesh, zs[i], buckets[i], stitch_tolerance, overlapping);
  });
  return out;
}

// ---------------------------------------------------------------- planar slicer

namespace {

// A layer's skin: its outline O less what lies under it all the way down (`under`, the
// intersection of the layers below that the skin reaches) and over it all the way up (`over`),
// C = under ∩ over (null: no skin on that side), opened by half a bead so that slivers narrower
// than a bead (a slowly changing wall) get no solid lines. Opened as
// dilate(erode(O) − dilate(C)), the same set as dilate(erode(O − C)) (up to Clipper's mitred
// corners, well under a micrometre): erode(O) is the outer walls' region (`eroded`), and O − C,
// mostly slivers along sloped walls, was the costliest region of a layer to subtract and offset.
// C is simplified by `tolerance` (the outlines' own) before it is dilated: where the layers'
// walls nearly coincide their intersection zig-zags between them (2.3 times the outline's
// vertices on TR12J_OCC.stl), and dilating those zig-zags was a fifth of the slicing time.
Regions skin_of(const Regions& eroded, const Regions* under, const Regions* over, double bead,
                double tolerance) {
  if ((!under && !over) || eroded.empty()) return {};
  Regions cover;
  if (under && over)
    cover = under->empty() || over->empty() ? Regions{} : intersection(*under, *over);
  else
    cover = under ? *under : *over;
  const Regions core =
      cover.empty() ? eroded : difference(eroded, offset(simplify(cover, tolerance), 0.5 * bead));
  return core.empty() ? core : offset(core, 0.5 * bead);
}

// An island's wall regions, outside in: the outline offset by -(k + 0.5) beads, k < walls, while
// not empty. Each wall's region is the one outside it offset by one bead: inward offsets add up
// (the offset edges are parallel lines), and the wall outside has fewer vertices to offset than
// the outline (a slice's noise and narrow features are gone).
std::vector<Regions> wall_regions(const Polygon2& island, int walls, double bead) {
  std::vector<Regions> out;
  for (int k = 0; k < walls; ++k) {
    Regions r = k == 0 ? offset(Regions{island}, -0.5 * bead) : offset(out.back(), -bead);
    if (r.empty()) break;
    out.push_back(std::move(r));
  }
  return out;
}

// Hatch lines in sweep order → greedy nearest end among the next few lines (zig-zag order).
void order_lines(std::vector<Segment2> lines, Vec2& cursor, std::vector<std::vector<Vec2>>& out) {
  constexpr std::size_t kWindow = 24;
  std::vector<char> used(lines.size(), 0);
  std::size_t first = 0;
  for (std::size_t count = 0; count < lines.size(); ++count) {
    while (first < lines.size() && used[first]) ++first;
    std::size_t best = first;
    bool reverse = false;
    double bd = 1e300;
    for (std::size_t k = first, seen = 0; k < lines.size() && seen < kWindow; ++k) {
      if (used[k]) continue;
      ++seen;
      const double da = dist2(cursor, lines[k].a), db = dist2(cursor, lines[k].b);
      if (da < bd) {
        bd = da;
        best = k;
        reverse = false;
      }
      if (db < bd) {
        bd = db;
        best = k;
        reverse = true;
      }
    }
    used[best] = 1;
    Segment2 s = lines[best];
    if (reverse) std::swap(s.a, s.b);
    out.push_back({s.a, s.b});
    cursor = s.b;
  }
}

}  // namespace

namespace {

// Ordered lines → runs: consecutive lines whose ends are neighbours are joined by a short
// connector (a zig-zag) when the connector stays in the region (within half a bead), so a solid
// fill is a few long paths instead of many short ones with travel between.
std::vector<std::vector<Vec2>> link_runs(const std::vector<std::vector<Vec2>>& lines,
                                         const Regions& r, double spacing, double bead_width,
                                         bool link) {
  std::vector<std::vector<Vec2>> runs;
  std::vector<Vec2> run;
  auto flush = [&] {
    if (run.size() >= 2) runs.push_back(run);
    run.clear();
  };
  for (const auto& l : lines) {
    if (link && !run.empty()) {
      const Vec2 a = run.back(), b = l.front();
      const Vec2 mid = (a + b) * 0.5;
      bool inside_region = false;
      if (std::sqrt(dist2(a, b)) <= 2.0 * spacing)
        for (const auto& poly : r)
          if (contains(poly, mid, 0.5 * bead_width)) {
            inside_region = true;
            break;
          }
      if (inside_region) {
        run.insert(run.end(), l.begin(), l.end());
        continue;
      }
    }
    flush();
    run = l;
  }
  flush();
  return runs;
}

}  // namespace

std::vector<std::vector<Vec2>> fill_lines(const Regions& r, double angle, double spacing,
                                          double bead_width, double min_path, bool link,
                                          Vec2& cursor) {
  if (r.empty() || !(spacing > 0)) return {};
  std::vector<Segment2> kept;
  for (const auto& s : hatch(r, angle, spacing))
    if (std::sqrt(dist2(s.a, s.b)) >= min_path) kept.push_back(s);
  std::vector<std::vector<Vec2>> lines;
  order_lines(std::move(kept), cursor, lines);
  return link_runs(lines, r, spacing, bead_width, link);
}

std::vector<std::vector<Vec2>> fill_lines_oriented(const Regions& r,
                                                   const std::function<double(Vec2)>& angle_of,
                                                   double cell, double quantum, double spacing,
                                                   double bead_width, double min_path, bool link,
                                                   Vec2& cursor) {
  if (r.empty() || !(spacing > 0) || !(cell > 0) || !(quantum > 0)) return {};
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& p : r)
    for (const Vec2 q : p.outer)
      x0 = std::min(x0, q.x), y0 = std::min(y0, q.y), x1 = std::max(x1, q.x),
      y1 = std::max(y1, q.y);
  const long i0 = static_cast<long>(std::floor(x0 / cell)),
             j0 = static_cast<long>(std::floor(y0 / cell));
  const long ni = static_cast<long>(std::floor(x1 / cell)) - i0 + 1;
  const long nj = static_cast<long>(std::floor(y1 / cell)) - j0 + 1;
  // Each cell's angle (quantised, in [0, 180)), from its centre.
  const int steps = std::max(1, static_cast<int>(std::lround(180 / quantum)));
  std::vector<int> angle(static_cast<std::size_t>(ni * nj));
  std::vector<char> used(static_cast<std::size_t>(steps), 0);
  for (long j = 0; j < nj; ++j)
    for (long i = 0; i < ni; ++i) {
      const Vec2 c{(static_cast<double>(i0 + i) + 0.5) * cell,
                   (static_cast<double>(j0 + j) + 0.5) * cell};
      double a = std::fmod(angle_of(c), 180.0);
      if (a < 0) a += 180;
      const int q = static_cast<int>(std::lround(a / (180.0 / steps))) % steps;
      angle[static_cast<std::size_t>(j * ni + i)] = q;
      used[static_cast<std::size_t>(q)] = 1;
    }
  auto cell_of = [&](Vec2 p) {
    const long i = std::clamp(static_cast<long>(std::floor(p.x / cell)) - i0, 0L, ni - 1);
    const long j = std::clamp(static_cast<long>(std::floor(p.y / cell)) - j0, 0L, nj - 1);
    return static_cast<std::size_t>(j * ni + i);
  };
  // Each angle hatches the whole region once; a line keeps its stretches in cells of that angle
  // (cut where it crosses cell edges), so every part of the region gets its cell's lines.
  std::vector<Segment2> kept;
  std::vector<std::size_t> cells;  // each kept piece's cell
  std::vector<double> ts;
  for (int q = 0; q < steps; ++q) {
    if (!used[static_cast<std::size_t>(q)]) continue;
    for (const auto& s : hatch(r, q * (180.0 / steps), spacing)) {
      ts.assign({0.0, 1.0});
      const Vec2 d = s.b - s.a;
      for (int axis = 0; axis < 2; ++axis) {
        const double pa = axis ? s.a.y : s.a.x, dp = axis ? d.y : d.x;
        if (std::abs(dp) < 1e-15) continue;
        const double lo = std::min(pa, pa + dp), hi = std::max(pa, pa + dp);
        for (double e = std::ceil(lo / cell) * cell; e < hi; e += cell) ts.push_back((e - pa) / dp);
      }
      std::sort(ts.begin(), ts.end());
      double start = -1;
      for (std::size_t k = 0; k + 1 < ts.size(); ++k) {
        const bool mine = angle[cell_of(s.a + d * (0.5 * (ts[k] + ts[k + 1])))] == q;
        if (mine && start < 0) start = ts[k];
        if ((!mine || k + 2 == ts.size()) && start >= 0) {
          const double end = mine ? ts[k + 1] : ts[k];
          const Segment2 piece{s.a + d * start, s.a + d * end};
          if (std::sqrt(dist2(piece.a, piece.b)) >= min_path) {
            kept.push_back(piece);
            cells.push_back(cell_of(s.a + d * (0.5 * (start + end))));
          }
          start = -1;
        }
      }
    }
  }
  // Cell by cell (rows of cells, every other row backwards), each cell's lines in sweep order,
  // so the zig-zag links stay within a cell.
  auto rank = [&](std::size_t c) {
    const std::size_t j = c / static_cast<std::size_t>(ni), i = c % static_cast<std::size_t>(ni);
    return j * static_cast<std::size_t>(ni) + (j % 2 ? static_cast<std::size_t>(ni) - 1 - i : i);
  };
  std::vector<std::size_t> order(kept.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return rank(cells[a]) < rank(cells[b]); });
  std::vector<Segment2> sorted;
  sorted.reserve(kept.size());
  for (const std::size_t k : order) sorted.push_back(kept[k]);
  std::vector<std::vector<Vec2>> lines;
  order_lines(std::move(sorted), cursor, lines);
  return link_runs(lines, r, spacing, bead_width, link);
}

namespace {

void add_to_box(BBox2& b, const Polygon2& poly) {
  for (const auto& v : poly.outer) {
    b.min = {std::min(b.min.x, v.x), std::min(b.min.y, v.y)};
    b.max = {std::max(b.max.x, v.x), std::max(b.max.y, v.y)};
  }
}

BBox2 box_of(const Regions& regions) {
  BBox2 b{{1e300, 1e300}, {-1e300, -1e300}};
  for (const auto& poly : regions) add_to_box(b, poly);
  return b;
}

// The polygons of `regions` whose box meets `box`: clipping one island against a whole layer's
// skin cost a Clipper sweep over every island's skin per island (quadratic in the islands; 35 s
// of the dodeca_chain_loop.3mf slice), clipping against its neighbours only does not.
Regions near(const Regions& regions, const BBox2& box) {
  Regions out;
  for (const auto& poly : regions) {
    BBox2 b{{1e300, 1e300}, {-1e300, -1e300}};
    add_to_box(b, poly);
    if (b.max.x >= box.min.x && b.min.x <= box.max.x && b.max.y >= box.min.y &&
        b.min.y <= box.max.y)
      out.push_back(poly);
  }
  return out;
}

}  // namespace

void PlanarStats::add(const PlanarStats& o) {
  layers += o.layers;
  paths += o.paths;
  walls += o.walls;
  skin_lines += o.skin_lines;
  infill_lines += o.infill_lines;
  extruded_length += o.extruded_length;
  link.add(o.link);
  lattice_trails += o.lattice_trails;
  lattice_trail_bound += o.lattice_trail_bound;
  layer_seconds += o.layer_seconds;
  link_seconds += o.link_seconds;
  layer_link.insert(layer_link.end(), o.layer_link.begin(), o.layer_link.end());
}

namespace {

bool same_regions(const Regions& a, const Regions& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (a[k].outer != b[k].outer || a[k].holes != b[k].holes) return false;
  return true;
}

}  // namespace

SkinWindows::SkinWindows(std::size_t layers, int below, int above)
    : n_(static_cast<long>(layers)),
      below_(std::max(0, below)),
      above_(std::max(0, above)),
      empty_(std::make_shared<const Regions>()) {
  for (long s = 1; s <= std::max(below_, above_); s *= 2) runs_.emplace_back();
}

void SkinWindows::Level::drop_before(long a) {
  while (!at.empty() && base < a) at.pop_front(), ++base;
}

// Positions [lo, hi) of `out` (the next ones), each the intersection of first(a) and second(a)
// (first(a) itself where second is null); a position whose two inputs are the previous one's
// shares its result.
void SkinWindows::compute(Level& out, long lo, long hi, const std::function<Ptr(long)>& first,
                          const std::function<Ptr(long)>& second) {
  if (hi <= lo) return;
  const auto m = static_cast<std::size_t>(hi - lo);
  std::vector<Ptr> x(m), y(m), result(m);
  std::vector<char> repeat(m, 0);
  std::vector<std::size_t> todo;
  for (std::size_t k = 0; k < m; ++k) {
    const long a = lo + static_cast<long>(k);
    x[k] = first(a), y[k] = second(a);
    if (!y[k]) {
      result[k] = x[k];
    } else if (x[k]->empty() || y[k]->empty()) {
      result[k] = empty_;
    } else if (k > 0 ? x[k] == x[k - 1] && y[k] == y[k - 1]
                     : !out.at.empty() && x[k] == out.last_x && y[k] == out.last_y) {
      repeat[k] = 1;
    } else {
      todo.push_back(k);
    }
  }
  tbb::parallel_for(std::size_t{0}, todo.size(), [&](std::size_t t) {
    const std::size_t k = todo[t];
    result[k] = std::make_shared<const Regions>(intersection(*x[k], *y[k]));
  });
  intersections_ += todo.size();
  for (std::size_t k = 0; k < m; ++k) {
    if (repeat[k]) result[k] = k > 0 ? result[k - 1] : out.at.back();
    out.at.push_back(result[k]);
  }
  out.last_x = x.back(), out.last_y = y.back();
}

void SkinWindows::add(const std::vector<Ptr>& outlines) {
  const long m0 = static_cast<long>(added_), m1 = m0 + static_cast<long>(outlines.size());
  if (m1 > n_) throw std::logic_error("SkinWindows: more layers than the part's");
  added_ = static_cast<std::size_t>(m1);
  if (runs_.empty()) return;  // no skins
  // Equal layers (a prism's) are one: the runs over them share their results.
  Level& layers = runs_[0];
  for (const Ptr& p : outlines) {
    const Ptr prev = layers.at.empty() ? nullptr : layers.at.back();
    layers.at.push_back(prev && same_regions(*prev, *p) ? prev : p);
  }
  // The runs of 2^k layers the new layers complete: those ending at m0 .. m1 - 1.
  for (std::size_t k = 1; k < runs_.size(); ++k) {
    const long s = 1L << k, h = s / 2;
    const Level& in = runs_[k - 1];
    compute(
        runs_[k], std::max(0L, m0 - s + 1), m1 - s + 1, [&](long a) { return in[a]; },
        [&](long a) { return in[a + h]; });
  }
  // A window of w layers: the run of the largest power of two S <= w at its start, met with the
  // one ending at its end.
  auto windows = [&](Level& out, long w) {
    std::size_t k = 0;
    while ((2L << k) <= w) ++k;
    const long S = 1L << k;
    const Level& in = runs_[k];
    compute(
        out, std::max(0L, m0 - w + 1), m1 - w + 1, [&](long a) { return in[a]; },
        [&](long a) { return S == w ? nullptr : in[a + w - S]; });
  };
  if (below_ > 0) windows(under_, below_);
  if (above_ > 0 && above_ != below_) windows(over_, above_);
  // Later runs read runs starting at most 2 max(below, above) layers back.
  const long keep = m1 - 2 * std::max(below_, above_) - 1;
  for (Level& l : runs_) l.drop_before(keep);
}

SkinWindows::Ptr SkinWindows::under(std::size_t layer) const {
  if (below_ == 0) return nullptr;
  const long a = static_cast<long>(layer) - below_;
  if (a < 0) return empty_;
  if (a < under_.base || a >= under_.base + static_cast<long>(under_.at.size()))
    throw std::logic_error("SkinWindows::under: window not intersected or forgotten");
  return under_[a];
}

SkinWindows::Ptr SkinWindows::over(std::size_t layer) const {
  if (above_ == 0) return nullptr;
  const long a = static_cast<long>(layer) + 1;
  if (a + above_ > n_) return empty_;
  const Level& w = above_ == below_ ? under_ : over_;
  if (a < w.base || a >= w.base + static_cast<long>(w.at.size()))
    throw std::logic_error("SkinWindows::over: window not intersected or forgotten");
  return w[a];
}

void SkinWindows::forget_before(std::size_t layer) {
  const long l = static_cast<long>(layer);
  under_.drop_before(l - below_);
  over_.drop_before(l + 1);
}

namespace {

void check_planar_options(const PlanarOptions& o) {
  if (!(o.layer_height > 0)) throw SettingError("layer height must be > 0");
  if (!(o.bead_width > 0)) throw SettingError("bead width must be > 0");
  if (o.walls < 0 || o.walls > 100) throw SettingError("walls must be 0..100");
  if (!(o.infill_density >= 0 && o.infill_density <= 1))
    throw SettingError("infill density must be within 0..1");
  if (o.top_layers < 0 || o.bottom_layers < 0) throw SettingError("skin layers must be >= 0");
}

// The box of outlines (lattice infill's frame when none is given).
BBox2 outline_frame(const std::vector<const Regions*>& outlines) {
  BBox2 frame{{1e300, 1e300}, {-1e300, -1e300}};
  for (const Regions* r : outlines)
    for (const auto& poly : *r)
      for (const Vec2 v : poly.outer)
        frame.min = {std::min(frame.min.x, v.x), std::min(frame.min.y, v.y)},
        frame.max = {std::max(frame.max.x, v.x), std::max(frame.max.y, v.y)};
  return frame;
}

Toolpath plan_layers(const std::vector<PlanarLayerInput>& in, const PlanarOptions& o,
                     const BBox2& frame, PlanarStats* stats) {
  const std::size_t n = in.size();
  const double w = o.bead_width;
  const long B = o.bottom_layers, T = o.top_layers;
  Toolpath tp;
  tp.layers.resize(n);
  std::vector<PlanarStats> per(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    const auto t_layer = std::chrono::steady_clock::now();
    Layer& layer = tp.layers[i];
    const std::size_t g = in[i].index;
    const double z = static_cast<double>(g + 1) * o.layer_height;
    layer.z = z;
    const Regions& outline = *in[i].outline;
    if (outline.empty()) return;
    std::vector<std::vector<Regions>> walls(outline.size());
    for (std::size_t k = 0; k < walls.size(); ++k)
      if (!outline[k].outer.empty()) walls[k] = wall_regions(outline[k], o.walls, w);
    // Solid where the part has no material within bottom_layers below or top_layers above.
    Regions skin;
    if (B > 0 || T > 0) {
      Regions eroded;  // the outline offset by half a bead: the outer walls' regions
      if (o.walls > 0) {
        for (const auto& r : walls)
          if (!r.empty()) eroded.insert(eroded.end(), r.front().begin(), r.front().end());
      } else {
        eroded = offset(outline, -0.5 * w);
      }
      skin = skin_of(eroded, B > 0 ? in[i].under.get() : nullptr,
                     T > 0 ? in[i].over.get() : nullptr, w, o.simplify);
    }
    const bool odd = g % 2 == 1;
    const double infill_angle = o.infill_angle + (odd ? 90.0 : 0.0);
    const double skin_angle = 45.0 + (odd ? 90.0 : 0.0);
    const double sparse_spacing = o.infill_density > 0 ? w / o.infill_density : 0;

    // Each island's walls (inside first, the outer wall last keeps the surface clean) and fill
    // lines, linked into paths by the linking stage (slice/link.hpp).
    std::vector<IslandPieces> islands;
    islands.reserve(outline.size());
    for (std::size_t k = 0; k < outline.size(); ++k) {
      const Polygon2& poly = outline[k];
      if (poly.outer.empty()) continue;
      IslandPieces& is = islands.emplace_back();
      is.outline = poly;
      is.bead_width = w;
      const Regions island{poly};
      const std::vector<Regions>& wall_regions = walls[k];
      if (!wall_regions.empty()) is.route = wall_regions.front();
      for (auto it = wall_regions.rbegin(); it != wall_regions.rend(); ++it) {
        auto rings = rings_of(*it);
        std::erase_if(rings, [](const auto& r) { return r.size() < 3; });
        per[i].walls += rings.size();
        is.walls.push_back(std::move(rings));
      }
      // Infill region: inside the innermost wall, reaching `infill_overlap` of a bead into it.
      const double inset =
          static_cast<double>(wall_regions.size()) * w + 0.5 * w - o.infill_overlap * w;
      const Regions inner = offset(island, -inset);
      if (inner.empty()) continue;
      const Regions skin_near = skin.empty() ? Regions{} : near(skin, box_of(inner));
      const Regions solid = skin_near.empty() ? Regions{} : intersection(inner, skin_near);
      const Regions sparse = solid.empty() ? inner : difference(inner, solid);
      auto add_fill = [&](const Regions& r, double angle, double spacing, PathRole role) {
        if (r.empty() || !(spacing > 0)) return;
        IslandPieces::Fill& f = is.fills.emplace_back();
        f.role = role;
        f.region = r;
        f.spacing = spacing;
        for (const auto& seg : hatch(r, angle, spacing))
          if (std::sqrt(dist2(seg.a, seg.b)) >= o.min_path) f.lines.push_back({seg.a, seg.b});
      };
      add_fill(solid, skin_angle, w, PathRole::Skin);
      if (o.infill_pattern == InfillPattern::Rectilinear || sparse.empty() ||
          !(o.infill_density > 0)) {
        add_fill(sparse, infill_angle, sparse_spacing, PathRole::Infill);
      } else {
        InfillSpec spec;
        spec.pattern = o.infill_pattern;
        spec.density = o.infill_density;
        spec.bead_width = w;
        spec.angle = o.infill_angle;
        spec.min_length = o.min_path;
        spec.lattice = o.infill_lattice;
        spec.seed = o.infill_seed;
        spec.frame = frame;
        InfillPaths made = make_infill(sparse, spec, g, in[i].plane);
        per[i].lattice_trails += made.trails;
        per[i].lattice_trail_bound += made.trail_lower_bound;
        IslandPieces::Fill& f = is.fills.emplace_back();
        f.role = PathRole::Infill;
        f.region = sparse;
        f.spacing = made.scale > 0 ? made.scale : sparse_spacing;
        f.lines = std::move(made.open);
        f.loops = std::move(made.loops);
      }
    }
    Vec2 cursor{-1e9, -1e9};
    LinkStats& ls = per[i].link;
    const auto t_link = std::chrono::steady_clock::now();
    link_layer(islands, o.link, z, o.layer_height, g, cursor, false, layer.paths, ls);
    const auto t_end = std::chrono::steady_clock::now();
    per[i].link_seconds = std::chrono::duration<double>(t_end - t_link).count();
    per[i].layer_seconds = std::chrono::duration<double>(t_end - t_layer).count();
    for (const auto& p : layer.paths) {
      if (p.role == PathRole::Skin) ++per[i].skin_lines;
      if (p.role == PathRole::Infill) ++per[i].infill_lines;
    }
  });
  PlanarStats total;
  total.layer_link.reserve(n);
  total.layers = n;
  for (std::size_t i = 0; i < n; ++i) {
    total.walls += per[i].walls;
    total.skin_lines += per[i].skin_lines;
    total.infill_lines += per[i].infill_lines;
    total.link.add(per[i].link);
    total.layer_link.push_back(per[i].link);
    total.lattice_trails += per[i].lattice_trails;
    total.lattice_trail_bound += per[i].lattice_trail_bound;
    total.layer_seconds += per[i].layer_seconds;
    total.link_seconds += per[i].link_seconds;
    total.paths += tp.layers[i].paths.size();
    for (const auto& p : tp.layers[i].paths) total.extruded_length += p.length();
  }
  if (stats) *stats = total;
  tp.source = "trellis planar slicer";
  return tp;
}

}  // namespace

Toolpath plan_planar(const std::vector<LayerOutline>& layers, const PlanarOptions& o,
                     PlanarStats* stats) {
  check_planar_options(o);
  const std::size_t n = layers.size();
  std::vector<SkinWindows::Ptr> outline(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    outline[i] = std::make_shared<const Regions>(
        o.simplify > 0 ? simplify(layers[i].regions, o.simplify) : layers[i].regions);
  });
  // Lattice infill's frame: the part's box, so its cells stack.
  BBox2 frame = o.infill_frame;
  if (!(frame.width() > 0) && o.infill_pattern == InfillPattern::Lattice) {
    std::vector<const Regions*> all;
    for (const auto& r : outline) all.push_back(r.get());
    frame = outline_frame(all);
  }
  // The layers planned here, [p0, p1), and the layers their skins read, [lo, hi).
  const std::size_t first = o.first_index, last = first + n;
  const long p0 = static_cast<long>(std::clamp(o.plan_begin, first, last) - first);
  const long p1 = std::max(p0, static_cast<long>(std::clamp(o.plan_end, first, last) - first));
  const long lo = std::max(0L, p0 - o.bottom_layers);
  const long hi = std::max(lo, std::min(static_cast<long>(n), p1 + o.top_layers));
  SkinWindows windows(static_cast<std::size_t>(hi - lo), o.bottom_layers, o.top_layers);
  windows.add(std::vector<SkinWindows::Ptr>(outline.begin() + lo, outline.begin() + hi));
  std::vector<PlanarLayerInput> in;
  in.reserve(static_cast<std::size_t>(p1 - p0));
  for (long i = p0; i < p1; ++i) {
    const auto local = static_cast<std::size_t>(i - lo);
    in.push_back({first + static_cast<std::size_t>(i), layers[static_cast<std::size_t>(i)].z,
                  outline[static_cast<std::size_t>(i)], windows.under(local), windows.over(local)});
  }
  return plan_layers(in, o, frame, stats);
}

Toolpath plan_planar_layers(const std::vector<PlanarLayerInput>& layers, const PlanarOptions& o,
                            PlanarStats* stats) {
  check_planar_options(o);
  BBox2 frame = o.infill_frame;
  if (!(frame.width() > 0) && o.infill_pattern == InfillPattern::Lattice) {
    std::vector<const Regions*> all;
    for (const auto& l : layers) all.push_back(l.outline.get());
    frame = outline_frame(all);
  }
  return plan_layers(layers, o, frame, stats);
}

}  // namespace trellis
