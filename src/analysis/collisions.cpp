#include "trellis/analysis/collisions.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <unordered_map>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

constexpr std::uint32_t kNone = UINT32_MAX;

// Nearest design node within `snap` of a point (hash grid of cell 2·snap).
class NodeSnap {
 public:
  NodeSnap(const Graph& g, double snap) : g_(g), snap_(snap), cell_(std::max(2 * snap, 1e-9)) {
    for (NodeId n = 0; n < g.nodes.size(); ++n) cells_[key(g.nodes[n])].push_back(n);
  }
  std::uint32_t find(Vec3 p) const {
    const auto cx = cell(p.x), cy = cell(p.y), cz = cell(p.z);
    std::uint32_t best = kNone;
    double best_d = snap_;
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          auto it = cells_.find(pack(cx + dx, cy + dy, cz + dz));
          if (it == cells_.end()) continue;
          for (NodeId n : it->second) {
            const double d = distance(p, g_.nodes[n]);
            if (d <= best_d) {
              best_d = d;
              best = n;
            }
          }
        }
    return best;
  }

 private:
  long long cell(double v) const { return static_cast<long long>(std::floor(v / cell_)); }
  static std::uint64_t pack(long long x, long long y, long long z) {
    return (static_cast<std::uint64_t>(x & 0x1FFFFF) << 42) |
           (static_cast<std::uint64_t>(y & 0x1FFFFF) << 21) |
           static_cast<std::uint64_t>(z & 0x1FFFFF);
  }
  std::uint64_t key(Vec3 p) const { return pack(cell(p.x), cell(p.y), cell(p.z)); }
  const Graph& g_;
  double snap_, cell_;
  std::unordered_map<std::uint64_t, std::vector<NodeId>> cells_;
};

// Nonzero segments of a layer in print order: f(path in the layer, point index, a, b).
template <class F>
void for_segments(const Layer& layer, F&& f) {
  for (std::size_t p = 0; p < layer.paths.size(); ++p) {
    const auto& pts = layer.paths[p].points;
    for (std::size_t i = 0; i + 1 < pts.size(); ++i)
      if (distance(pts[i], pts[i + 1]) > 0) f(p, i, pts[i], pts[i + 1]);
  }
}

// What the first visit finds: each layer's segments, their extent, and the lowest tip still to
// come from each layer on (what the replay may drop before it).
struct PrintOutline {
  struct LayerExtent {
    std::size_t segments = 0;
    BBox3 box;
  };
  std::vector<LayerExtent> layers;
  std::vector<double> floor;  // floor[k]: the lowest point of layers k, k+1, ...
  std::size_t printed_layers = 0, segments = 0;
  double typical = 0;  // median XY extent of the first segments: the index's cell
};

PrintOutline outline_of(const LayerSource& source) {
  PrintOutline o;
  std::vector<double> extents;
  source([&](std::size_t, const Layer& layer) {
    PrintOutline::LayerExtent& e = o.layers.emplace_back();
    for_segments(layer, [&](std::size_t, std::size_t, Vec3 a, Vec3 b) {
      ++e.segments;
      e.box.add(a);
      e.box.add(b);
      if (extents.size() < 4096)
        extents.push_back(std::max(std::abs(b.x - a.x), std::abs(b.y - a.y)));
    });
    o.segments += e.segments;
    if (e.segments > 0) ++o.printed_layers;
  });
  o.floor.assign(o.layers.size() + 1, std::numeric_limits<double>::infinity());
  for (std::size_t k = o.layers.size(); k-- > 0;)
    o.floor[k] = std::min(o.floor[k + 1], o.layers[k].box.min.z);
  if (!extents.empty()) {
    const auto mid = extents.begin() + static_cast<std::ptrdiff_t>(extents.size() / 2);
    std::nth_element(extents.begin(), mid, extents.end());
    o.typical = *mid;
  }
  return o;
}

// The segments printed so far that a later tip can still hit, in a hash grid of XY cells over
// their footprints padded by the nozzle radius; dropped once no later tip comes below their top.
class HeldIndex {
 public:
  struct Held {
    Vec3 a, b;
    std::size_t id = 0, path = 0, index = 0;  // print order, path, segment in the path
    long long strut = -1;
    std::uint32_t na = kNone, nb = kNone;
  };

  HeldIndex(double cell, double pad) : cell_(cell), pad_(pad) {}

  void insert(const Held& h) {
    std::uint32_t slot;
    if (free_.empty()) {
      slot = static_cast<std::uint32_t>(held_.size());
      held_.push_back(h);
      stamp_.push_back(0);
      live_.push_back(1);
    } else {
      slot = free_.back();
      free_.pop_back();
      held_[slot] = h;
      live_[slot] = 1;
    }
    const Range r = range(h.a, h.b, pad_);
    if (r.cells() > kWide)
      wide_.push_back(slot);
    else
      for (long long y = r.y0; y <= r.y1; ++y)
        for (long long x = r.x0; x <= r.x1; ++x) cells_[key(x, y)].push_back(slot);
    tops_.push({std::max(h.a.z, h.b.z), slot});
    peak_ = std::max(peak_, ++count_);
  }

  // Drops every held segment whose top is at or below z.
  void drop_to(double z) {
    while (!tops_.empty() && tops_.top().first <= z) {
      remove(tops_.top().second);
      tops_.pop();
    }
  }

  // f(held) once per held segment whose padded footprint may meet the footprint of [a, b].
  template <class F>
  void for_candidates(Vec3 a, Vec3 b, F&& f) {
    const Range r = range(a, b, 0);
    if (r.cells() > kWide) {  // a long move: every held segment
      for (std::uint32_t slot = 0; slot < held_.size(); ++slot)
        if (live_[slot]) f(held_[slot]);
      return;
    }
    if (++tick_ == 0) std::fill(stamp_.begin(), stamp_.end(), 0), tick_ = 1;
    auto visit = [&](std::uint32_t slot) {
      if (stamp_[slot] == tick_) return;
      stamp_[slot] = tick_;
      f(held_[slot]);
    };
    for (long long y = r.y0; y <= r.y1; ++y)
      for (long long x = r.x0; x <= r.x1; ++x)
        if (const auto it = cells_.find(key(x, y)); it != cells_.end())
          for (std::uint32_t slot : it->second) visit(slot);
    for (std::uint32_t slot : wide_) visit(slot);
  }

  std::size_t peak() const { return peak_; }

 private:
  static constexpr long long kWide = 64;  // footprints over more cells go in one list
  struct Range {
    long long x0, x1, y0, y1;
    long long cells() const { return (x1 - x0 + 1) * (y1 - y0 + 1); }
  };
  long long cell(double v) const {
    return static_cast<long long>(std::clamp(std::floor(v / cell_), -1e9, 1e9));
  }
  Range range(Vec3 a, Vec3 b, double pad) const {
    return {cell(std::min(a.x, b.x) - pad), cell(std::max(a.x, b.x) + pad),
            cell(std::min(a.y, b.y) - pad), cell(std::max(a.y, b.y) + pad)};
  }
  static std::uint64_t key(long long x, long long y) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32) |
           static_cast<std::uint32_t>(y);
  }
  static void erase_one(std::vector<std::uint32_t>& v, std::uint32_t slot) {
    const auto it = std::find(v.begin(), v.end(), slot);
    *it = v.back();
    v.pop_back();
  }
  void remove(std::uint32_t slot) {
    const Range r = range(held_[slot].a, held_[slot].b, pad_);
    if (r.cells() > kWide) {
      erase_one(wide_, slot);
    } else {
      for (long long y = r.y0; y <= r.y1; ++y)
        for (long long x = r.x0; x <= r.x1; ++x) {
          const auto it = cells_.find(key(x, y));
          erase_one(it->second, slot);
          if (it->second.empty()) cells_.erase(it);
        }
    }
    live_[slot] = 0;
    free_.push_back(slot);
    --count_;
  }
  double cell_, pad_;
  std::vector<Held> held_;
  std::vector<std::uint32_t> free_, stamp_, wide_;
  std::vector<char> live_;
  std::uint32_t tick_ = 0;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
  std::priority_queue<std::pair<double, std::uint32_t>,
                      std::vector<std::pair<double, std::uint32_t>>, std::greater<>>
      tops_;
  std::size_t count_ = 0, peak_ = 0;
};

// Held segments: the replay's memory per segment (record, cells, heap entry, stamp) and the
// layer being read with it, measured about 300 bytes.
constexpr double kBytesPerHeld = 300;

// The replay's work from the outline, layer by layer: each move reads the lists of the cells
// its footprint meets, about the held count times the share of the layer's padded area one
// footprint covers (all of them when the moves pile up), once per cell. A layer is taken as held
// until the floor passes its top (the replay drops segment by segment: it holds fewer).
Estimate replay_estimate(const PrintOutline& o, double cell, double pad) {
  using Top = std::pair<double, std::size_t>;  // (layer top, segments)
  std::priority_queue<Top, std::vector<Top>, std::greater<>> held;
  double visits = 0, held_now = 0, peak = 0;
  const double reach = o.typical + cell + 2 * pad;
  const double cells = std::pow((o.typical + 2 * pad) / cell + 1, 2);
  for (std::size_t k = 0; k < o.layers.size(); ++k) {
    const auto& l = o.layers[k];
    while (!held.empty() && held.top().first <= o.floor[k]) {
      held_now -= static_cast<double>(held.top().second);
      held.pop();
    }
    if (l.segments == 0) continue;
    const double n = static_cast<double>(l.segments);
    const double area =
        (l.box.max.x - l.box.min.x + 2 * pad) * (l.box.max.y - l.box.min.y + 2 * pad);
    const double share = std::min(1.0, reach * reach / std::max(area, 1e-12));
    visits += n * (held_now + n / 2) * share * cells;
    held_now += n;
    peak = std::max(peak, held_now);
    held.push({l.box.max.z, l.segments});
  }
  Estimate e;
  // Measured: 25,000 moves piled on one 10 mm span, 1.25e9 candidate visits in 1.35 s of CPU,
  // most of them the cheap ones (below the tip); one that tests the nozzle costs more: 5 ns.
  e.seconds = visits * 5e-9;
  e.bytes = peak * kBytesPerHeld;
  e.what = fmt::format(
      "replaying {} segments against the nozzle ({:.3g} candidate pairs, up to "
      "{:.3g} segments held)",
      o.segments, visits, peak);
  e.change = "the print (check it in parts: a layer range, or fewer paths)";
  return e;
}

// The replay, one layer at a time (the outline says what is still to come).
class Replay {
 public:
  Replay(const Graph& design, const CheckOptions& options, const PrintOutline& outline)
      : design_(design),
        options_(options),
        outline_(outline),
        snap_(design, options.snap),
        index_(std::max({outline.typical, 2 * options.nozzle.radius, 1e-3}),
               options.nozzle.radius) {
    c_.struts = design.edges.size();
    // A planar design (a 2D lattice, every node at one z) is printed layer by layer at the
    // layers' heights: each layer's segments are matched in the design's plane, and every strut
    // is due once per printed layer.
    planar_ = !design.nodes.empty() &&
              std::all_of(design.nodes.begin(), design.nodes.end(), [&](const Vec3& n) {
                return std::abs(n.z - design.nodes.front().z) <= 1e-9;
              });
    // A design of planar layers stacked (GIPPO parts of many layers: every strut level, as many
    // levels as printed layers): printed layer k is matched in the plane of level k, as a single
    // planar design is (the nozzle prints a layer one layer height above its design plane).
    const bool flat_struts = std::all_of(
        design.edges.begin(), design.edges.end(),
        [&](const Edge& e) { return std::abs(design.nodes[e.a].z - design.nodes[e.b].z) <= 1e-9; });
    if (!planar_ && flat_struts) {
      for (const Vec3& n : design.nodes) levels_.push_back(n.z);
      std::sort(levels_.begin(), levels_.end());
      levels_.erase(std::unique(levels_.begin(), levels_.end(),
                                [](double a, double b) { return std::abs(a - b) <= 1e-9; }),
                    levels_.end());
      if (levels_.size() != outline.printed_layers) levels_.clear();
    }
    strut_of_.reserve(design.edges.size() * 2);
    for (EdgeId e = 0; e < design.edges.size(); ++e)
      strut_of_[pair_key(design.edges[e].a, design.edges[e].b)] = e;
    times_.assign(design.edges.size(), 0);
  }

  void layer(std::size_t k, const Layer& layer) {
    if (k >= outline_.layers.size()) throw IoError("the print changed while it was checked");
    index_.drop_to(outline_.floor[k] + options_.nozzle.tip_clearance);
    std::vector<HeldIndex::Held> segs;
    for_segments(layer, [&](std::size_t p, std::size_t i, Vec3 a, Vec3 b) {
      HeldIndex::Held h;
      h.a = a, h.b = b, h.path = c_.paths + p, h.index = i;
      segs.push_back(h);
    });
    c_.paths += layer.paths.size();
    if (segs.size() != outline_.layers[k].segments)
      throw IoError("the print changed while it was checked");
    if (segs.empty()) return;
    match(segs, printed_++);
    for (auto& s : segs) {
      s.id = c_.segments++;
      replay(s);
      index_.insert(s);
    }
  }

  CollisionCheck finish() {
    if (printed_ != outline_.printed_layers)
      throw IoError("the print changed while it was checked");
    const int due = planar_ ? static_cast<int>(std::max<std::size_t>(printed_, 1)) : 1;
    for (EdgeId e = 0; e < design_.edges.size(); ++e) {
      if (times_[e] < due) c_.missing.push_back(e);  // planar: missing from some layer
      if (times_[e] > due) c_.repeated.push_back(e);
      if (times_[e] == due) ++c_.printed_once;
    }
    c_.peak_held = index_.peak();
    return std::move(c_);
  }

 private:
  static std::uint64_t pair_key(std::uint32_t a, std::uint32_t b) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
  }
  Vec3 in_plane(Vec3 p, std::size_t layer) const {
    if (planar_) p.z = design_.nodes.front().z;
    if (!levels_.empty()) p.z = levels_[layer];
    return p;
  }

  // A layer's segments matched to design struts by their end nodes; counted, steep ones checked.
  void match(std::vector<HeldIndex::Held>& segs, std::size_t layer) {
    for (auto& s : segs) {
      s.na = snap_.find(in_plane(s.a, layer));
      s.nb = snap_.find(in_plane(s.b, layer));
      if (s.na != kNone && s.nb != kNone)
        if (const auto it = strut_of_.find(pair_key(s.na, s.nb)); it != strut_of_.end())
          s.strut = it->second;
    }
    // A strut printed as a polyline (laid on a surface, its points between the two nodes at no
    // node): the run of a path's segments from node to node is that strut, printed once.
    std::vector<char> continued(segs.size(), 0);
    for (std::size_t i = 0; i < segs.size(); ++i) {
      if (segs[i].strut >= 0 || segs[i].na == kNone || segs[i].nb != kNone) continue;
      std::size_t j = i;
      while (segs[j].nb == kNone && j + 1 < segs.size() && segs[j + 1].path == segs[i].path) ++j;
      if (segs[j].nb != kNone)
        if (const auto it = strut_of_.find(pair_key(segs[i].na, segs[j].nb)); it != strut_of_.end())
          for (std::size_t k = i; k <= j; ++k) segs[k].strut = it->second, continued[k] = k > i;
      i = j;
    }
    for (std::size_t i = 0; i < segs.size(); ++i) {
      const auto& s = segs[i];
      if (s.strut < 0) {
        ++c_.off_design_segments;
        continue;
      }
      if (!continued[i]) ++times_[static_cast<std::size_t>(s.strut)];
      if (is_steep(s.a, s.b, options_.nozzle) && s.b.z < s.a.z)
        c_.top_down.push_back({s.path, static_cast<EdgeId>(s.strut)});
    }
  }

  // The tip's sweep along `s` against every held segment printed before it.
  void replay(const HeldIndex::Held& s) {
    const NozzleModel& nozzle = options_.nozzle;
    const double qz = std::min(s.a.z, s.b.z) + nozzle.tip_clearance;
    const double x0 = std::min(s.a.x, s.b.x) - nozzle.radius,
                 x1 = std::max(s.a.x, s.b.x) + nozzle.radius;
    const double y0 = std::min(s.a.y, s.b.y) - nozzle.radius,
                 y1 = std::max(s.a.y, s.b.y) + nozzle.radius;
    found_.clear();
    index_.for_candidates(s.a, s.b, [&](const HeldIndex::Held& t) {
      if (s.strut >= 0 && t.strut == s.strut) return;  // the same strut again: a repeat
      if (std::max(t.a.z, t.b.z) <= qz) return;
      if (std::max(t.a.x, t.b.x) < x0 || std::min(t.a.x, t.b.x) > x1 ||
          std::max(t.a.y, t.b.y) < y0 || std::min(t.a.y, t.b.y) > y1)
        return;
      ++c_.pairs_tested;
      Vec3 shared[2];
      int n = 0;
      if (t.na != kNone && (t.na == s.na || t.na == s.nb)) shared[n++] = design_.nodes[t.na];
      if (t.nb != kNone && (t.nb == s.na || t.nb == s.nb)) shared[n++] = design_.nodes[t.nb];
      Contact contact;
      if (!nozzle_hits(nozzle, s.a, s.b, t.a, t.b, shared, n, &contact)) return;
      found_.push_back(
          {t.id, {s.path, s.index, s.strut, t.strut, t.path, t.index, contact.tip, contact.point}});
    });
    std::sort(found_.begin(), found_.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [id, hit] : found_) {
      ++c_.collisions;
      if (c_.hits.size() < options_.max_listed) c_.hits.push_back(hit);
    }
  }

  const Graph& design_;
  const CheckOptions& options_;
  const PrintOutline& outline_;
  NodeSnap snap_;
  HeldIndex index_;
  bool planar_ = false;
  std::vector<double> levels_;
  std::unordered_map<std::uint64_t, EdgeId> strut_of_;
  std::vector<int> times_;
  std::size_t printed_ = 0;
  std::vector<std::pair<std::size_t, CollisionHit>> found_;
  CollisionCheck c_;
};

}  // namespace

CollisionCheck check_collisions(const Graph& design, const Toolpath& toolpath,
                                const CheckOptions& options) {
  return check_collisions(design, layers_of(toolpath), options);
}

CollisionCheck check_collisions(const Graph& design, const LayerSource& layers,
                                const CheckOptions& options) {
  options.nozzle.validate();
  if (!(options.snap > 0) || !std::isfinite(options.snap))
    throw SettingError("the snap distance must be positive");
  const PrintOutline outline = outline_of(layers);
  const double cell = std::max({outline.typical, 2 * options.nozzle.radius, 1e-3});
  check_budget(replay_estimate(outline, cell, options.nozzle.radius), options.budget);
  Replay replay(design, options, outline);
  layers([&](std::size_t k, const Layer& layer) { replay.layer(k, layer); });
  return replay.finish();
}

}  // namespace trellis
