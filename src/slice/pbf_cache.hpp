// The caches a PBF layer's marches share on one thread: the part's and the joint measure's values
// at the grid's nodes (with the section march's crossings), and the part's bounds over blocks.
// Reused from layer to layer; an entry is valid for its layer's stamp.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <utility>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/contour.hpp"

namespace trellis::pbf_detail {

// The flat box [lo, hi] at height z (a layer's block, for 3D bounds).
inline BBox3 plane_box(Vec2 lo, Vec2 hi, double z) {
  BBox3 b;
  b.add({lo.x, lo.y, z});
  b.add({hi.x, hi.y, z});
  return b;
}

// Grid-node values of the part and of the joint measure, shared by the S and J marches of a
// layer (both sample the same nodes).
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

}  // namespace trellis::pbf_detail
