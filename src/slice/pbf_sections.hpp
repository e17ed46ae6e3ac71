// The plane functions a PBF layer is marched on, at height z: the part's section S, the joint
// (or, inverted, the thin-wall) measure and the mid-surface φ, each sampling through the
// thread's context (its evaluators and the caches of pbf_cache.hpp) in batches and on grids.
#pragma once
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <optional>
#include <vector>

#include "pbf_cache.hpp"
#include "trellis/core/vec.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/slice/pbf.hpp"

namespace trellis::pbf_detail {

inline constexpr double kDeg = std::numbers::pi / 180;

// A plane function's sampling buffers, kept by the thread's context from layer to layer (grown
// once instead of on every layer: fewer allocations and page faults).
struct SampleBuffers {
  std::vector<std::size_t> miss, keys, need;
  std::vector<Vec3> pts, grads;
  std::vector<double> part, vals, xs, ys;
};

// Per-thread evaluators of the part, the mid-surface, the solids and c.
struct Ctx {
  Evaluator part, phi, sheet;  // sheet: Φ alone (no envelope), for thickness measurements
  std::optional<Evaluator> solids, c, envelope;
  LayerGrid grid;
  BoundCache bounds;                         // the part's, over this layer's blocks
  std::vector<EdgeCrossing> edge_crossings;  // the section march's, by grid edge
  // For the layer's section, joint-measure, thin-measure and mid-surface functions.
  SampleBuffers part_buffers, joint_buffers, thin_buffers, mid_buffers;
  // The sheet's period along x and y when it repeats across the plane (0: it does not), and
  // the boxes the part is clipped to.
  Vec2 period;
  const std::vector<BBox3>& clip;
  Ctx(const Field& p, const PbfDesign& d, const Field& c_field, Vec2 sheet_period)
      : part(p),
        phi(d.phi),
        sheet(trellis::sheet(d.phi, d.c, d.thickness)),
        period(sheet_period),
        clip(d.clip) {
    if (!d.solids.empty()) solids.emplace(d.solids);
    if (!c_field.empty()) c.emplace(c_field);
    if (!d.envelope.empty() && period.x > 0) envelope.emplace(d.envelope);
  }
  // Whether the part is the repeating sheet alone over the rectangle [lo, hi] at height z:
  // strictly inside the root boxes and the envelope (its bound below 0), outside the solids
  // (above 0). The part's sign, level set and bounds there are the sheet's (the envelope and
  // the solids change the part's value only where their own sign decides it).
  bool periodic(Vec2 lo, Vec2 hi, double z) {
    if (!(period.x > 0 && period.y > 0)) return false;
    for (const BBox3& b : clip)
      if (!(lo.x > b.min.x && hi.x < b.max.x && lo.y > b.min.y && hi.y < b.max.y && z > b.min.z &&
            z < b.max.z))
        return false;
    const BBox3 box = plane_box(lo, hi, z);
    if (envelope && !(envelope->bound(box).hi < 0)) return false;
    if (solids && !(solids->bound(box).lo > 0)) return false;
    return true;
  }
};

// f at the block of points p (w a row, row by row) of a plane z, as a grid: the same values as
// f.values at those points.
inline void evaluate_grid(Evaluator& f, const Vec2* p, std::size_t w, std::size_t rows, double z,
                          std::vector<double>& xs, std::vector<double>& ys, double* out) {
  xs.resize(w);
  ys.resize(rows);
  for (std::size_t i = 0; i < w; ++i) xs[i] = p[i].x;
  for (std::size_t j = 0; j < rows; ++j) ys[j] = p[j * w].y;
  f.values_grid(xs.data(), w, ys.data(), rows, z, out);
}

// What the plane functions below share: the thread's context, the plane's height, and the
// answers that come from the context alone — the sheet's period, whether the part is the
// repeating sheet alone over a rectangle, bounds of the part prefetched through its cache.
class CtxSection : public PlaneFunction {
 public:
  CtxSection(Ctx& ctx, double z) : ctx_(ctx), z_(z) {}
  void prefetch_bounds(const Vec2* lo, const Vec2* hi, std::size_t n) override {
    ctx_.bounds.prefetch(lo, hi, n);
  }
  Vec2 period() const override { return ctx_.period; }
  bool periodic(Vec2 lo, Vec2 hi) override { return ctx_.periodic(lo, hi, z_); }

 protected:
  Ctx& ctx_;
  double z_;
};

// The joint region's field at height z: negative where the sheet is wider than a thin wall
// (thin_multiple·D), or shallower than the minimum inclination, or inside a solid part; positive
// outside the part. Only its sign matters (crossings are refined on it).
class JointSection : public CtxSection {
 public:
  // invert: the thin-wall region instead (inside the part, not a joint).
  JointSection(Ctx& ctx, const PbfDesign& d, const PbfOptions& o, double c_const, double z,
               bool invert = false)
      : CtxSection(ctx, z),
        d_(d),
        o_(o),
        c_(c_const),
        cos_min_(std::cos(o.min_inclination * kDeg)),
        invert_(invert),
        b_(invert ? ctx.thin_buffers : ctx.joint_buffers) {}
  // Part values are read from and written to the grid's nodes; the measure too when `cache` (the
  // layer's one JointSection that owns the grid's joint slots).
  void use_grid(LayerGrid* g, bool cache = true) {
    grid_ = g;
    cache_ = cache;
  }
  double at(Vec2 q) {
    const std::size_t k = grid_ ? grid_->node(q) : LayerGrid::npos;
    if (k != LayerGrid::npos && cache_ && grid_->has_joint(k)) return grid_->joint(k);
    const double v = compute(q, k);
    if (k != LayerGrid::npos && cache_) grid_->set_joint(k, v);
    return v;
  }
  double compute(Vec2 q, std::size_t k) {
    double D;
    if (k != LayerGrid::npos && grid_->has_part(k)) {
      D = grid_->part(k);
    } else {
      D = ctx_.part.value({q.x, q.y, z_});
      if (k != LayerGrid::npos) grid_->set_part(k, D);
    }
    return finish(q, D);
  }
  // The measure at q given the part's value D there (and φ's gradient there when D < 0).
  double finish(Vec2 q, double D) {
    if (D >= 0) return D;
    return finish(q, D, ctx_.phi.gradient({q.x, q.y, z_}));  // analytic for TPMS
  }
  double finish(Vec2 q, double D, Vec3 grad) {
    if (D >= 0) return D;
    const Vec3 p{q.x, q.y, z_};
    const double gx = grad.x, gy = grad.y, gz = grad.z;
    const double gxy = std::sqrt(gx * gx + gy * gy), g = std::sqrt(gxy * gxy + gz * gz);
    // Horizontal width of the sheet: 2c / |∇xy φ| (or t·|∇φ| / |∇xy φ| for uniform thickness).
    const double full =
        d_.thickness > 0 ? d_.thickness * g : 2 * std::abs(ctx_.c ? ctx_.c->value(p) : c_);
    double m;
    if (o_.split == PbfSplit::Inclination) {
      // The sheet of the c interpolated by inclination: > 0 inside it (|φ| below that c).
      const double incl = g > 0 ? std::acos(std::min(1.0, std::abs(gz) / g)) / kDeg : 0;
      m = pbf_split_c(0.5 * full, incl, o_.min_inclination) - std::abs(ctx_.phi.value(p));
    } else {
      m = o_.thin_multiple * o_.melt_pool * gxy - full;         // < 0: wider than a thin wall
      if (g > 0) m = std::min(m, cos_min_ - std::abs(gz) / g);  // < 0: shallow
    }
    if (ctx_.solids) m = std::min(m, ctx_.solids->value(p));
    return std::max(D, invert_ ? -m : m);
  }
  void sample(const Vec2* p, double* out, std::size_t n) override {
    run(p, out, n, [&](std::size_t i) { return grid_ ? grid_->node(p[i]) : LayerGrid::npos; });
  }
  void sample_grid(Vec2 origin, double step, std::size_t w, std::size_t rows, const Vec2* p,
                   double* out) override {
    const auto b = grid_ ? grid_->block(origin, step, w, rows) : std::nullopt;
    if (!b) {
      sample(p, out, w * rows);
      return;
    }
    if (grid_rows(p, out, w, rows, *b)) return;
    run(p, out, w * rows, *b);
  }
  // The block as a grid: the part's values at every node, φ's gradient at every node (when φ
  // has a grid path: a TPMS), the measure where the part is negative; false when φ has none.
  bool grid_rows(const Vec2* p, double* out, std::size_t w, std::size_t rows,
                 LayerGrid::BlockIndex key) {
    const std::size_t n = w * rows;
    b_.part.resize(n);
    // The section march has usually sampled every node of the block (its blocks cover those
    // where the part changes sign): its values are read, else the block is evaluated whole.
    bool cached = true;
    {
      LayerGrid::BlockIndex probe = key;
      for (std::size_t i = 0; i < n && cached; ++i) {
        const std::size_t k = probe(i);
        cached = grid_->has_part(k);
        if (cached) b_.part[i] = grid_->part(k);
      }
    }
    if (cached) {
      b_.xs.resize(w);
      b_.ys.resize(rows);
      for (std::size_t i = 0; i < w; ++i) b_.xs[i] = p[i].x;
      for (std::size_t j = 0; j < rows; ++j) b_.ys[j] = p[j * w].y;
    } else {
      evaluate_grid(ctx_.part, p, w, rows, z_, b_.xs, b_.ys, b_.part.data());
    }
    bool inside = false;
    for (std::size_t i = 0; i < n; ++i) inside |= b_.part[i] < 0;
    if (inside) {
      b_.grads.resize(n);
      if (!ctx_.phi.gradients_grid(b_.xs.data(), w, b_.ys.data(), rows, z_, b_.grads.data()))
        return false;
    }
    const bool cache_joint = cache_;
    for (std::size_t i = 0; i < n; ++i) {
      const double D = b_.part[i];
      out[i] = D < 0 ? finish(p[i], D, b_.grads[i]) : D;
      const std::size_t k = key(i);
      grid_->set_part(k, D);
      if (cache_joint) grid_->set_joint(k, out[i]);
    }
    return true;
  }
  // Cached nodes are read; the part is evaluated in one batch at the rest (most of them lie
  // outside the sheet, where the part's value is the answer). key(i): point i's node or npos.
  template <class Key>
  void run(const Vec2* p, double* out, std::size_t n, Key key) {
    // Pass 1: cached joint values, and cached part values outside the part (the answer there)
    // are settled at once; the rest is listed (b_.miss: point, b_.keys: its node or npos).
    b_.miss.clear();
    b_.keys.clear();
    b_.part.clear();
    b_.need.clear();
    b_.pts.clear();
    const bool cache_joint = grid_ && cache_;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = key(i);
      if (k != LayerGrid::npos) {
        if (cache_joint && grid_->has_joint(k)) {
          out[i] = grid_->joint(k);
          continue;
        }
        if (grid_->has_part(k)) {
          const double D = grid_->part(k);
          if (D >= 0) {
            out[i] = D;
            if (cache_joint) grid_->set_joint(k, D);
            continue;
          }
          b_.miss.push_back(i);
          b_.keys.push_back(k);
          b_.part.push_back(D);
          continue;
        }
      }
      b_.need.push_back(b_.miss.size());
      b_.miss.push_back(i);
      b_.keys.push_back(k);
      b_.part.push_back(0);
      b_.pts.push_back({p[i].x, p[i].y, z_});
    }
    // Pass 2: the part where it was not cached, in one batch.
    b_.vals.resize(b_.pts.size());
    if (!b_.pts.empty()) ctx_.part.values(b_.pts.data(), b_.vals.data(), b_.pts.size());
    for (std::size_t j = 0; j < b_.need.size(); ++j) {
      const std::size_t m = b_.need[j];
      b_.part[m] = b_.vals[j];
      if (b_.keys[m] != LayerGrid::npos) grid_->set_part(b_.keys[m], b_.vals[j]);
    }
    // Pass 3: φ's gradient in one batch at the points inside the part; the measure.
    b_.pts.clear();
    for (std::size_t m = 0; m < b_.miss.size(); ++m)
      if (b_.part[m] < 0) b_.pts.push_back({p[b_.miss[m]].x, p[b_.miss[m]].y, z_});
    b_.grads.resize(b_.pts.size());
    if (!b_.pts.empty()) ctx_.phi.gradients(b_.pts.data(), b_.grads.data(), b_.pts.size());
    for (std::size_t m = 0, g = 0; m < b_.miss.size(); ++m) {
      const double v =
          b_.part[m] < 0 ? finish(p[b_.miss[m]], b_.part[m], b_.grads[g++]) : b_.part[m];
      out[b_.miss[m]] = v;
      if (b_.keys[m] != LayerGrid::npos && cache_joint) grid_->set_joint(b_.keys[m], v);
    }
  }
  // Crossings where the part decides the measure are the section march's (on the grid's finer
  // nodes, refined at least as tightly as this march's): taken over where the measure's other
  // terms are confirmed on the part's side there. `stride`: this march's cell in grid cells
  // (its grid starts at the grid's origin); 0: off (the section march stored none).
  void use_section_crossings(std::size_t stride) { stride_ = stride; }
  double known_crossing(std::size_t i, std::size_t j, bool vertical, double fa,
                        double fb) override {
    if (stride_ == 0) return -1;
    const std::size_t row = grid_->row(), unit = vertical ? row : 1, n = stride_;
    const std::size_t ka = j * n * row + i * n, kb = ka + n * unit;
    if (kb >= grid_->size() || (!vertical && i * n + n >= row)) return -1;
    if (!grid_->has_part(ka) || !grid_->has_part(kb) || grid_->part(ka) != fa ||
        grid_->part(kb) != fb)
      return -1;  // the measure is not the part's value at an end
    // The one finer edge along the edge where the part changes sign, and the section's
    // crossing there.
    std::size_t at = n;
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t q = ka + k * unit;
      if (!grid_->has_part(q + unit)) return -1;
      if ((grid_->part(q) < 0) != (grid_->part(q + unit) < 0)) {
        if (at != n) return -1;
        at = k;
      }
    }
    if (at == n) return -1;
    const double t = grid_->crossing(ka + at * unit, vertical);
    if (!(t > 0 && t < 1)) return -1;
    return (static_cast<double>(at) + t) / static_cast<double>(n);
  }
  // The part is ~0 at the points (its crossings): the measure there is its other terms,
  // which must be on the part's side of the level (negative) for the crossing to be the part's.
  void confirm_crossings(const Vec2* p, std::size_t n, unsigned char* ok) override {
    b_.pts.resize(n);
    b_.grads.resize(n);
    for (std::size_t k = 0; k < n; ++k) b_.pts[k] = {p[k].x, p[k].y, z_};
    ctx_.phi.gradients(b_.pts.data(), b_.grads.data(), n);
    for (std::size_t k = 0; k < n; ++k) {
      const double v = finish(p[k], -std::numeric_limits<double>::infinity(), b_.grads[k]);
      ok[k] = std::isfinite(v) && v < 0;
    }
  }
  Interval bound(Vec2 lo, Vec2 hi) override {
    return {ctx_.bounds.get(ctx_.part, lo, hi).lo, std::numeric_limits<double>::infinity()};
  }
  // The measure is the part's value or terms of φ's gradient and c: it repeats where the part
  // is the sheet alone (CtxSection's period and periodic).

 private:
  const PbfDesign& d_;
  const PbfOptions& o_;
  double c_, cos_min_;
  bool invert_, cache_ = false;
  std::size_t stride_ = 0;
  LayerGrid* grid_ = nullptr;
  SampleBuffers& b_;
};

class PartSection : public CtxSection {
 public:
  PartSection(Ctx& ctx, LayerGrid& grid, double z) : CtxSection(ctx, z), grid_(grid) {}
  void sample(const Vec2* p, double* out, std::size_t n) override {
    run(p, out, n, [&](std::size_t i) { return grid_.node(p[i]); });
  }
  void sample_grid(Vec2 origin, double step, std::size_t w, std::size_t rows, const Vec2* p,
                   double* out) override {
    const auto b = grid_.block(origin, step, w, rows);
    if (!b) {
      sample(p, out, w * rows);
      return;
    }
    // The whole block is evaluated as a grid (cheaper than reading the nodes a neighbouring
    // block cached and evaluating the rest point by point; the same values).
    LayerGrid::BlockIndex key = *b;
    evaluate_grid(ctx_.part, p, w, rows, z_, b_.xs, b_.ys, out);
    for (std::size_t i = 0; i < w * rows; ++i) grid_.set_part(key(i), out[i]);
  }
  // Cached nodes are read; the rest evaluated in one batch. key(i): point i's node or npos.
  template <class Key>
  void run(const Vec2* p, double* out, std::size_t n, Key key) {
    b_.miss.clear();
    b_.pts.clear();
    b_.keys.clear();
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = key(i);
      if (k != LayerGrid::npos && grid_.has_part(k)) {
        out[i] = grid_.part(k);
        continue;
      }
      b_.miss.push_back(i);
      b_.keys.push_back(k);
      b_.pts.push_back({p[i].x, p[i].y, z_});
    }
    if (b_.miss.empty()) return;
    b_.vals.resize(b_.miss.size());
    ctx_.part.values(b_.pts.data(), b_.vals.data(), b_.pts.size());
    for (std::size_t m = 0; m < b_.miss.size(); ++m) {
      out[b_.miss[m]] = b_.vals[m];
      if (b_.keys[m] != LayerGrid::npos) grid_.set_part(b_.keys[m], b_.vals[m]);
    }
  }
  // Blocks narrower than `shared` on both sides are bounded without the cache: the coarser
  // thin-wall, joint and mid-curve marches never ask for them, so caching them only filled the
  // table (they were most of its entries).
  void share_bounds_from(double shared) { shared_ = shared; }
  Interval bound(Vec2 lo, Vec2 hi) override {
    if (hi.x - lo.x < shared_ && hi.y - lo.y < shared_)
      return ctx_.part.bound(plane_box(lo, hi, z_));
    return ctx_.bounds.get(ctx_.part, lo, hi);
  }
  void prefetch_bounds(const Vec2* lo, const Vec2* hi, std::size_t n) override {
    if (n > 0 && hi[0].x - lo[0].x < shared_ && hi[0].y - lo[0].y < shared_) return;
    CtxSection::prefetch_bounds(lo, hi, n);
  }

 private:
  LayerGrid& grid_;
  double shared_ = 0;
  SampleBuffers& b_ = ctx_.part_buffers;
};

// φ at z, with blocks the part does not reach skipped (their mid-curve is clipped away anyway).
class MidSection : public CtxSection {
 public:
  MidSection(Ctx& ctx, double z) : CtxSection(ctx, z) {}
  void sample(const Vec2* p, double* out, std::size_t n) override {
    b_.pts.resize(n);
    for (std::size_t i = 0; i < n; ++i) b_.pts[i] = {p[i].x, p[i].y, z_};
    ctx_.phi.values(b_.pts.data(), out, n);
  }
  void sample_grid(Vec2, double, std::size_t w, std::size_t rows, const Vec2* p,
                   double* out) override {
    evaluate_grid(ctx_.phi, p, w, rows, z_, b_.xs, b_.ys, out);
  }
  Interval bound(Vec2 lo, Vec2 hi) override {
    if (ctx_.bounds.get(ctx_.part, lo, hi).lo >= 0)
      return {1, std::numeric_limits<double>::infinity()};
    return ctx_.phi.bound(plane_box(lo, hi, z_));
  }
  // φ repeats everywhere; the blocks skipped (outside the part) repeat where the part is the
  // sheet alone (CtxSection's period and periodic).

 private:
  SampleBuffers& b_ = ctx_.mid_buffers;
};

}  // namespace trellis::pbf_detail
