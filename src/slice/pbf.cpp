#include "trellis/slice/pbf.hpp"

#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <numbers>
#include <numeric>
#include <optional>
#include <utility>

#include "pbf_chords.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/scan_strategy.hpp"
#include "trellis/slice/slice.hpp"

namespace trellis {

Field PbfDesign::part() const {
  if (phi.empty()) throw GeometryError("PBF design needs a mid-surface field");
  Field f = sheet(phi, c, thickness);
  if (!envelope.empty()) f = intersect({f, envelope});
  for (const BBox3& b : clip) f = clip_box(f, b.min, b.max);
  if (!solids.empty()) f = unite({f, solids});
  return f;
}

double pbf_split_c(double c, double inclination_deg, double min_inclination_deg) {
  const double w = std::clamp((inclination_deg - min_inclination_deg) / kSplitBand, 0.0, 1.0);
  return w * c;
}

double equivalent_length(double length, double melt_pool) {
  return length + 0.25 * std::numbers::pi * melt_pool;
}

namespace {

constexpr double kDeg = std::numbers::pi / 180;

// The flat box [lo, hi] at height z (a layer's block, for 3D bounds).
BBox3 plane_box(Vec2 lo, Vec2 hi, double z) {
  BBox3 b;
  b.add({lo.x, lo.y, z});
  b.add({hi.x, hi.y, z});
  return b;
}

class LayerGrid {
 public:
  // Reused across layers by one thread: entries are valid when their stamp is the current one.
  void reset(Vec2 lo, double h, std::size_t nx, std::size_t ny) {
    lo_ = lo;
    h_ = h;
    inv_ = 1.0 / h;
    nx_ = nx + 1;
    const std::size_t n = (nx + 1) * (ny + 1);
    if (nodes_.size() != n) nodes_.assign(n, Node{});
    if (++gen_ == 0) {  // stamps wrapped: forget everything
      std::fill(nodes_.begin(), nodes_.end(), Node{});
      gen_ = 1;
    }
  }
  // Index of p if it is a grid node, else npos.
  std::size_t node(Vec2 p) const {
    const double fi = (p.x - lo_.x) * inv_, fj = (p.y - lo_.y) * inv_;
    const double ri = std::floor(fi + 0.5), rj = std::floor(fj + 0.5);
    if (std::abs(fi - ri) > 1e-7 || std::abs(fj - rj) > 1e-7 || ri < 0 || rj < 0) return npos;
    const auto i = static_cast<std::size_t>(ri), j = static_cast<std::size_t>(rj);
    if (i >= nx_ || j * nx_ + i >= nodes_.size()) return npos;
    return j * nx_ + i;
  }
  static constexpr std::size_t npos = static_cast<std::size_t>(-1);
  // Node index of point i of a block (row by row, w a row): k0 + (j·row + i)·stride. Called with
  // i = 0, 1, 2, … it steps along without dividing.
  struct BlockIndex {
    std::size_t k0, stride, row, w;
    std::size_t next_i = 0, col = 0, base = 0;  // the position of point next_i
    std::size_t operator()(std::size_t i) {
      if (i != next_i) {
        col = i % w;
        base = (i / w) * row;
      }
      const std::size_t k = k0 + (base + col) * stride;
      next_i = i + 1;
      if (++col == w) col = 0, base += row;
      return k;
    }
  };
  // The block origin + (i, j)·step, i < w, j < rows, if all its points are nodes.
  std::optional<BlockIndex> block(Vec2 origin, double step, std::size_t w, std::size_t rows) const {
    const std::size_t k = node(origin);
    if (k == npos || w == 0 || rows == 0) return std::nullopt;
    const double r = step * inv_, c = std::floor(r + 0.5);
    if (c < 1 || std::abs(r - c) > 1e-9) return std::nullopt;
    const auto stride = static_cast<std::size_t>(c);
    const std::size_t i0 = k % nx_, j0 = k / nx_;
    if (i0 + (w - 1) * stride >= nx_ || j0 + (rows - 1) * stride >= nodes_.size() / nx_)
      return std::nullopt;
    return BlockIndex{k, stride, nx_, w, 0, 0, 0};
  }
  bool has_part(std::size_t k) const { return nodes_[k].dstamp == gen_; }
  bool has_joint(std::size_t k) const { return nodes_[k].jstamp == gen_; }
  double part(std::size_t k) const { return nodes_[k].d; }
  double joint(std::size_t k) const { return nodes_[k].j; }
  void set_part(std::size_t k, double v) {
    nodes_[k].d = v;
    nodes_[k].dstamp = gen_;
  }
  // The section march's crossings (on this grid's edges), replacing the layer's previous ones:
  // an open-addressing table by node, a quarter full at most (a full-grid array would add 12
  // bytes a node to every thread's memory for the few nodes on the section's outline).
  void set_crossings(const std::vector<EdgeCrossing>& c) {
    std::size_t cap = 1024;
    while (cap < 4 * c.size()) cap *= 2;
    if (cross_.size() < cap) cross_.resize(cap);
    cmask_ = cap - 1;
    if (++cgen_ == 0) {  // stamps wrapped: forget everything
      std::fill(cross_.begin(), cross_.end(), Cross{});
      cgen_ = 1;
    }
    for (const EdgeCrossing& e : c) {
      const std::uint64_t k = e.j * nx_ + e.i;
      std::size_t i = cslot(k);
      while (cross_[i].gen == cgen_ && cross_[i].node != k) i = (i + 1) & cmask_;
      Cross& x = cross_[i];
      if (x.gen != cgen_) x = {k, cgen_, -1, -1};
      (e.vertical ? x.tv : x.th) = static_cast<float>(e.t);
    }
  }
  // The section's crossing on the edge from node k to its +x (vertical: +y) neighbour, as the
  // parameter along it; −1: none.
  double crossing(std::size_t k, bool vertical) const {
    if (cross_.empty()) return -1;
    for (std::size_t i = cslot(k); cross_[i].gen == cgen_; i = (i + 1) & cmask_)
      if (cross_[i].node == k) return vertical ? cross_[i].tv : cross_[i].th;
    return -1;
  }
  std::size_t row() const { return nx_; }
  std::size_t size() const { return nodes_.size(); }
  double step() const { return h_; }
  void set_joint(std::size_t k, double v) {
    nodes_[k].j = v;
    nodes_[k].jstamp = gen_;
  }

 private:
  Vec2 lo_;
  double h_ = 1, inv_ = 1;
  std::size_t nx_ = 0;
  std::uint32_t gen_ = 0;
  // A node's part and joint values with the layer stamps that make them valid (one cache line
  // for all four).
  struct Node {
    double d = 0, j = 0;
    std::uint32_t dstamp = 0, jstamp = 0;
  };
  std::vector<Node> nodes_;
  struct Cross {
    std::uint64_t node = 0;
    std::uint32_t gen = 0;  // the set_crossings call it belongs to (0: none)
    float th = -1, tv = -1;
  };
  std::size_t cslot(std::uint64_t k) const {
    return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> 40) & cmask_;
  }
  std::vector<Cross> cross_;
  std::size_t cmask_ = 0;
  std::uint32_t cgen_ = 0;
};

// The part's bounds over the blocks of a layer: the section, joint and mid-curve marches ask
// for the same blocks (about 24,000 asks a layer, half of them repeats, for the shipped example),
// so each is computed once. Open addressing on the block's corners, exact comparison; valid for
// the layer's stamp. The probes walk a compact array of 4-byte tags (the layer's 16-bit stamp
// and 16 bits of the hash, 256 KB for the largest layers: it stays in the core's cache) and
// read a slot's corners and bound only when its tag matches; a table of whole slots (56 bytes
// each) missed the cache on most probes.
class BoundCache {
 public:
  void reset(double z) {
    z_ = z;
    size_ = 0;
    if (++gen_ == 0x10000) {  // stamps wrapped: forget everything
      std::fill(tags_.begin(), tags_.end(), 0u);
      gen_ = 1;
    }
  }
  // Starts loading the tags of these blocks (their probes would each wait for memory).
  void prefetch(const Vec2* lo, const Vec2* hi, std::size_t n) const {
    for (std::size_t k = 0; k < n; ++k) __builtin_prefetch(&tags_[slot(hash(lo[k], hi[k]))]);
  }
  Interval get(Evaluator& part, Vec2 lo, Vec2 hi) {
    const std::uint64_t h = hash(lo, hi);
    const std::uint32_t tag = gen_ << 16 | static_cast<std::uint32_t>(h & 0xFFFF);
    std::size_t i = slot(h);
    for (; live(i); i = (i + 1) & (tags_.size() - 1)) {
      if (tags_[i] != tag) continue;
      const Slot& t = slots_[i];
      if (t.lo.x == lo.x && t.lo.y == lo.y && t.hi.x == hi.x && t.hi.y == hi.y) return t.v;
    }
    const Interval v = part.bound(plane_box(lo, hi, z_));
    if (4 * (size_ + 1) > tags_.size()) {  // kept a quarter full at most (short probes)
      grow();
      i = free_slot(h);
    }
    tags_[i] = tag;
    slots_[i] = {lo, hi, v};
    ++size_;
    return v;
  }

 private:
  struct Slot {
    Vec2 lo, hi;
    Interval v;
  };
  static std::uint64_t bits(double v) {
    std::uint64_t u;
    std::memcpy(&u, &v, sizeof u);
    return u;
  }
  static std::uint64_t hash(Vec2 lo, Vec2 hi) {
    std::uint64_t h = bits(lo.x);
    for (const double v : {lo.y, hi.x, hi.y}) h = (h ^ (h >> 31)) * 0x9E3779B97F4A7C15ull + bits(v);
    return (h ^ (h >> 29)) * 0xBF58476D1CE4E5B9ull;
  }
  // The table position from the hash's top bits (the tag holds its low 16).
  std::size_t slot(std::uint64_t h) const {
    return static_cast<std::size_t>(h >> (64 - log2_slots_));
  }
  bool live(std::size_t i) const { return (tags_[i] >> 16) == gen_; }
  std::size_t free_slot(std::uint64_t h) const {
    std::size_t i = slot(h);
    while (live(i)) i = (i + 1) & (tags_.size() - 1);
    return i;
  }
  // Twice the slots, this layer's entries moved over (the size follows the largest layer).
  void grow() {
    std::vector<std::uint32_t> old_tags =
        std::exchange(tags_, std::vector<std::uint32_t>(std::size_t{2} << log2_slots_, 0u));
    std::vector<Slot> old = std::exchange(slots_, std::vector<Slot>(std::size_t{2} << log2_slots_));
    ++log2_slots_;
    for (std::size_t k = 0; k < old.size(); ++k) {
      if ((old_tags[k] >> 16) != gen_) continue;
      const std::size_t i = free_slot(hash(old[k].lo, old[k].hi));
      tags_[i] = old_tags[k];
      slots_[i] = old[k];
    }
  }
  int log2_slots_ = 10;
  std::vector<std::uint32_t> tags_ = std::vector<std::uint32_t>(std::size_t{1} << 10, 0u);
  std::vector<Slot> slots_ = std::vector<Slot>(std::size_t{1} << 10);
  std::uint32_t gen_ = 0;  // the layer's stamp, 1 … 0xFFFF (0: no tag is live)
  std::size_t size_ = 0;
  double z_ = 0;
};

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
void evaluate_grid(Evaluator& f, const Vec2* p, std::size_t w, std::size_t rows, double z,
                   std::vector<double>& xs, std::vector<double>& ys, double* out) {
  xs.resize(w);
  ys.resize(rows);
  for (std::size_t i = 0; i < w; ++i) xs[i] = p[i].x;
  for (std::size_t j = 0; j < rows; ++j) ys[j] = p[j * w].y;
  f.values_grid(xs.data(), w, ys.data(), rows, z, out);
}

// Grid-node values of the part and of the joint measure, shared by the S and J marches of a
// layer (both sample the same nodes).

// The joint region's field at height z: negative where the sheet is wider than a thin wall
// (thin_multiple·D), or shallower than the minimum inclination, or inside a solid part; positive
// outside the part. Only its sign matters (crossings are refined on it).
class JointSection : public PlaneFunction {
 public:
  // invert: the thin-wall region instead (inside the part, not a joint).
  JointSection(Ctx& ctx, const PbfDesign& d, const PbfOptions& o, double c_const, double z,
               bool invert = false)
      : ctx_(ctx),
        d_(d),
        o_(o),
        c_(c_const),
        z_(z),
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
  void prefetch_bounds(const Vec2* lo, const Vec2* hi, std::size_t n) override {
    ctx_.bounds.prefetch(lo, hi, n);
  }
  // The measure is the part's value or terms of φ's gradient and c: it repeats where the part
  // is the sheet alone.
  Vec2 period() const override { return ctx_.period; }
  bool periodic(Vec2 lo, Vec2 hi) override { return ctx_.periodic(lo, hi, z_); }

 private:
  Ctx& ctx_;
  const PbfDesign& d_;
  const PbfOptions& o_;
  double c_, z_, cos_min_;
  bool invert_, cache_ = false;
  std::size_t stride_ = 0;
  LayerGrid* grid_ = nullptr;
  SampleBuffers& b_;
};

class PartSection : public PlaneFunction {
 public:
  PartSection(Ctx& ctx, LayerGrid& grid, double z) : ctx_(ctx), grid_(grid), z_(z) {}
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
    ctx_.bounds.prefetch(lo, hi, n);
  }
  Vec2 period() const override { return ctx_.period; }
  bool periodic(Vec2 lo, Vec2 hi) override { return ctx_.periodic(lo, hi, z_); }

 private:
  Ctx& ctx_;
  LayerGrid& grid_;
  double z_, shared_ = 0;
  SampleBuffers& b_ = ctx_.part_buffers;
};

// φ at z, with blocks the part does not reach skipped (their mid-curve is clipped away anyway).
class MidSection : public PlaneFunction {
 public:
  MidSection(Ctx& ctx, double z) : ctx_(ctx), z_(z) {}
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
  void prefetch_bounds(const Vec2* lo, const Vec2* hi, std::size_t n) override {
    ctx_.bounds.prefetch(lo, hi, n);
  }
  // φ repeats everywhere; the blocks skipped (outside the part) repeat where the part is the
  // sheet alone.
  Vec2 period() const override { return ctx_.period; }
  bool periodic(Vec2 lo, Vec2 hi) override { return ctx_.periodic(lo, hi, z_); }

 private:
  Ctx& ctx_;
  double z_;
  SampleBuffers& b_ = ctx_.mid_buffers;
};

// Bisection of many brackets [lo, hi] at once: each round samples the middle of every bracket
// still wider than tol in one batch. sample(active, middles, values) fills values for the
// listed brackets; low(value) tells whether the middle is on lo's side. At most max_rounds.
struct Bracket {
  double lo, hi;
};
template <class Sample, class Low>
void bisect_together(std::vector<Bracket>& br, double tol, int max_rounds, Sample sample, Low low) {
  std::vector<std::size_t> active;
  for (std::size_t i = 0; i < br.size(); ++i)
    if (br[i].hi - br[i].lo > tol) active.push_back(i);
  std::vector<double> mid, val;
  for (int round = 0; round < max_rounds && !active.empty(); ++round) {
    mid.resize(active.size());
    val.resize(active.size());
    for (std::size_t k = 0; k < active.size(); ++k)
      mid[k] = 0.5 * (br[active[k]].lo + br[active[k]].hi);
    sample(active, mid, val);
    std::size_t keep = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      Bracket& b = br[active[k]];
      (low(val[k]) ? b.lo : b.hi) = mid[k];
      if (b.hi - b.lo > tol) active[keep++] = active[k];
    }
    active.resize(keep);
  }
}

// A hatch vector's end on the joints' outline, to be refined on the joint field along the line
// (dir points into the vector).
struct HatchEnd {
  Vec2 p, dir;
  double half_length;
};

// Refines hatch ends, all of a layer together: the root near p, inside towards +dir, within a
// bracket that never reaches past the vector's middle (thin sheets) and that is shrunk until
// its outer end is outside; an end without a clean bracket keeps the polygon's point.
std::vector<Vec2> refine_ends(JointSection& joint, const std::vector<HatchEnd>& ends, double delta,
                              double tol) {
  const std::size_t n = ends.size();
  std::vector<Bracket> br(n);
  std::vector<double> flo(n), fhi(n);
  std::vector<Vec2> pts;
  std::vector<double> vals;
  std::vector<std::pair<std::size_t, bool>> which;  // (end, is hi)
  auto at = [&](std::size_t i, double t) { return ends[i].p + ends[i].dir * t; };
  auto sample_listed = [&]() {
    vals.resize(pts.size());
    if (!pts.empty()) joint.sample(pts.data(), vals.data(), pts.size());
    for (std::size_t k = 0; k < which.size(); ++k)
      (which[k].second ? fhi : flo)[which[k].first] = vals[k];
  };
  for (std::size_t i = 0; i < n; ++i) {
    br[i] = {-delta, std::min(delta, ends[i].half_length)};
    pts.push_back(at(i, br[i].lo));
    which.emplace_back(i, false);
    pts.push_back(at(i, br[i].hi));
    which.emplace_back(i, true);
  }
  sample_listed();
  std::vector<int> tries_lo(n, 0), tries_hi(n, 0);
  for (int round = 0; round < 8; ++round) {
    pts.clear();
    which.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (flo[i] < 0 && tries_lo[i] < 8) {
        ++tries_lo[i];
        pts.push_back(at(i, br[i].lo *= 0.5));
        which.emplace_back(i, false);
      }
      if (fhi[i] >= 0 && tries_hi[i] < 8) {
        ++tries_hi[i];
        pts.push_back(at(i, br[i].hi *= 0.5));
        which.emplace_back(i, true);
      }
    }
    if (pts.empty()) break;
    sample_listed();
  }
  std::vector<std::size_t> ok;  // ends with a clean bracket
  std::vector<Bracket> okb;
  for (std::size_t i = 0; i < n; ++i)
    if (flo[i] >= 0 && fhi[i] < 0) {
      ok.push_back(i);
      okb.push_back(br[i]);
    }
  bisect_together(
      okb, tol, 200,
      [&](const std::vector<std::size_t>& act, const std::vector<double>& mid,
          std::vector<double>& out) {
        pts.resize(act.size());
        for (std::size_t k = 0; k < act.size(); ++k) pts[k] = at(ok[act[k]], mid[k]);
        joint.sample(pts.data(), out.data(), pts.size());
      },
      [](double v) { return v >= 0; });
  std::vector<Vec2> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = ends[i].p;
  for (std::size_t k = 0; k < ok.size(); ++k) out[ok[k]] = at(ok[k], 0.5 * (okb[k].lo + okb[k].hi));
  return out;
}

// Inside intervals of the part (< 0) along the scan line q(s) = origin + s·u, s in [s0, s1], by
// zero-finding: the part's interval bound discards stretches that cannot reach the sheet;
// the rest is split down to `leaf`, whose ends are sampled; a sign change is bisected to `tol`;
// a leaf with both ends outside is probed at its middle, so a crossing wider than half a leaf is
// always found.
class LineZeros {
 public:
  LineZeros(Ctx& ctx, double z, double leaf, double tol)
      : ctx_(ctx), z_(z), leaf_(leaf), tol_(tol) {}
  std::vector<std::pair<double, double>> run(Vec2 origin, Vec2 u, double s0, double s1) {
    o_ = origin;
    u_ = u;
    roots_.clear();
    const double f0 = f(s0), f1 = f(s1);
    visit(s0, s1, f0, f1, 0);
    // Roots in order; inside between an entering and the next leaving root.
    std::vector<std::pair<double, double>> out;
    bool inside = f0 < 0;
    double start = s0;
    std::sort(roots_.begin(), roots_.end());
    for (double r : roots_) {
      if (inside)
        out.emplace_back(start, r);
      else
        start = r;
      inside = !inside;
    }
    if (inside) out.emplace_back(start, s1);
    return out;
  }

 private:
  double f(double s) {
    const Vec2 q = o_ + u_ * s;
    return ctx_.part.value({q.x, q.y, z_});
  }
  Interval bound(double a, double b) {
    BBox3 box;
    const Vec2 p = o_ + u_ * a, q = o_ + u_ * b;
    box.add({p.x, p.y, z_});
    box.add({q.x, q.y, z_});
    return ctx_.part.bound(box);
  }
  void root(double a, double b, double fa) {
    while (b - a > tol_) {
      const double m = 0.5 * (a + b);
      if ((f(m) < 0) == (fa < 0))
        a = m;
      else
        b = m;
    }
    roots_.push_back(0.5 * (a + b));
  }
  void visit(double a, double b, double fa, double fb, int depth) {
    // Stretches that cannot reach the part are dropped (bounds are not worth it on the last
    // levels, where sampling is as cheap).
    if (b - a > 4 * leaf_ && bound(a, b).lo > 0) return;
    if (b - a <= leaf_ || depth > 40) {
      if ((fa < 0) != (fb < 0)) {
        root(a, b, fa);
      } else if (fa >= 0) {
        const double m = 0.5 * (a + b), fm = f(m);
        if (fm < 0) {
          root(a, m, fa);
          root(m, b, fm);
        }
      }
      return;
    }
    const double m = 0.5 * (a + b), fm = f(m);
    visit(a, m, fa, fm, depth + 1);
    visit(m, b, fm, fb, depth + 1);
  }
  Ctx& ctx_;
  double z_, leaf_, tol_;
  Vec2 o_, u_;
  std::vector<double> roots_;
};

// The mid-curve comes from the coarse grid: puts a point, projected onto φ = 0 by a Newton step
// along ∇φ, in the middle of every chord (chord error / 4).
void densify_on_mid_surface(Ctx& ctx, double z, std::vector<std::vector<Vec2>>& lines) {
  std::vector<Vec3> mids;
  for (const auto& l : lines)
    for (std::size_t k = 0; k + 1 < l.size(); ++k) {
      const Vec2 c = (l[k] + l[k + 1]) * 0.5;
      mids.push_back({c.x, c.y, z});
    }
  std::vector<double> fm(mids.size());
  std::vector<Vec3> gm(mids.size());
  if (!mids.empty()) {  // one batch each (TPMS: analytic gradients)
    ctx.phi.values(mids.data(), fm.data(), mids.size());
    ctx.phi.gradients(mids.data(), gm.data(), mids.size());
  }
  std::size_t next_mid = 0;
  for (auto& l : lines) {
    std::vector<Vec2> dense;
    dense.reserve(2 * l.size());
    for (std::size_t k = 0; k + 1 < l.size(); ++k, ++next_mid) {
      dense.push_back(l[k]);
      const Vec2 c{mids[next_mid].x, mids[next_mid].y};
      const double f = fm[next_mid];
      const Vec3 g = gm[next_mid];
      const double gg = g.x * g.x + g.y * g.y;  // in the plane of the layer
      dense.push_back(gg > 0 ? c - Vec2{g.x, g.y} * (f / gg) : c);
    }
    dense.push_back(l.back());
    l = std::move(dense);
  }
}

// A thin-wall stretch of the mid-curve: a loop (closed) or a piece between switches to a joint
// or to the part's outer boundary (then the track stops short of it).
struct ThinPiece {
  std::vector<Vec2> points;
  bool closed = false;
  bool boundary_start = false, boundary_end = false;
};

// Splits mid-curve lines (open ones first, loops from first_loop on, each loop's last point its
// first) where the inverted joint measure changes sign; each switch is bisected along its chord
// and classed by the part's value just past it. The measure is sampled in batches: all lines'
// points at once, then every switch's bisection step together, then the parts past them.
std::vector<ThinPiece> thin_pieces(Ctx& ctx, JointSection& thin,
                                   const std::vector<std::vector<Vec2>>& lines,
                                   std::size_t first_loop, double z, double refine) {
  std::vector<std::size_t> at(lines.size() + 1, 0);  // line li's points from at[li]
  for (std::size_t li = 0; li < lines.size(); ++li)
    at[li + 1] = at[li] + (lines[li].size() >= 2 ? lines[li].size() : 0);
  std::vector<Vec2> all(at.back());
  for (std::size_t li = 0; li < lines.size(); ++li)
    if (lines[li].size() >= 2) std::copy(lines[li].begin(), lines[li].end(), all.begin() + at[li]);
  std::vector<double> tv(all.size());
  if (!all.empty()) thin.sample(all.data(), tv.data(), all.size());
  // The switches in order along the lines, bisected together (bisect_together, in mm along
  // each one's chord from its first point) while the bracket is longer than `refine` (at most 30
  // halvings); lo stays on the side of the measure before the switch.
  struct Switch {
    Vec2 a, u;     // the chord's first point and direction
    bool leaving;  // the measure was negative before it
    Vec2 at(double t) const { return a + u * t; }
  };
  std::vector<Switch> sw;
  std::vector<Bracket> br;
  for (std::size_t li = 0; li < lines.size(); ++li)
    for (std::size_t k = at[li] + 1; k < at[li + 1]; ++k)
      if ((tv[k] < 0) != (tv[k - 1] < 0)) {
        const double len = std::sqrt(dist2(all[k - 1], all[k]));
        const Vec2 u = len > 0 ? (all[k] - all[k - 1]) * (1 / len) : Vec2{};
        sw.push_back({all[k - 1], u, tv[k - 1] < 0});
        br.push_back({0, len});
      }
  std::vector<Vec2> mids;
  bisect_together(
      br, refine, 30,
      [&](const std::vector<std::size_t>& act, const std::vector<double>& mid,
          std::vector<double>& out) {
        mids.resize(act.size());
        for (std::size_t k = 0; k < act.size(); ++k) mids[k] = sw[act[k]].at(mid[k]);
        thin.sample(mids.data(), out.data(), mids.size());
        // As "on lo's side": the measure's sign before the switch (a leaving switch: negative).
        for (std::size_t k = 0; k < act.size(); ++k)
          out[k] = (out[k] < 0) == sw[act[k]].leaving ? -1.0 : 1.0;
      },
      [](double v) { return v < 0; });
  std::vector<Vec3> past(sw.size());
  for (std::size_t s = 0; s < sw.size(); ++s) {
    const Vec2 q = sw[s].at(sw[s].leaving ? br[s].hi : br[s].lo);
    past[s] = {q.x, q.y, z};
  }
  std::vector<double> past_part(sw.size());
  if (!past.empty()) ctx.part.values(past.data(), past_part.data(), past.size());

  std::vector<ThinPiece> pieces;
  std::size_t next_switch = 0;
  // The piece being built: its points gathered in one buffer, then copied out at their number.
  std::vector<Vec2> cur;
  bool cur_start = false;
  auto emit = [&](bool boundary_end) {
    if (cur.size() < 2) return;
    ThinPiece p;
    p.points.assign(cur.begin(), cur.end());
    p.boundary_start = cur_start;
    p.boundary_end = boundary_end;
    pieces.push_back(std::move(p));
  };
  for (std::size_t li = 0; li < lines.size(); ++li) {
    const auto& l = lines[li];
    if (l.size() < 2) continue;
    const bool loop = li >= first_loop;
    const double* v_at = tv.data() + at[li];
    const std::size_t first_piece = pieces.size();
    bool switched = false;
    cur.clear();
    cur_start = false;
    if (v_at[0] < 0) {
      cur.push_back(l[0]);
      cur_start = !loop;  // an open mid-curve ends where the part does
    }
    double prev = v_at[0];
    for (std::size_t k = 1; k < l.size(); ++k) {
      const double v = v_at[k];
      if ((v < 0) != (prev < 0)) {
        switched = true;
        const std::size_t s = next_switch++;
        const Vec2 x = sw[s].at(0.5 * (br[s].lo + br[s].hi));
        const bool boundary = past_part[s] >= 0;
        if (prev < 0) {
          cur.push_back(x);
          emit(boundary);
          cur.clear();
          cur_start = false;
        } else {
          cur.assign(1, x);
          cur_start = boundary;
        }
      }
      if (v < 0) cur.push_back(l[k]);
      prev = v;
    }
    if (prev < 0) emit(!loop);
    if (!loop || v_at[0] >= 0 || prev >= 0 || pieces.size() == first_piece) continue;
    if (!switched) {
      pieces.back().closed = true;  // the whole loop is thin
    } else if (pieces.size() - first_piece >= 2) {
      // The last piece runs on into the first across the loop's seam: one piece.
      ThinPiece last = std::move(pieces.back());
      pieces.pop_back();
      ThinPiece& f = pieces[first_piece];
      last.points.insert(last.points.end(), f.points.begin() + 1, f.points.end());
      last.boundary_end = f.boundary_end;
      f = std::move(last);
    }
  }
  return pieces;
}

// Wall thickness measured across the sheet at mid-curve points inside the part (every 32nd
// point): from φ = 0 along ±∇φ to where Φ = 0 on each side, all rays bisected together.
void measure_wall_thickness(Ctx& ctx, const PbfDesign& design, double c_const, double z,
                            const std::vector<std::vector<Vec2>>& lines, PbfLayer& L) {
  L.t_min = std::numeric_limits<double>::infinity();
  L.t_max = 0;
  std::vector<Vec3> tp;  // mid-curve points sampled for thickness
  for (const auto& l : lines)
    for (std::size_t k = 0; k < l.size(); k += 32) tp.push_back({l[k].x, l[k].y, z});
  std::vector<double> tpart(tp.size());
  std::vector<Vec3> tgrad(tp.size());
  if (!tp.empty()) {
    ctx.part.values(tp.data(), tpart.data(), tp.size());
    ctx.phi.gradients(tp.data(), tgrad.data(), tp.size());
  }
  // Two rays per point inside the part (up and down ∇φ), reaching twice the nominal.
  struct Ray {
    Vec3 p, n;
  };
  std::vector<Ray> rays;
  std::vector<Bracket> br;
  for (std::size_t k = 0; k < tp.size(); ++k) {
    if (tpart[k] >= 0) continue;
    const double gn = norm(tgrad[k]);
    if (!(gn > 0)) continue;
    const Vec3 n = tgrad[k] * (1.0 / gn);
    const double nominal = design.thickness > 0
                               ? design.thickness
                               : 2 * std::abs(ctx.c ? ctx.c->value(tp[k]) : c_const) / gn;
    rays.push_back({tp[k], n});
    rays.push_back({tp[k], n * -1.0});
    br.push_back({0, 2 * nominal});
    br.push_back({0, 2 * nominal});
  }
  std::vector<Vec3> rp(rays.size());
  std::vector<double> rv(rays.size());
  for (std::size_t r = 0; r < rays.size(); ++r) rp[r] = rays[r].p + rays[r].n * br[r].hi;
  if (!rp.empty()) ctx.sheet.values(rp.data(), rv.data(), rp.size());
  std::vector<char> reached(rays.size());
  for (std::size_t r = 0; r < rays.size(); ++r) {
    reached[r] = rv[r] >= 0;  // else no sheet boundary within reach
    if (!reached[r]) br[r] = {0, 0};
  }
  bisect_together(
      br, 1e-6, 40,
      [&](const std::vector<std::size_t>& act, const std::vector<double>& mid,
          std::vector<double>& out) {
        rp.resize(act.size());
        for (std::size_t k = 0; k < act.size(); ++k)
          rp[k] = rays[act[k]].p + rays[act[k]].n * mid[k];
        ctx.sheet.values(rp.data(), out.data(), rp.size());
      },
      [](double v) { return v < 0; });
  for (std::size_t r = 0; r + 1 < rays.size(); r += 2) {
    if (!reached[r] || !reached[r + 1]) continue;  // no boundary within twice the nominal
    const double t = 0.5 * (br[r].lo + br[r].hi) + 0.5 * (br[r + 1].lo + br[r + 1].hi);
    L.t_min = std::min(L.t_min, t);
    L.t_max = std::max(L.t_max, t);
    L.t_sum += t;
    ++L.t_count;
  }
  if (L.t_count == 0) L.t_min = 0;
}

}  // namespace

PbfResult plan_pbf(const PbfDesign& design, const PbfOptions& o, const Progress& progress) {
  return plan_pbf(design, o, progress, {}, {});
}

std::size_t pbf_layer_count(const PbfDesign& design, const PbfOptions& o) {
  if (!(o.layer > 0)) throw SettingError("layer thickness must be > 0");
  const BBox3 e = design.part().extent();
  if (e.empty() || !std::isfinite(e.min.z) || !std::isfinite(e.max.z)) return 0;
  return layer_planes(e.min.z, e.max.z, o.layer).size();
}

PbfResult plan_pbf(const PbfDesign& design, const PbfOptions& o, const Progress& progress,
                   const PbfLayerSink& sink, PbfLayerRange range) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!(o.layer > 0)) throw SettingError("layer thickness must be > 0");
  if (!(o.resolution > 0)) throw SettingError("resolution must be > 0");
  if (o.coarse < 1 || o.coarse > 8) throw SettingError("coarse grid factor must be 1..8");
  if (!(o.segment_length > 0) || !std::isfinite(o.segment_length))
    throw SettingError("segment length SL must be > 0 mm");
  if (!(o.segment_gap >= 0) || !std::isfinite(o.segment_gap))
    throw SettingError("segment gap LHD must be >= 0 mm");
  if (!(o.hatch_distance > 0)) throw SettingError("hatch distance must be > 0");
  if (!(o.beam_compensation >= 0)) throw SettingError("beam compensation must be >= 0");
  if (!(o.melt_pool > 0)) throw SettingError("melt-pool width must be > 0");
  const Field part = design.part();
  PbfResult result;
  if (o.segment_length < 0.005 || o.segment_length > 0.4)
    result.diagnostics.warn("pbf.sl_untested",
                            fmt::format("segment length SL = {} µm is outside the 5–400 µm the "
                                        "PBF paper tested",
                                        o.segment_length * 1e3));
  if (o.segment_gap > 0.12)
    result.diagnostics.warn("pbf.lhd_untested",
                            fmt::format("segment gap LHD = {} µm is outside the 0–120 µm the PBF "
                                        "paper tested",
                                        o.segment_gap * 1e3));
  if (o.beam_compensation > 0 && o.beam_compensation >= 0.5 * o.thin_multiple * o.melt_pool)
    result.diagnostics.warn("pbf.beam_compensation_wide",
                            fmt::format("beam compensation {} mm is at least half the widest thin "
                                        "wall ({} mm): joints narrower than twice it get no hatch",
                                        o.beam_compensation, o.thin_multiple * o.melt_pool));
  result.layer = o.layer;
  result.extent = part.extent();
  const BBox3& e = result.extent;
  if (e.empty() || !std::isfinite(e.min.x) || !std::isfinite(e.max.x) || !std::isfinite(e.min.y) ||
      !std::isfinite(e.max.y) || !std::isfinite(e.min.z) || !std::isfinite(e.max.z))
    throw GeometryError("the lattice has no finite extent: give it an envelope (a box or a solid)");
  const std::vector<double> zs = layer_planes(e.min.z, e.max.z, o.layer);
  if (zs.size() > 200000) throw SettingError("more than 200,000 layers: check the layer thickness");
  if (!o.stl_route) {
    // The threads the layers run on: the arena's, bounded by a global_control (run.threads).
    const int threads = static_cast<int>(std::min<std::size_t>(
        static_cast<std::size_t>(tbb::this_task_arena::max_concurrency()),
        tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
    result.memory_estimate = pbf_memory_estimate(design, o, threads, static_cast<bool>(sink));
    if (progress.estimate)
      progress.estimate({result.memory_estimate, 0,
                         fmt::format("PBF paths of {} layers at resolution {} mm on {} thread(s)",
                                     zs.size(), o.resolution, threads),
                         "--resolution (pbf.resolution)"});
    const double budget = o.memory_budget > 0 ? o.memory_budget : default_memory_budget();
    if (budget > 0 && result.memory_estimate > budget)
      throw ResourceError(
          fmt::format(
              "refused before starting: this job needs about {:.0f} MB ({} threads at resolution "
              "{} "
              "mm, {} layers, estimate) but the memory budget is {:.0f} MB: raise the resolution "
              "(--resolution), cut the part in build-height ranges, run fewer threads or raise the "
              "budget (--max-memory MB, or --force)",
              result.memory_estimate / 1e6, threads, o.resolution, zs.size(), budget / 1e6),
          {"", 0, "run.max_memory"});
  }

  // c as a constant or as its own field.
  double c_const = 0;
  Field c_field;
  if (design.thickness <= 0) {
    // c = 1/0 filled the box solid, sqrt(-1) sliced noise: a c that is not a finite number at
    // the part's centre is refused.
    const Vec3 centre = e.center();
    double at_centre = 0;
    if (!constant_expression(design.c.text, &c_const)) {
      c_field = expression_field(design.c);
      at_centre = Evaluator(c_field).value(centre);
    } else {
      at_centre = c_const;
    }
    if (!std::isfinite(at_centre))
      throw SettingError(
          fmt::format("the sheet parameter c = '{}' is {} at the part's centre "
                      "({:g}, {:g}, {:g}): it must be a finite number",
                      design.c.text, std::isnan(at_centre) ? "not a number" : "infinite", centre.x,
                      centre.y, centre.z),
          {"", 0, "pbf.c"});
  }

  // A sheet nowhere as narrow as a thin wall has none: its horizontal width 2c / |∇xy φ| is at
  // least 2c / max|∇φ| (φ's Lipschitz bound) with a constant c, and at least t with a uniform
  // thickness t. Then the thin-wall measure is negative everywhere, and its march and the thin
  // pieces of the mid-curve, which would find nothing, are skipped.
  const double thin_width = o.thin_multiple * o.melt_pool;
  result.thin_walls_possible =
      o.split == PbfSplit::Inclination ? true
      : design.thickness > 0
          ? !(design.thickness > thin_width)
          : !c_field.empty() || !(thin_width * design.phi.lipschitz() < 2 * std::abs(c_const));

  // The STL route: one marching-cubes mesh of the part, cut by planes.
  TriangleMesh mesh;
  std::vector<std::vector<std::uint32_t>> buckets;
  if (o.stl_route) {
    MeshingStats ms;
    BBox3 box = e;
    mesh = field_to_mesh(part, box, o.resolution, &ms);
    result.mesh_triangles = mesh.triangles.size();
    if (!o.stl_scan_all)
      buckets = triangles_by_plane(mesh, zs);  // each layer: the triangles it cuts
    result.mesh_bytes = ms.mesh_bytes;
    result.grid_bytes = ms.grid_bytes;
  }

  // The joints and the mid-curve, smooth at the scale of a cell, are contoured on a grid
  // `coarse` times the resolution; the sheet section S (it gives the layer's area for FR_a and
  // the R67 baseline, not paths) on the same grid while that is at most 25 µm (two nodes across
  // the paper's thinnest, 65 µm walls), else on the resolution grid. Crossings are refined on
  // the field, so S at 20 µm is closer to the true section than the STL route's mesh at 10 µm
  // (tests/slice/test_pbf.cpp measures both). The node cache is on the finer of the two grids.
  const double H = std::max(1, o.coarse) * o.resolution;
  const double Hs = H <= 0.025 + 1e-9 ? H : o.resolution;
  const double pad = 2 * H;
  Vec2 lo{std::floor((e.min.x - pad) / H) * H, std::floor((e.min.y - pad) / H) * H};
  const Vec2 hi{std::ceil((e.max.x + pad) / H) * H, std::ceil((e.max.y + pad) / H) * H};
  // Crossings: the section to 2 µm (an area), the mid-curve to 0.5 µm (contour vectors must lie
  // within 1 µm of φ = 0), the joints to 1 µm (each hatch end is refined again on the field).
  MarchOptions mo_section, mo_mid, mo_joint;
  mo_section.resolution = Hs;
  mo_mid.resolution = mo_joint.resolution = H;
  // With beam compensation the section is also the boundary hatch vectors keep their distance
  // from: refined to 0.25 µm (and its chords halved onto the field, below).
  mo_section.refine_fraction = std::min(0.1, (o.beam_compensation > 0 ? 2.5e-4 : 2e-3) / Hs);
  // The section's crossings start from the cubic through the grid values along their edge:
  // about one refinement sample each instead of three (the same tolerance).
  mo_section.cubic_guess = true;
  // With beam compensation every hatch vector keeps it from the section's outline: its chords
  // are halved onto the field (a Newton step from each chord's middle), except where the outline
  // is within 0.25 µm of straight, the crossings' own tolerance (a point more there only costs
  // the hatching: 0.1 µm took 8% more time on 3 cells; the gyroid test's worst hatch end is
  // 0.24 µm inside the compensation, 0.20 µm with 0.1 µm).
  mo_section.segment_midpoints = o.beam_compensation > 0;
  mo_section.midpoint_min_offset = 2.5e-4;
  mo_mid.refine_fraction = std::min(0.1, 5e-4 / H);
  // Periodic tiles about 0.5 mm a side (measured on the 2–4-cell cubes at 25 µm: 2–3% faster
  // than 0.25 mm, which cost more per block, and than 1.25 mm, whose blocks along the envelope
  // are marched further in before their periodic quarters are taken from the tiles).
  auto tile_cells = [](double h) {
    return static_cast<std::size_t>(std::max(4.0, std::round(0.5 / h)));
  };
  mo_section.tile_block = tile_cells(Hs);
  mo_mid.tile_block = mo_joint.tile_block = tile_cells(H);
  mo_joint.refine_fraction = std::min(0.1, 1e-3 / H);
  // The thin-wall march (direct route, with compensation) takes the section's crossings where
  // the part decides its measure, when they are refined at least as tightly as its own.
  const auto stride = static_cast<std::size_t>(std::llround(H / Hs));
  const bool section_crossings = o.reuse_section_crossings && !o.stl_route && o.hybrid &&
                                 o.beam_compensation > 0 &&
                                 mo_section.refine_fraction * Hs <= mo_joint.refine_fraction * H &&
                                 std::abs(H - static_cast<double>(stride) * Hs) < 1e-12;

  const std::size_t first = std::min(range.first, zs.size());
  const std::size_t last = std::max(first, std::min(range.last, zs.size()));
  result.layers.resize(last - first);
  // A sheet of constant c (or thickness) around a φ that repeats along x and y repeats too.
  Vec2 sheet_period{0, 0};
  if (o.periodic_tiles && (design.thickness > 0 || c_field.empty())) {
    const Vec3 p = design.phi.period();
    // A period wider than the part never repeats inside it, and a tile's grid spans a whole
    // period (a 947 mm cell on a 3 mm part was a 34 GB grid): no tiles then.
    if (p.x > 0 && p.y > 0 && p.x <= hi.x - lo.x && p.y <= hi.y - lo.y) sheet_period = {p.x, p.y};
  }
  // The tiles pay where the part is the sheet alone over much of its extent; elsewhere their
  // smaller blocks only cost (e.g. a lattice cut by another lattice, whose envelope is
  // negative only inside its own walls). Checked on 0.5 mm blocks of three layers: tiles when
  // at least 30% of the blocks are periodic.
  if (sheet_period.x > 0 && !zs.empty()) {
    Ctx probe(part, design, c_field, sheet_period);
    std::size_t periodic = 0, total = 0;
    const double step = 0.5;
    for (const double f : {0.25, 0.5, 0.75}) {
      const auto k = static_cast<std::size_t>(f * static_cast<double>(zs.size()));
      const double z = zs[std::min(zs.size() - 1, k)];
      for (double y = e.min.y; y < e.max.y; y += step)
        for (double x = e.min.x; x < e.max.x; x += step) {
          ++total;
          periodic += probe.periodic({x, y}, {x + step, y + step}, z);
        }
    }
    result.periodic_fraction =
        total ? static_cast<double>(periodic) / static_cast<double>(total) : 0;
    if (!(result.periodic_fraction >= 0.3)) sheet_period = {0, 0};
  }
  tbb::enumerable_thread_specific<Ctx> contexts(
      [&] { return Ctx(part, design, c_field, sheet_period); });
  // Layers a period apart along z (the sheet repeats along z too, by a whole number P of layers)
  // take the same tiles: a class of layers (i mod P) has its tiles made once, at the height of
  // its first layer, by marches of the sheet alone over one period from the layers' grid origin,
  // and kept while later layers of the class remain (up to the budget; else made again). Made
  // from the class alone, they are the same whichever layers a run covers (a layer range run on
  // its own equals that range of the whole run). A last layer cut below the top (not whole
  // periods above its class's first) marches its own.
  struct ClassTiles {
    PeriodTiles section, thin, joint, mid;
    std::size_t bytes() const { return section.bytes + thin.bytes + joint.bytes + mid.bytes; }
  };
  std::size_t zp = 0;  // P; 0: no sharing along z
  if (sheet_period.x > 0 && o.z_tiles_budget > 0) {
    const double pz = design.phi.period().z, r = pz / o.layer, c = std::round(r);
    if (pz > 0 && std::isfinite(r) && c >= 1 && std::abs(r - c) <= 1e-9 * c)
      zp = static_cast<std::size_t>(c);
  }
  // Classes mirrored through the origin (PbfOptions::mirror_tiles): with z_c + z_c' ≡ 0 modulo
  // the period, i.e. c + c' + 1 ≡ N = −2·min z / layer (mod P), class c' is class c turned half
  // a turn (Φ(x, y, −z) = Φ(−x, −y, z); φ itself keeps or changes its sign). The turn takes
  // grid node k to node s − k (s = −2·lo in cells, modulo the period): tiles go onto tiles when
  // s is a multiple of every march's tile side, so lo is moved down until it is.
  const int parity = design.phi.inversion_parity();
  long long mirror_n = 0;
  bool mirror = false;
  std::size_t sx_s = 0, sy_s = 0, sx_c = 0, sy_c = 0;
  if (zp && o.mirror_tiles && parity != 0) {
    const std::size_t pxs = period_cells(sheet_period.x, Hs),
                      pys = period_cells(sheet_period.y, Hs);
    const std::size_t pxc = period_cells(sheet_period.x, H), pyc = period_cells(sheet_period.y, H);
    const std::size_t tsx = pxs ? period_tile_side(pxs, mo_section.tile_block) : 0;
    const std::size_t tsy = pys ? period_tile_side(pys, mo_section.tile_block) : 0;
    const std::size_t tcx = pxc ? period_tile_side(pxc, mo_joint.tile_block) : 0;
    const std::size_t tcy = pyc ? period_tile_side(pyc, mo_joint.tile_block) : 0;
    const double n = -2 * e.min.z / o.layer, nr = std::round(n);
    if (tsx && tsy && tcx && tcy && std::abs(n - nr) <= 1e-9 * std::max(1.0, std::abs(n))) {
      // lo in section cells: a multiple of stride (a node of both grids) whose double is a
      // multiple of both marches' tile sides.
      auto unit = [&](std::size_t ts, std::size_t tc) {
        const std::size_t a = ts % 2 ? ts : ts / 2, b = (tc % 2 ? tc : tc / 2) * stride;
        return static_cast<double>(std::lcm(std::lcm(a, b), stride)) * Hs;
      };
      const double ux = unit(tsx, tcx), uy = unit(tsy, tcy);
      lo = {std::floor((e.min.x - pad) / ux) * ux, std::floor((e.min.y - pad) / uy) * uy};
      auto shift = [](double lo_, double h, std::size_t p) {
        const long long s = -2 * std::llround(lo_ / h), pp = static_cast<long long>(p);
        return static_cast<std::size_t>(((s % pp) + pp) % pp);
      };
      sx_s = shift(lo.x, Hs, pxs), sy_s = shift(lo.y, Hs, pys);
      sx_c = shift(lo.x, H, pxc), sy_c = shift(lo.y, H, pyc);
      mirror_n = static_cast<long long>(nr);
      mirror = true;
    }
  }
  result.mirror_tiles = mirror;
  const auto nx = static_cast<std::size_t>(std::llround((hi.x - lo.x) / Hs));
  const auto ny = static_cast<std::size_t>(std::llround((hi.y - lo.y) / Hs));
  // The class whose tiles, turned, are class c's: the mirror class when it comes first, else c.
  auto mirror_source = [&](std::size_t c) {
    if (!mirror) return c;
    const auto p = static_cast<long long>(zp);
    const auto m =
        static_cast<std::size_t>((((mirror_n - 1 - static_cast<long long>(c)) % p) + p) % p);
    return std::min(m, c);
  };
  PbfDesign sheet_design = design;
  sheet_design.envelope = Field{};
  sheet_design.solids = Field{};
  sheet_design.clip.clear();
  const Field sheet_part = zp ? sheet_design.part() : Field{};
  tbb::enumerable_thread_specific<Ctx> class_contexts(
      [&] { return Ctx(sheet_part, sheet_design, c_field, sheet_period); });
  std::vector<std::shared_ptr<const ClassTiles>> kept(zp);
  std::size_t kept_bytes = 0;
  std::mutex kept_mutex;
  std::atomic<std::size_t> turned_classes{0};
  // The section march of a context at height z over [a, b] (direct route): its crossings are kept
  // with the context's grid for the thin-wall march.
  auto march_section = [&](Ctx& c, double z, Vec2 a, Vec2 b, MarchOptions mo) {
    PartSection fs(c, c.grid, z);
    // The coarse marches' smallest blocks are 4 of their cells (MarchOptions::block's leaves).
    if (Hs < H) fs.share_bounds_from(4 * H - 1e-9);
    mo.edge_crossings = section_crossings ? &c.edge_crossings : nullptr;
    ContourSet r = march_squares(fs, a, b, 0.0, mo);
    if (section_crossings) c.grid.set_crossings(c.edge_crossings);
    return r;
  };
  // The joint slots of the grid's nodes hold the joint measure when the joints are marched (no
  // compensation), else the thin-wall measure (the thin region is marched instead).
  auto use_grid = [&](Ctx& c, JointSection& joint, JointSection& thin) {
    joint.use_grid(&c.grid, o.beam_compensation <= 0);
    thin.use_grid(&c.grid, o.beam_compensation > 0);
    thin.use_section_crossings(section_crossings ? stride : 0);
  };
  auto make_class_tiles = [&](std::size_t c) {
    auto out = std::make_shared<ClassTiles>();
    Ctx& cc = class_contexts.local();
    const double z = zs[c];
    const Vec2 top = lo + sheet_period;
    cc.grid.reset(lo, Hs, static_cast<std::size_t>(std::llround(sheet_period.x / Hs)),
                  static_cast<std::size_t>(std::llround(sheet_period.y / Hs)));
    cc.bounds.reset(z);
    if (!o.stl_route) {
      MarchOptions mo = mo_section;
      mo.tiles_out = &out->section;
      march_section(cc, z, lo, top, mo);
    }
    if (o.hybrid) {
      JointSection joint(cc, sheet_design, o, c_const, z);
      JointSection thin(cc, sheet_design, o, c_const, z, true);
      use_grid(cc, joint, thin);
      MarchOptions mj = mo_joint;
      if (o.beam_compensation <= 0) {
        mj.tiles_out = &out->joint;
        march_squares(joint, lo, top, 0.0, mj);
      } else if (result.thin_walls_possible) {
        mj.tiles_out = &out->thin;
        march_squares(thin, lo, top, 0.0, mj);
      }
      MidSection mid(cc, z);
      MarchOptions mm = mo_mid;
      mm.tiles_out = &out->mid;
      march_squares(mid, lo, top, 0.0, mm);
    }
    return std::shared_ptr<const ClassTiles>(std::move(out));
  };
  auto class_tiles = [&](std::size_t i) -> std::shared_ptr<const ClassTiles> {
    if (zp == 0 || zs[i] != e.min.z + (static_cast<double>(i) + 0.5) * o.layer) return nullptr;
    const std::size_t c = i % zp;
    {
      std::lock_guard lock(kept_mutex);
      if (kept[c]) return kept[c];
    }
    std::shared_ptr<const ClassTiles> t;
    if (const std::size_t m = mirror_source(c); m < c) {
      std::shared_ptr<const ClassTiles> from;
      {
        std::lock_guard lock(kept_mutex);
        from = kept[m];
      }
      if (!from) from = make_class_tiles(m);
      auto turned = std::make_shared<ClassTiles>();
      turned->section = point_reflected_tiles(from->section, Hs, sx_s, sy_s, false);
      turned->thin = point_reflected_tiles(from->thin, H, sx_c, sy_c, false);
      turned->joint = point_reflected_tiles(from->joint, H, sx_c, sy_c, false);
      turned->mid = point_reflected_tiles(from->mid, H, sx_c, sy_c, parity < 0);
      t = std::move(turned);
      ++turned_classes;
    } else {
      t = make_class_tiles(c);
    }
    if (i + zp < last) {  // the class has a later layer in this run
      std::lock_guard lock(kept_mutex);
      if (kept[c]) return kept[c];
      if (kept_bytes + t->bytes() <= o.z_tiles_budget) {
        kept[c] = t;
        kept_bytes += t->bytes();
      }
    }
    return t;
  };
  auto release_class = [&](std::size_t i) {  // after the class's last layer in this run
    if (zp == 0 || i + zp < last) return;
    std::lock_guard lock(kept_mutex);
    if (auto& k = kept[i % zp]) {
      kept_bytes -= k->bytes();
      k.reset();
    }
  };
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex;
  const std::size_t count = last - first;
  // Layer i into result.layers[i - first] (the calling thread's context).
  auto compute = [&](std::size_t i) {
    progress.check("PBF planning");
    Ctx& ctx = contexts.local();
    PbfLayer& L = result.layers[i - first];
    const double z = zs[i];
    L.z = z;
    L.hatch_angle = std::fmod(o.hatch_angle + o.hatch_rotation * static_cast<double>(i), 180.0);
    // A point the layer's hatch lines pass through (HatchPhase).
    Vec2 ho{0, 0};
    if (o.hatch_phase == HatchPhase::Origin) {
      ho = o.machine_origin;
    } else if (o.hatch_phase == HatchPhase::Random) {
      ho = random_hatch_shift(L.hatch_angle, o.hatch_seed, i, o.hatch_distance);
    }
    // A march's contours, its blocks counted in the layer's.
    auto counted = [&L](ContourSet c) {
      L.blocks += c.blocks;
      L.tiled_blocks += c.tiled_blocks;
      return c;
    };
    // The sheet's cross-section S.
    const std::shared_ptr<const ClassTiles> ct = class_tiles(i);
    auto tiled = [&](const MarchOptions& base, const PeriodTiles ClassTiles::*which) {
      MarchOptions m = base;
      m.tiles_in = ct ? &(*ct.*which) : nullptr;
      return m;
    };
    LayerGrid& grid = ctx.grid;
    grid.reset(lo, Hs, nx, ny);
    ctx.bounds.reset(z);
    Regions S;
    if (o.stl_route) {
      S = o.stl_scan_all ? slice_mesh(mesh, z) : slice_mesh(mesh, z, buckets[i]);
    } else {
      S = nest_oriented_rings(
          counted(march_section(ctx, z, lo, hi, tiled(mo_section, &ClassTiles::section)))
              .lines.loops);
    }
    L.area = area(S);
    if (S.empty()) return;
    // With beam compensation every hatch vector keeps it from the section's outline (its chords
    // halved onto the field by the march on the direct route) and from the thin walls' outline.
    const double bc = o.beam_compensation;
    Regions T;  // thin walls, when compensating
    JointSection joint(ctx, design, o, c_const, z);
    JointSection thin(ctx, design, o, c_const, z, true);
    use_grid(ctx, joint, thin);
    Regions hatch_region = S;
    if (o.hybrid) {
      // Joints are contoured from their own field (a Boolean of S and J would spend its time on
      // their shared edges); thin walls are the pieces of the mid-curve φ = 0 where the
      // inverted joint measure is negative, split where it changes sign.
      if (bc > 0) {
        // Joints = the section minus the thin walls, so the joints' outline along the sheet is
        // the section's (refined) one, not the coarse grid's; slivers between the two outlines
        // are narrower than a cell and within the compensation of both.
        if (result.thin_walls_possible)
          T = nest_oriented_rings(
              counted(march_squares(thin, lo, hi, 0.0, tiled(mo_joint, &ClassTiles::thin)))
                  .lines.loops);
      } else {
        hatch_region = nest_oriented_rings(
            counted(march_squares(joint, lo, hi, 0.0, tiled(mo_joint, &ClassTiles::joint)))
                .lines.loops);
      }
      MidSection mid(ctx, z);
      const ContourSet m =
          counted(march_squares(mid, lo, hi, 0.0, tiled(mo_mid, &ClassTiles::mid)));
      std::vector<std::vector<Vec2>> lines = m.lines.open;
      const std::size_t first_loop = lines.size();
      for (auto l : m.lines.loops) {
        l.push_back(l.front());
        lines.push_back(std::move(l));
      }
      densify_on_mid_surface(ctx, z, lines);
      measure_wall_thickness(ctx, design, c_const, z, lines, L);
      const std::vector<ThinPiece> pieces =
          result.thin_walls_possible ? thin_pieces(ctx, thin, lines, first_loop, z, o.refine)
                                     : std::vector<ThinPiece>{};
      const double period = o.segment_length + o.segment_gap;
      const double phase = std::fmod(o.contour_shift * static_cast<double>(i), 1.0) * period;
      // φ and its gradient in the layer; the traced line lies within a grid cell of φ = 0, so a
      // Newton step that goes further than 4 cells (a near-zero gradient: a cell not much
      // larger than the grid) is not kept.
      const pbf_detail::Curve curve{[&](Vec2 q, Vec2* grad) {
                                      Vec3 g;
                                      const double f = ctx.phi.value_gradient({q.x, q.y, z}, &g);
                                      *grad = {g.x, g.y};
                                      return f;
                                    },
                                    4 * o.resolution};
      for (const auto& piece : pieces) {
        // A track ending at the part's outer boundary stops the beam compensation before it.
        const std::vector<Vec2>* pts = &piece.points;
        std::vector<Vec2> trimmed;
        if (piece.boundary_start) pts = &(trimmed = pbf_detail::trim_arc(*pts, bc, true));
        if (piece.boundary_end) pts = &(trimmed = pbf_detail::trim_arc(*pts, bc, false));
        pbf_detail::chord_vectors(*pts, piece.closed, o.segment_length, o.segment_gap, phase, curve,
                                  L.contours);
      }
      for (const auto& v : L.contours)
        for (std::size_t k = 1; k < v.size(); ++k)
          L.contour_length += std::hypot(v[k].x - v[k - 1].x, v[k].y - v[k - 1].y);
    }
    // Hatch vectors: with beam compensation they end on the inward offset (each at the
    // compensation from the boundary); without, on the field.
    const double ang = L.hatch_angle * kDeg;
    const Vec2 u{std::cos(ang), std::sin(ang)}, v{-std::sin(ang), std::cos(ang)};
    auto add_vector = [&](Vec2 a, Vec2 b) {
      const double len = std::hypot(b.x - a.x, b.y - a.y);
      if (len <= 1e-6) return;
      L.hatches.push_back({a, b});
      L.hatch_length += len;
    };
    // The whole section hatched with the compensation: the R67 baseline, and the hybrid path's
    // joints once the thin walls are taken out.
    const std::vector<Segment2> S_hatch =
        bc > 0 ? hatch_inset(S, {}, L.hatch_angle, o.hatch_distance, bc, ho)
               : hatch(S, L.hatch_angle, o.hatch_distance, ho);
    if (bc > 0) {
      const std::vector<Segment2> segs =
          o.hybrid ? trim_hatch(S_hatch, T, L.hatch_angle, o.hatch_distance, bc, true, ho)
                   : S_hatch;
      for (const auto& seg : segs) add_vector(seg.a, seg.b);
    } else if (o.stl_route) {
      for (const auto& seg : hatch(hatch_region, L.hatch_angle, o.hatch_distance, ho))
        add_vector(seg.a, seg.b);
    } else if (o.hybrid) {
      // Joints are wider than a thin wall (thin_multiple · D) by definition, so their outline on
      // the grid cannot miss one: its scan lines seed each crossing, refined on the field.
      const std::vector<Segment2> segs = hatch(hatch_region, L.hatch_angle, o.hatch_distance, ho);
      std::vector<HatchEnd> ends;
      ends.reserve(2 * segs.size());
      for (const auto& seg : segs) {
        const double half = 0.5 * std::hypot(seg.b.x - seg.a.x, seg.b.y - seg.a.y);
        ends.push_back({seg.a, u, half});
        ends.push_back({seg.b, u * -1.0, half});
      }
      const std::vector<Vec2> r = refine_ends(joint, ends, 2 * o.resolution, o.refine);
      for (std::size_t k = 0; k < segs.size(); ++k) add_vector(r[2 * k], r[2 * k + 1]);
    } else {
      // R67 without compensation over the whole sheet, where walls can be thinner than the
      // grid: zero-finding along every scan line, across the domain box.
      double t0 = 1e300, t1 = -1e300, s0 = 1e300, s1 = -1e300;
      for (const Vec2 c : {lo, hi, Vec2{lo.x, hi.y}, Vec2{hi.x, lo.y}}) {
        t0 = std::min(t0, c.x * v.x + c.y * v.y);
        t1 = std::max(t1, c.x * v.x + c.y * v.y);
        s0 = std::min(s0, c.x * u.x + c.y * u.y);
        s1 = std::max(s1, c.x * u.x + c.y * u.y);
      }
      // Leaves of two grid cells, probed at their middle: crossings wider than one cell are
      // always found.
      LineZeros zeros(ctx, z, 2 * o.resolution, o.refine);
      const double off = ho.x * v.x + ho.y * v.y;  // the lines' phase across them
      const auto k0 = static_cast<long long>(std::ceil((t0 - off) / o.hatch_distance));
      const auto k1 = static_cast<long long>(std::floor((t1 - off) / o.hatch_distance));
      for (long long k = k0; k <= k1; ++k) {
        const Vec2 origin = v * (static_cast<double>(k) * o.hatch_distance + off);
        for (const auto& [a, b] : zeros.run(origin, u, s0, s1))
          add_vector(origin + u * a, origin + u * b);
      }
    }
    // Scan time of this path (contours, then hatches, in order) and of the R67 baseline on the
    // same layer: the whole sheet hatched with the same compensation.
    ScanClock clock(o.timing);
    for (const auto& c : L.contours) clock.mark(c.data(), c.size(), o.timing.contour_speed);
    for (const auto& h : L.hatches) clock.mark(h.a, h.b, o.timing.hatch_speed);
    L.scan_time = clock.seconds();
    if (o.hybrid) {
      ScanClock r67(o.timing);
      for (const auto& s : S_hatch) {
        L.r67_length += std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
        r67.mark(s.a, s.b, o.timing.hatch_speed);
      }
      L.scan_time_r67 = r67.seconds();
    } else {
      L.r67_length = L.hatch_length;
      L.scan_time_r67 = L.scan_time;
    }
    L.fr = o.melt_pool * (L.contour_length + L.hatch_length) / L.area;
    L.fr_r67 = o.melt_pool * L.r67_length / L.area;
    const double cap = equivalent_length(0, o.melt_pool);
    const double n_vec = static_cast<double>(L.contours.size() + L.hatches.size());
    const double n_r67 = static_cast<double>(o.hybrid ? S_hatch.size() : L.hatches.size());
    L.fr_eq = o.melt_pool * (L.contour_length + L.hatch_length + n_vec * cap) / L.area;
    L.fr_eq_r67 = o.melt_pool * (L.r67_length + n_r67 * cap) / L.area;
  };
  // A bounded in-order pipeline: layer numbers in order, layers computed in parallel (at most
  // two per thread in flight), then summed up and handed to the sink in order; with a sink the
  // vectors are dropped once it has them.
  const std::size_t tokens =
      2 * static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  std::size_t next = first;
  tbb::parallel_pipeline(
      tokens, tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                                  [&](tbb::flow_control& fc) -> std::size_t {
                                                    if (next >= last) {
                                                      fc.stop();
                                                      return 0;
                                                    }
                                                    return next++;
                                                  }) &
                  tbb::make_filter<std::size_t, std::size_t>(tbb::filter_mode::parallel,
                                                             [&](std::size_t i) {
                                                               compute(i);
                                                               return i;
                                                             }) &
                  tbb::make_filter<std::size_t, void>(
                      tbb::filter_mode::serial_in_order, [&](std::size_t i) {
                        release_class(i);
                        PbfLayer& L = result.layers[i - first];
                        result.contour_vectors += L.contours.size();
                        result.hatch_vectors += L.hatches.size();
                        result.contour_length += L.contour_length;
                        result.hatch_length += L.hatch_length;
                        result.scan_time += L.scan_time;
                        result.scan_time_r67 += L.scan_time_r67;
                        result.blocks += L.blocks;
                        result.tiled_blocks += L.tiled_blocks;
                        if (sink) {
                          sink(i, L);
                          std::vector<std::vector<Vec2>>().swap(L.contours);
                          std::vector<Segment2>().swap(L.hatches);
                        }
                        const std::size_t d = ++done;
                        if (progress.report && (d % 32 == 0 || d == count)) {
                          std::lock_guard lock(progress_mutex);
                          progress("layers", static_cast<double>(d) / static_cast<double>(count));
                        }
                      }));
  result.turned_classes = turned_classes;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace trellis
