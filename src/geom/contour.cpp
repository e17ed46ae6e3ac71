// Marching squares with bracketed root refinement, fuzzy segment stitching, ring nesting.
// Hand-written: the refinement needs the field itself (not a sampled image), and block skipping
// needs the field's interval bounds; no packaged contouring library does either.
#include "trellis/geom/contour.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>

namespace trellis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// This thread's instance of T, kept between calls (a nested call gets a fresh one). Slicers
// march thousands of layers; handing their buffers back to the allocator every time makes the
// heap shrink and regrow, and the page faults cost more than the marching.
template <class T>
class Lease {
 public:
  Lease() {
    Slot& s = slot();
    if (!s.busy) {
      s.busy = true;
      p_ = &s.value;
    } else {
      local_.emplace();
      p_ = &*local_;
    }
  }
  ~Lease() {
    if (!local_) slot().busy = false;
  }
  Lease(const Lease&) = delete;
  Lease& operator=(const Lease&) = delete;
  T& operator*() { return *p_; }
  T* operator->() { return p_; }

 private:
  struct Slot {
    T value;
    bool busy = false;
  };
  static Slot& slot() {
    thread_local Slot s;
    return s;
  }
  T* p_ = nullptr;
  std::optional<T> local_;
};

}  // namespace

// ---------------------------------------------------------------- stitching

namespace {

// Points within `tol` are one. Cells are 64 tolerances wide, so a point only looks into the
// neighbouring cells when it lies within `tol` of its cell's border (rarely).
class PointIndex {
 public:
  explicit PointIndex(double tol) : tol_(tol > 0 ? tol : 1e-12), inv_(1.0 / (64 * tol_)) {}
  std::size_t find_or_add(Vec2 p) {
    const double gx = p.x * inv_, gy = p.y * inv_;
    const double fx = std::floor(gx), fy = std::floor(gy);
    const auto cx = static_cast<std::int64_t>(fx), cy = static_cast<std::int64_t>(fy);
    constexpr double edge = 1.0 / 64;
    const int x0 = gx - fx < edge ? -1 : 0, x1 = gx - fx > 1 - edge ? 1 : 0;
    const int y0 = gy - fy < edge ? -1 : 0, y1 = gy - fy > 1 - edge ? 1 : 0;
    for (int dx = x0; dx <= x1; ++dx)
      for (int dy = y0; dy <= y1; ++dy) {
        auto it = cells_.find(key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (std::size_t v = it->second; v != kNone; v = next_[v])
          if (std::abs(points[v].x - p.x) <= tol_ && std::abs(points[v].y - p.y) <= tol_ &&
              std::hypot(points[v].x - p.x, points[v].y - p.y) <= tol_)
            return v;
      }
    const std::size_t id = points.size();
    points.push_back(p);
    auto [it, inserted] = cells_.try_emplace(key(cx, cy), id);
    next_.push_back(inserted ? kNone : it->second);
    if (!inserted) it->second = id;
    return id;
  }
  void reserve(std::size_t n) {
    points.reserve(n);
    next_.reserve(n);
    cells_.reserve(n);
  }
  std::vector<Vec2> points;

 private:
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  static std::uint64_t key(std::int64_t x, std::int64_t y) {
    return static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
           (static_cast<std::uint64_t>(y) + 0x632BE59BD9B4E019ull);
  }
  double tol_, inv_;
  std::unordered_map<std::uint64_t, std::size_t> cells_;
  std::vector<std::size_t> next_;
};

}  // namespace

namespace {

// Walks directed edges between numbered points into open chains and loops.
struct WalkBuffers {
  std::vector<std::size_t> start, in_degree, out, fill, cursor, out_degree;
  std::vector<char> used;
  std::vector<Vec2> line;  // the chain being walked (copied out at its size: one allocation)
};

// inner_at (if given): edge e's points inner[inner_at[e] .. inner_at[e + 1]), put between its
// ends.
StitchedLines walk_edges(const std::vector<Vec2>& points,
                         const std::vector<std::pair<std::size_t, std::size_t>>& edges,
                         const std::vector<std::size_t>* inner_at = nullptr,
                         const std::vector<Vec2>* inner = nullptr) {
  const std::size_t nv = points.size();
  Lease<WalkBuffers> buffers;
  // (Plain references, not a structured binding: lambdas below capture them, which clang
  // before 16 refuses for bindings.)
  WalkBuffers& wb = *buffers;
  auto &start = wb.start, &in_degree = wb.in_degree, &out = wb.out, &fill = wb.fill,
       &cursor = wb.cursor, &out_degree = wb.out_degree;
  auto& used = wb.used;
  // CSR of outgoing edges.
  start.assign(nv + 1, 0);
  in_degree.assign(nv, 0);
  for (auto [a, b] : edges) {
    ++start[a + 1];
    ++in_degree[b];
  }
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  out.resize(edges.size());
  fill.assign(start.begin(), start.end() - 1);
  for (std::size_t e = 0; e < edges.size(); ++e) out[fill[edges[e].first]++] = e;
  cursor.assign(start.begin(), start.end() - 1);
  used.assign(edges.size(), 0);

  auto next_edge = [&](std::size_t v) -> std::size_t {
    while (cursor[v] < start[v + 1]) {
      const std::size_t e = out[cursor[v]++];
      if (!used[e]) return e;
    }
    return static_cast<std::size_t>(-1);
  };
  // Points equal to the previous one (a crossing exactly at a grid node, reached from two
  // edges) are not repeated.
  auto push = [&](std::vector<Vec2>& line, Vec2 p) {
    if (line.empty() || line.back().x != p.x || line.back().y != p.y) line.push_back(p);
  };
  auto walk = [&](std::size_t from, std::vector<Vec2>& line) {
    push(line, points[from]);
    std::size_t v = from;
    for (;;) {
      const std::size_t e = next_edge(v);
      if (e == static_cast<std::size_t>(-1)) return v;
      used[e] = 1;
      v = edges[e].second;
      if (inner_at)
        for (std::size_t k = (*inner_at)[e]; k < (*inner_at)[e + 1]; ++k) push(line, (*inner)[k]);
      if (v == from) return v;
      push(line, points[v]);
    }
  };
  auto finish = [](std::vector<Vec2>& line, bool closed, StitchedLines& result) {
    if (closed && line.size() >= 2 && line.back().x == line.front().x &&
        line.back().y == line.front().y)
      line.pop_back();
    if (closed && line.size() >= 3)
      result.loops.emplace_back(line.begin(), line.end());
    else if (line.size() >= 2)
      result.open.emplace_back(line.begin(), line.end());
  };

  StitchedLines result;
  // Open chains start where more edges leave than arrive.
  out_degree.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) out_degree[v] = start[v + 1] - start[v];
  for (std::size_t v = 0; v < nv; ++v)
    while (out_degree[v] > in_degree[v] && cursor[v] < start[v + 1]) {
      std::vector<Vec2>& line = wb.line;
      line.clear();
      const std::size_t end = walk(v, line);
      --out_degree[v];
      ++in_degree[v];
      finish(line, end == v, result);
    }
  for (std::size_t v = 0; v < nv; ++v)
    while (cursor[v] < start[v + 1]) {
      std::vector<Vec2>& line = wb.line;
      line.clear();
      const std::size_t end = walk(v, line);
      finish(line, end == v, result);
    }
  return result;
}

}  // namespace

StitchedLines stitch_segments(const std::vector<Segment2>& segments, double tolerance) {
  PointIndex index(tolerance);
  index.reserve(segments.size() + 16);
  std::vector<std::pair<std::size_t, std::size_t>> edges;
  edges.reserve(segments.size());
  for (const auto& s : segments) {
    const std::size_t a = index.find_or_add(s.a), b = index.find_or_add(s.b);
    if (a != b) edges.emplace_back(a, b);
  }
  return walk_edges(index.points, edges);
}

// ---------------------------------------------------------------- marching squares

namespace {

// Grid edge -> crossing index: open addressing with linear probing (hand-written: a node-based
// std::unordered_map costs more than the lookups it serves here, one or two per crossing).
class EdgeTable {
 public:
  EdgeTable() : keys_(1024, kEmpty), values_(1024) {}
  void clear() {
    if (size_ > 0) std::fill(keys_.begin(), keys_.end(), kEmpty);
    size_ = 0;
  }
  // The value stored for key, inserting `value` if the key is new.
  std::size_t& find_or_insert(std::uint64_t key, std::size_t value) {
    if (2 * (size_ + 1) > keys_.size()) grow();
    std::size_t i = slot(key);
    while (keys_[i] != kEmpty && keys_[i] != key) i = (i + 1) & (keys_.size() - 1);
    if (keys_[i] == kEmpty) {
      keys_[i] = key;
      values_[i] = value;
      ++size_;
    }
    return values_[i];
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t slot(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  void grow() {
    std::vector<std::uint64_t> keys(keys_.size() * 2, kEmpty);
    std::vector<std::size_t> values(keys.size());
    keys.swap(keys_);
    values.swap(values_);
    --shift_;
    for (std::size_t k = 0; k < keys.size(); ++k) {
      if (keys[k] == kEmpty) continue;
      std::size_t i = slot(keys[k]);
      while (keys_[i] != kEmpty) i = (i + 1) & (keys_.size() - 1);
      keys_[i] = keys[k];
      values_[i] = values[k];
    }
  }
  std::vector<std::uint64_t> keys_;
  std::vector<std::size_t> values_;
  std::size_t size_ = 0;
  int shift_ = 64 - 10;  // 1024 slots
};

// A crossing being refined on the grid edge a→b (parameter t along it, bracket [t_lo, t_hi]).
struct Crossing {
  Vec2 a, b;
  double t_lo, t_hi, g_lo, g_hi, t;
  int side;
  double known;  // the function's own crossing (PlaneFunction::known_crossing), or −1
};

// One thread's marching buffers, reused from call to call (see Lease).
struct MarchBuffers {
  EdgeTable table;
  std::vector<Crossing> pending;
  std::vector<Vec2> crossings, pts, guesses;
  std::vector<double> val, guess_values;
  std::vector<unsigned char> sgn;
  std::vector<std::pair<std::size_t, std::size_t>> segments;
  std::vector<std::size_t> active;
  std::vector<std::uint64_t> edges;  // each pending crossing's edge key (for edge_crossings)
  std::vector<Vec2> mid_pts;         // segment midpoints' samples (segment_midpoints)
  std::vector<Vec2> inner;           // points inside segments (midpoints, translated chains)
  std::vector<std::size_t> inner_at;
  std::vector<double> mid_vals;
  std::vector<double> ts;
  std::vector<unsigned char> ok;
  void clear() {
    edges.clear();
    table.clear();
    pending.clear();
    crossings.clear();
    segments.clear();
  }
};

struct Marcher {
  PlaneFunction& f;
  Vec2 lo;
  double h, level;
  const MarchOptions& opt;
  std::size_t samples = 0;

  Vec2 node(std::size_t i, std::size_t j) const {
    return {lo.x + static_cast<double>(i) * h, lo.y + static_cast<double>(j) * h};
  }
  double eval(Vec2 p) {
    double v;
    f.sample(&p, &v, 1);
    ++samples;
    return v;
  }
  // Crossings on grid edges a→b (a the lower node) with values fa, fb on opposite sides of the
  // level, refined all together: each round samples the next guess of every unfinished crossing
  // in one batch (one call per round instead of one per guess; the same guesses as refining them
  // one by one). Illinois steps inside the bracket.
  std::vector<Crossing>& pending;
  void add(Vec2 a, Vec2 b, double fa, double fb, double guess, double known) {
    Crossing c{a, b, 0, 1, fa - level, fb - level, 0, 0, known};
    c.t = guess > 0 && guess < 1 ? guess : c.g_lo / (c.g_lo - c.g_hi);
    if (!std::isfinite(c.t)) c.t = 0.5;
    pending.push_back(c);
  }
  // out: the crossings; ts (if given): their parameters along their edges.
  void refine(std::vector<Vec2>& out, std::vector<std::size_t>& active, std::vector<Vec2>& pts,
              std::vector<double>& vals, std::vector<unsigned char>& ok, std::vector<double>* ts) {
    const double tol = opt.refine_fraction;  // in units of the edge length (= resolution)
    // Crossings the function already knows, checked in one batch: the confirmed ones are done.
    active.clear();
    for (std::size_t i = 0; i < pending.size(); ++i)
      if (pending[i].known > 0 && pending[i].known < 1) active.push_back(i);
    if (!active.empty()) {
      pts.resize(active.size());
      ok.resize(active.size());
      for (std::size_t k = 0; k < active.size(); ++k) {
        const Crossing& c = pending[active[k]];
        pts[k] = c.a + (c.b - c.a) * c.known;
      }
      f.confirm_crossings(pts.data(), pts.size(), ok.data());
      samples += pts.size();
      for (std::size_t k = 0; k < active.size(); ++k) {
        if (!ok[k]) continue;
        Crossing& c = pending[active[k]];
        c.t = c.t_lo = c.t_hi = c.known;
      }
      active.clear();
    }
    for (std::size_t i = 0; i < pending.size(); ++i)
      if (pending[i].t_hi - pending[i].t_lo > tol) active.push_back(i);
    for (int it = 0; it < opt.max_refine_iterations && !active.empty(); ++it) {
      pts.resize(active.size());
      vals.resize(active.size());
      for (std::size_t k = 0; k < active.size(); ++k) {
        const Crossing& c = pending[active[k]];
        pts[k] = c.a + (c.b - c.a) * c.t;
      }
      f.sample(pts.data(), vals.data(), pts.size());
      samples += pts.size();
      std::size_t keep = 0;
      for (std::size_t k = 0; k < active.size(); ++k) {
        Crossing& c = pending[active[k]];
        const double g = vals[k] - level;
        if (std::abs(g) <= opt.value_tolerance || !std::isfinite(g)) continue;
        if ((g < 0) == (c.g_lo < 0)) {
          c.t_lo = c.t;
          c.g_lo = g;
          if (c.side == -1) c.g_hi *= 0.5;  // Illinois: the retained end stalls, halve its value
          c.side = -1;
        } else {
          c.t_hi = c.t;
          c.g_hi = g;
          if (c.side == 1) c.g_lo *= 0.5;
          c.side = 1;
        }
        double next = (c.t_lo * c.g_hi - c.t_hi * c.g_lo) / (c.g_hi - c.g_lo);
        if (!(next > c.t_lo && next < c.t_hi)) next = 0.5 * (c.t_lo + c.t_hi);
        // Converged when the step is far below the tolerance: take it and stop.
        const bool converged = std::abs(next - c.t) < 0.25 * tol;
        c.t = next;
        if (!converged && c.t_hi - c.t_lo > tol) active[keep++] = active[k];
      }
      active.resize(keep);
    }
    out.resize(pending.size());
    for (std::size_t i = 0; i < pending.size(); ++i)
      out[i] = pending[i].a + (pending[i].b - pending[i].a) * pending[i].t;
    if (ts) {
      ts->resize(pending.size());
      for (std::size_t i = 0; i < pending.size(); ++i) (*ts)[i] = pending[i].t;
    }
    pending.clear();
  }
};

}  // namespace

double crossing_guess(double before, double fa, double fb, double after) {
  // The polynomial p(s) through (0, fa), (1, fb) and the neighbours (−1, before), (2, after)
  // that exist: p = fa + b·s + c·s² + d·s³.
  const bool has_before = std::isfinite(before), has_after = std::isfinite(after);
  if (!has_before && !has_after) return -1;
  double c, d = 0;
  if (has_before && has_after) {
    d = (-before + 3 * fa - 3 * fb + after) / 6;
    c = (before - 2 * fa + fb) / 2;
  } else if (has_before) {
    c = (before - 2 * fa + fb) / 2;
  } else {
    c = (fa - 2 * fb + after) / 2;
  }
  const double b = fb - fa - c - d;
  // Newton steps from the straight line's root, kept only if they stay inside the edge.
  // (Usually two or three steps; at most six.)
  double t = fa / (fa - fb);
  for (int it = 0; it < 6; ++it) {
    const double p = fa + t * (b + t * (c + t * d)), dp = b + t * (2 * c + 3 * t * d);
    const double step = p / dp;
    t -= step;
    if (!(t > 0 && t < 1)) return -1;
    if (std::abs(step) < 1e-9) break;
  }
  return t;
}

namespace {
// A tile's lines for translation (see march_squares): chains from a crossing on the block's
// edge to another, with the points between, and loops inside the block; in the block's own
// terms (node relative to its first node, points relative to that node's position).
struct TileEnd {
  std::uint16_t i, jv;  // jv: j · 2 + (the edge is vertical); tiles are under 32,768 cells a side
  float t;  // (float: a crossing's parameter to 6e-8 of its edge, far inside the refinement)
  std::size_t j() const { return jv >> 1; }
  bool vertical() const { return (jv & 1) != 0; }
};
struct TileChain {
  TileEnd from, to;
  std::uint32_t begin, end;  // its points in the tile's pts
};
// Points relative to the block's first node: floats (a block is well under 1 mm: 1e-8 mm).
struct TilePoint {
  float x, y;
};
struct TileLines {
  std::vector<TileChain> chains;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> loops;  // ranges of pts
  std::vector<TilePoint> pts;
  void add(Vec2 p, Vec2 origin) {
    pts.push_back({static_cast<float>(p.x - origin.x), static_cast<float>(p.y - origin.y)});
  }
  static Vec2 at(Vec2 origin, TilePoint q) { return {origin.x + q.x, origin.y + q.y}; }
  std::uint32_t size() const { return static_cast<std::uint32_t>(pts.size()); }
  std::size_t bytes() const {
    return chains.capacity() * sizeof(TileChain) + loops.capacity() * sizeof(loops[0]) +
           pts.capacity() * sizeof(TilePoint);
  }
};
}  // namespace

// One period's tiles (see march_squares), by place: the lines as chains (whole blocks take
// them) and the segments one chain each, ordered by cell (blocks along a boundary take them by
// cells). All tiles' in one array each (kept for many layers: a few arrays, not a few per tile):
// tile t's chains are lines.chains[chain_at[t] .. chain_at[t + 1]), its loops likewise
// (loop_at); the segments of row r of its cells are cells.chains[row_at[t · (by + 1) + r] ..
// row_at[t · (by + 1) + r + 1]), by column, chain k's column col[k].
struct PeriodTileData {
  std::size_t px = 0, py = 0, bx = 0, by = 0;  // the period and the tile side, in cells
  TileLines lines, cells;
  std::vector<std::uint32_t> chain_at, loop_at, row_at;
  std::vector<std::uint16_t> col;
  std::size_t bytes() const {
    return sizeof(*this) + lines.bytes() + cells.bytes() +
           (chain_at.capacity() + loop_at.capacity() + row_at.capacity()) * sizeof(std::uint32_t) +
           col.capacity() * sizeof(std::uint16_t);
  }
};

std::size_t period_cells(double period, double h) {
  if (!(period > 0) || !std::isfinite(period)) return 0;
  const double r = period / h, c = std::round(r);
  return c >= 1 && std::abs(r - c) <= 1e-6 * c ? static_cast<std::size_t>(c) : 0;
}

std::size_t period_tile_side(std::size_t p, std::size_t tile_block) {
  const std::size_t want = std::max<std::size_t>(tile_block, 1);
  auto off = [&](std::size_t d) {
    const double r = static_cast<double>(d) / static_cast<double>(want);
    return std::max(r, 1 / r);
  };
  std::size_t best = 0;
  for (std::size_t d = std::min<std::size_t>(4, want); d <= 4 * want; ++d)
    if (p % d == 0 && (best == 0 || off(d) < off(best))) best = d;
  return best ? best : (p <= 4 * want ? p : 0);
}

PeriodTiles point_reflected_tiles(const PeriodTiles& tiles, double h, std::size_t sx,
                                  std::size_t sy, bool reverse) {
  if (!tiles.data) return {};
  const PeriodTileData& S = *tiles.data;
  if (S.bx == 0 || S.by == 0 || sx % S.bx != 0 || sy % S.by != 0) return {};
  const std::size_t nax = S.px / S.bx, nby = S.py / S.by, ntiles = nax * nby;
  if (S.chain_at.size() != ntiles + 1 || S.loop_at.size() != ntiles + 1 ||
      S.row_at.size() != ntiles * (S.by + 1))
    return {};
  auto made = std::make_shared<PeriodTileData>();
  PeriodTileData& D = *made;
  D.px = S.px, D.py = S.py, D.bx = S.bx, D.by = S.by;
  D.chain_at.resize(ntiles + 1);
  D.loop_at.resize(ntiles + 1);
  D.row_at.resize(ntiles * (S.by + 1));
  D.col.reserve(S.col.size());
  for (TileLines* l : {&D.lines, &D.cells}) {
    const TileLines& from = l == &D.lines ? S.lines : S.cells;
    l->chains.reserve(from.chains.size());
    l->loops.reserve(from.loops.size());
    l->pts.reserve(from.pts.size());
  }
  // Block-local terms: node (i, j) goes to (bx − i, by − j), so a horizontal edge from (i, j)
  // to (i + 1, j) runs back along the one from (bx − i − 1, by − j), at 1 − t; a point (x, y)
  // goes to (bx·h − x, by·h − y).
  const double wx = static_cast<double>(S.bx) * h, wy = static_cast<double>(S.by) * h;
  auto end = [&](const TileEnd& e) {
    const std::size_t i = e.vertical() ? S.bx - e.i : S.bx - 1 - e.i;
    const std::size_t j = e.vertical() ? S.by - 1 - e.j() : S.by - e.j();
    return TileEnd{static_cast<std::uint16_t>(i),
                   static_cast<std::uint16_t>(j << 1 | (e.vertical() ? 1 : 0)), 1.0f - e.t};
  };
  auto point = [&](TilePoint q) {
    return TilePoint{static_cast<float>(wx - static_cast<double>(q.x)),
                     static_cast<float>(wy - static_cast<double>(q.y))};
  };
  auto points = [&](const TileLines& from, std::uint32_t b, std::uint32_t e, TileLines& to) {
    if (reverse)
      for (std::uint32_t k = e; k-- > b;) to.pts.push_back(point(from.pts[k]));
    else
      for (std::uint32_t k = b; k < e; ++k) to.pts.push_back(point(from.pts[k]));
  };
  auto chain = [&](const TileLines& from, const TileChain& c, TileLines& to) {
    const std::uint32_t begin = to.size();
    points(from, c.begin, c.end, to);
    to.chains.push_back(reverse ? TileChain{end(c.to), end(c.from), begin, to.size()}
                                : TileChain{end(c.from), end(c.to), begin, to.size()});
  };
  const std::size_t mx = sx / S.bx, my = sy / S.by;
  for (std::size_t t = 0; t < ntiles; ++t) {
    // Tile (a, b) covers nodes a·bx .. (a + 1)·bx, which come from s − (a + 1)·bx .. s − a·bx.
    const std::size_t a = t % nax, b = t / nax;
    const std::size_t u = ((my + nby - 1 - b) % nby) * nax + (mx + nax - 1 - a) % nax;
    D.chain_at[t] = static_cast<std::uint32_t>(D.lines.chains.size());
    D.loop_at[t] = static_cast<std::uint32_t>(D.lines.loops.size());
    for (std::uint32_t n = S.chain_at[u]; n < S.chain_at[u + 1]; ++n)
      chain(S.lines, S.lines.chains[n], D.lines);
    for (std::uint32_t n = S.loop_at[u]; n < S.loop_at[u + 1]; ++n) {
      const auto [lb, le] = S.lines.loops[n];
      const std::uint32_t begin = D.lines.size();
      points(S.lines, lb, le, D.lines);
      D.lines.loops.emplace_back(begin, D.lines.size());
    }
    // The cells' segments by row, each row by column: rows and columns both run backwards.
    const std::uint32_t* from_row = S.row_at.data() + u * (S.by + 1);
    for (std::size_t r = 0; r < S.by; ++r) {
      D.row_at[t * (S.by + 1) + r] = static_cast<std::uint32_t>(D.cells.chains.size());
      const std::size_t fr = S.by - 1 - r;
      for (std::uint32_t c = from_row[fr + 1]; c-- > from_row[fr];) {
        D.col.push_back(static_cast<std::uint16_t>(S.bx - 1 - S.col[c]));
        chain(S.cells, S.cells.chains[c], D.cells);
      }
    }
    D.row_at[t * (S.by + 1) + S.by] = static_cast<std::uint32_t>(D.cells.chains.size());
  }
  D.chain_at[ntiles] = static_cast<std::uint32_t>(D.lines.chains.size());
  D.loop_at[ntiles] = static_cast<std::uint32_t>(D.lines.loops.size());
  return {made, made->bytes()};
}

namespace {

// One call of march_squares, as named steps (run): the grid's top blocks marched or skipped by
// their bounds (march_top_blocks, visit, march_block), the crossings refined, the segments'
// midpoints (add_midpoints), the periodic tiles made (make_tiles) and the blocks of each tile's
// place taken from them (replay_tiles), then the walk.
class SquareMarch {
 public:
  SquareMarch(PlaneFunction& f, Vec2 lo, Vec2 hi, double level, const MarchOptions& options,
              MarchBuffers& buffers);
  ContourSet run();

 private:
  struct Block {
    std::size_t i, j, ci, cj;
  };
  // A tile: the block marched for its place in the period, and its segments.
  struct Tile {
    bool marched = false;
    std::size_t bi = 0, bj = 0, s0 = 0, s1 = 0;
  };
  struct Replay {
    std::size_t bi, bj, tile;
  };

  void march_block(std::size_t bi, std::size_t bj, std::size_t ci, std::size_t cj);
  Interval bound(const Block& k) {
    return f_.bound(m_.node(k.i, k.j), m_.node(k.i + k.ci, k.j + k.cj));
  }
  bool excluded(const Interval& r) const { return r.lo >= level_ || r.hi < level_; }
  void visit(const Block& k, const Interval& range);
  std::size_t tile_of(std::size_t i, std::size_t j) const {  // the tile of cell (i, j)'s place
    return ((j % py_) / by_) * (px_ / bx_) + (i % px_) / bx_;
  }
  void march_top_blocks();
  void march_periodic_parts();
  void add_midpoints();
  std::size_t crossing_on(std::size_t i, std::size_t j, bool vertical, double t);
  void make_tiles();
  void take_chain(std::size_t bi, std::size_t bj, const TileLines& L, const TileChain& c);
  void replay_tiles(const PeriodTileData* D);
  void report_edge_crossings();

  PlaneFunction& f_;
  const double h_, level_;
  const MarchOptions& options_;
  MarchBuffers& buf_;
  Marcher m_;
  ContourSet result_;
  // Every crossing lies on one grid edge and is refined once, whichever block asks for it;
  // segments join crossings by edge, so stitching is exact (no distance tolerance).
  EdgeTable& table_;
  std::vector<Vec2>& crossings_;
  std::vector<std::pair<std::size_t, std::size_t>>& segments_;
  // Points inside each segment, put between its ends by the walk: inner_[inner_at_[e] ..
  // inner_at_[e + 1]) (a midpoint each, or a translated tile's chain of points).
  std::vector<Vec2>& inner_;
  std::vector<std::size_t>& inner_at_;
  std::vector<double>* ts_ = nullptr;  // the crossings' parameters, when keep_keys_
  std::size_t nx_, ny_, row_;
  // Periodic tiles (PlaneFunction::period): px_ x py_ cells, tiles of bx_ x by_ (the top blocks
  // when tiling_, else they are options.block).
  std::size_t px_, py_, bx_, by_;
  bool tiling_, keep_keys_;
  // Blocks smaller than a tile where the function is periodic (along the envelope, where a
  // tile-sized block would cross it): marched at the end by their cells, from the tiles'.
  std::vector<Block> periodic_parts_;
  bool defer_periodic_ = false;  // while marching the top blocks, when tiling
  std::size_t ntiles_;
  std::vector<Tile> tiles_;
  const PeriodTileData* given_ = nullptr;  // another march's tiles, when they fit this one
  std::vector<Replay> replays_;            // whole blocks to take from their tile
  std::shared_ptr<PeriodTileData> made_;   // this march's tiles
};

SquareMarch::SquareMarch(PlaneFunction& f, Vec2 lo, Vec2 hi, double level,
                         const MarchOptions& options, MarchBuffers& buffers)
    : f_(f),
      h_(options.resolution),
      level_(level),
      options_(options),
      buf_(buffers),
      m_{f, lo, options.resolution, level, options, 0, buffers.pending},
      table_(buffers.table),
      crossings_(buffers.crossings),
      segments_(buffers.segments),
      inner_(buffers.inner),
      inner_at_(buffers.inner_at) {
  nx_ = static_cast<std::size_t>(std::ceil((hi.x - lo.x) / h_ - 1e-9));
  ny_ = static_cast<std::size_t>(std::ceil((hi.y - lo.y) / h_ - 1e-9));
  row_ = nx_ + 1;
  // Periodic tiles (PlaneFunction::period): top blocks that divide the period, one block per
  // place in the period marched (its "tile"), the others where the function is periodic
  // translated from it after refinement.
  const Vec2 period = options.periodic_tiles ? f.period() : Vec2{0, 0};
  // A block side dividing the period: the divisor in 4..4·tile_block closest to tile_block by
  // ratio, else the period if it is that small; else no tiles. (By ratio: a period of 125 cells
  // and 13 wanted takes 25, not 5; blocks much smaller than wanted cost the most.)
  px_ = period_cells(period.x, h_), py_ = period_cells(period.y, h_);
  const std::size_t tx = px_ ? period_tile_side(px_, options.tile_block) : 0;
  const std::size_t ty = py_ ? period_tile_side(py_, options.tile_block) : 0;
  tiling_ = tx > 0 && ty > 0 && tx < 32768 && ty < 32768;  // (TileEnd)
  const std::size_t B = std::max<std::size_t>(options.block, 1);
  bx_ = tiling_ ? tx : B, by_ = tiling_ ? ty : B;
  keep_keys_ = tiling_ || options.edge_crossings;
  ntiles_ = tiling_ ? (px_ / bx_) * (py_ / by_) : 0;
  tiles_.resize(ntiles_);
  // Another march's tiles, when they fit this one (every place's, the same period and side).
  if (tiling_ && options.tiles_in && options.tiles_in->data) {
    const PeriodTileData& d = *options.tiles_in->data;
    if (d.px == px_ && d.py == py_ && d.bx == bx_ && d.by == by_ &&
        d.chain_at.size() == ntiles_ + 1 && d.row_at.size() == ntiles_ * (by_ + 1))
      given_ = &d;
  }
}

// Marches the cells [bi, bi+ci) x [bj, bj+cj): samples its nodes, refines its crossings.
void SquareMarch::march_block(std::size_t bi, std::size_t bj, std::size_t ci, std::size_t cj) {
  std::vector<Vec2>& pts = buf_.pts;
  std::vector<double>& val = buf_.val;
  std::vector<unsigned char>& sgn = buf_.sgn;  // node inside (below the level)
  const double h = h_, level = level_;
  const std::size_t w = ci + 1, hgt = cj + 1;
  pts.resize(w * hgt);
  val.resize(w * hgt);
  for (std::size_t j = 0; j < hgt; ++j)
    for (std::size_t i = 0; i < w; ++i) pts[j * w + i] = m_.node(bi + i, bj + j);
  f_.sample_grid(pts[0], h, w, hgt, pts.data(), val.data());
  m_.samples += pts.size();
  sgn.resize(w * hgt);
  for (std::size_t k = 0; k < w * hgt; ++k) sgn[k] = val[k] < level;
  // Crossing on the edge from local node (i, j) to (i + 1, j) (horizontal) or (i, j + 1).
  auto cross = [&](std::size_t i, std::size_t j, bool vertical) {
    const std::uint64_t key =
        (((bj + j) * row_ + (bi + i)) << 1) | static_cast<std::uint64_t>(vertical);
    std::size_t& slot = table_.find_or_insert(key, m_.pending.size());
    if (slot == m_.pending.size()) {
      if (keep_keys_) buf_.edges.push_back(key);
      const std::size_t a = j * w + i, b = vertical ? a + w : a + 1;
      double guess = -1;
      if (options_.cubic_guess) {
        // The nodes before a and after b on the edge's line, where the block has them.
        const std::size_t pos = vertical ? j : i, len = vertical ? hgt : w, step = vertical ? w : 1;
        const double before = pos > 0 ? val[a - step] - level : kNaN;
        const double after = pos + 2 < len ? val[b + step] - level : kNaN;
        guess = crossing_guess(before, val[a] - level, val[b] - level, after);
      }
      m_.add(pts[a], pts[b], val[a], val[b], guess,
             f_.known_crossing(bi + i, bj + j, vertical, val[a], val[b]));
    }
    return slot;
  };
  for (std::size_t j = 0; j < cj; ++j)
    for (std::size_t i = 0; i < ci; ++i) {
      // Corners counter-clockwise: v0 (i,j), v1 (i+1,j), v2 (i+1,j+1), v3 (i,j+1).
      const std::size_t a0 = j * w + i;
      const unsigned code = sgn[a0] | sgn[a0 + 1] << 1 | sgn[a0 + w + 1] << 2 | sgn[a0 + w] << 3;
      if (code == 0 || code == 15) continue;  // no crossing (most cells)
      const bool in[4] = {sgn[a0] != 0, sgn[a0 + 1] != 0, sgn[a0 + w + 1] != 0, sgn[a0 + w] != 0};
      // Walk the cell boundary counter-clockwise; record crossings and their direction.
      std::size_t ids[4];
      bool leaving[4];  // inside -> outside along the walk
      int n = 0;
      for (int e = 0; e < 4; ++e) {
        const int a = e, b = (e + 1) % 4;
        if (in[a] == in[b]) continue;
        std::size_t id;
        switch (e) {
          case 0:
            id = cross(i, j, false);
            break;
          case 1:
            id = cross(i + 1, j, true);
            break;
          case 2:
            id = cross(i, j + 1, false);
            break;
          default:
            id = cross(i, j, true);
            break;
        }
        ids[n] = id;
        leaving[n] = in[a];
        ++n;
      }
      if (n == 2) {
        const int s = leaving[0] ? 0 : 1;
        segments_.emplace_back(ids[s], ids[1 - s]);
      } else if (n == 4) {
        const Vec2 c = pts[j * w + i] + Vec2{h * 0.5, h * 0.5};
        const bool center_in = m_.eval(c) < level;
        for (int k = 0; k < 4; ++k) {
          if (!leaving[k]) continue;
          const int other = center_in ? (k + 1) % 4 : (k + 3) % 4;
          segments_.emplace_back(ids[k], ids[other]);
        }
      }
    }
}

// Blocks whose bound excludes the level are skipped; others split down to small leaves, so a
// narrow-band or loosely bounded field still skips most of the plane. `range` is the block's
// bound, computed once by the caller (a block reaching here is not periodic, or not to be taken
// from the tiles).
void SquareMarch::visit(const Block& k, const Interval& range) {
  if (excluded(range)) {
    ++result_.skipped_blocks;
    return;
  }
  const std::size_t leaf = std::min<std::size_t>(4, std::max<std::size_t>(options_.block, 1));
  const bool bounded = std::isfinite(range.lo) || std::isfinite(range.hi);
  if (!bounded || (k.ci <= leaf && k.cj <= leaf)) {
    march_block(k.i, k.j, k.ci, k.cj);
    return;
  }
  const std::size_t hi = (k.ci + 1) / 2, hj = (k.cj + 1) / 2;
  Block parts[4];
  int np = 0;
  parts[np++] = {k.i, k.j, hi, hj};
  if (k.ci > hi) parts[np++] = {k.i + hi, k.j, k.ci - hi, hj};
  if (k.cj > hj) parts[np++] = {k.i, k.j + hj, hi, k.cj - hj};
  if (k.ci > hi && k.cj > hj) parts[np++] = {k.i + hi, k.j + hj, k.ci - hi, k.cj - hj};
  Interval ranges[4];
  bool any_skippable = false;
  // Quarters taken from the tiles need no bound (one the bound would skip has no segments).
  Vec2 plo[4], phi[4];
  bool periodic[4] = {false, false, false, false};
  int bounded_parts[4], nb = 0;
  Vec2 blo[4], bhi[4];
  for (int q = 0; q < np; ++q) {
    plo[q] = m_.node(parts[q].i, parts[q].j);
    phi[q] = m_.node(parts[q].i + parts[q].ci, parts[q].j + parts[q].cj);
    periodic[q] = defer_periodic_ && f_.periodic(plo[q], phi[q]);
    any_skippable = any_skippable || periodic[q];
    if (!periodic[q]) {
      blo[nb] = plo[q];
      bhi[nb] = phi[q];
      bounded_parts[nb++] = q;
    }
  }
  f_.prefetch_bounds(blo, bhi, static_cast<std::size_t>(nb));
  for (int b = 0; b < nb; ++b) {
    const int q = bounded_parts[b];
    ranges[q] = bound(parts[q]);
    any_skippable = any_skippable || excluded(ranges[q]);
  }
  // If no quarter can be skipped (or taken from the tiles), march the block whole: splitting
  // would only sample the shared edges twice (a surface everywhere, like a TPMS sheet).
  if (!any_skippable) {
    march_block(k.i, k.j, k.ci, k.cj);
    return;
  }
  for (int q = 0; q < np; ++q) {
    if (periodic[q])
      periodic_parts_.push_back(parts[q]);
    else
      visit(parts[q], ranges[q]);
  }
}

// The top blocks in rows: where the function is periodic, a tile's place is marched once (the
// block marks its tile) and its other blocks are left to replay_tiles.
void SquareMarch::march_top_blocks() {
  defer_periodic_ = tiling_;
  for (std::size_t bj = 0; bj < ny_; bj += by_)
    for (std::size_t bi = 0; bi < nx_; bi += bx_) {
      ++result_.blocks;
      const Block top{bi, bj, std::min(bx_, nx_ - bi), std::min(by_, ny_ - bj)};
      if (tiling_ && f_.periodic(m_.node(bi, bj), m_.node(bi + top.ci, bj + top.cj))) {
        if (top.ci < bx_ || top.cj < by_) {  // a part block at the grid's end
          periodic_parts_.push_back(top);
          continue;
        }
        const std::size_t t = tile_of(bi, bj);
        if (given_ || tiles_[t].marched) {
          replays_.push_back({bi, bj, t});
          ++result_.tiled_blocks;
          continue;
        }
        tiles_[t] = {true, bi, bj, segments_.size(), 0};
        defer_periodic_ = false;
        visit(top, bound(top));
        defer_periodic_ = true;
        tiles_[t].s1 = segments_.size();
        continue;
      }
      visit(top, bound(top));
    }
  defer_periodic_ = false;
}

// Periodic parts (each inside one top block, so one tile's place) whose tile was marched are
// taken from it (replay_tiles); the others are marched.
void SquareMarch::march_periodic_parts() {
  std::size_t kept = 0;
  for (const Block& k : periodic_parts_) {
    if (given_ || tiles_[tile_of(k.i, k.j)].marched)
      periodic_parts_[kept++] = k;
    else
      visit(k, bound(k));
  }
  periodic_parts_.resize(kept);
  result_.tiled_parts = kept;
}

// Segment midpoints: the middle of each segment moved onto the level by a Newton step along the
// segment's normal (a forward difference: two batches of values; the curve between two crossings
// a cell apart is nearly parallel to its chord, so the normal is nearly the gradient's
// direction), at most a quarter of the segment; one within midpoint_min_offset of its segment
// adds nothing and is dropped.
void SquareMarch::add_midpoints() {
  const std::size_t n = segments_.size();
  constexpr double dh = 1e-6;
  std::vector<Vec2>& mp = buf_.mid_pts;
  std::vector<double>& mv = buf_.mid_vals;
  mp.resize(2 * n);
  mv.resize(2 * n);
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2 a = crossings_[segments_[k].first], b = crossings_[segments_[k].second];
    const Vec2 c = (a + b) * 0.5, d = b - a;
    const double len = std::sqrt(d.x * d.x + d.y * d.y);
    const Vec2 normal = len > 0 ? Vec2{-d.y / len, d.x / len} : Vec2{0, 0};
    mp[k] = c;
    mp[n + k] = c + normal * dh;
  }
  if (n > 0) f_.sample(mp.data(), mv.data(), 2 * n);
  m_.samples += 2 * n;
  const double keep2 = options_.midpoint_min_offset * options_.midpoint_min_offset;
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2 a = crossings_[segments_[k].first], b = crossings_[segments_[k].second];
    const Vec2 d = b - a;
    const double len = std::sqrt(d.x * d.x + d.y * d.y);
    const double fv = mv[k] - level_, slope = (mv[n + k] - mv[k]) / dh;
    const double along = slope != 0 ? std::clamp(-fv / slope, -0.25 * len, 0.25 * len) : 0;
    const Vec2 mid = len > 0 ? mp[k] + Vec2{-d.y / len, d.x / len} * along : mp[k];
    const Vec2 q = mid - a;
    const double cr = d.x * q.y - d.y * q.x;
    if (!(cr * cr <= keep2 * (d.x * d.x + d.y * d.y))) inner_.push_back(mid);
    inner_at_[k + 1] = inner_.size();
  }
}

// The crossing on grid edge (i, j, vertical) at parameter t along it, unless the edge has one
// (marched by a neighbour, or translated for one): for the lines translated from the tiles.
std::size_t SquareMarch::crossing_on(std::size_t i, std::size_t j, bool vertical, double t) {
  const std::uint64_t key = ((j * row_ + i) << 1) | static_cast<std::uint64_t>(vertical);
  const std::size_t id = table_.find_or_insert(key, crossings_.size());
  if (id == crossings_.size()) {
    const Vec2 a = m_.node(i, j), b = vertical ? m_.node(i, j + 1) : m_.node(i + 1, j);
    crossings_.push_back(a + (b - a) * t);
    buf_.edges.push_back(key);
    ts_->push_back(t);
  }
  return id;
}

// This march's tiles as lines: each tile's lines as chains, from a crossing where a line enters
// the block to the one where it leaves (on the block's edges, in the block's own terms: node
// relative to its first, edge direction, parameter along the edge), with the crossings and
// midpoints between them relative to the block's first node; lines closed inside the block as
// loops. Every other block of the tile's place takes them translated: its chains' ends are
// looked up by grid edge (an edge that already has a crossing, marched by a neighbour or
// translated for one, keeps it), so the lines join as in one march, and only the ends are
// stitched. (A tile where a crossing would start two segments is taken segment by segment.)
// Blocks along a boundary take a tile's segments by cells, each its own chain.
void SquareMarch::make_tiles() {
  const bool exporting = options_.tiles_out != nullptr;
  const std::size_t Bx = bx_, By = by_, ntiles = ntiles_;
  made_ = std::make_shared<PeriodTileData>();
  PeriodTileData& D = *made_;
  D.px = px_, D.py = py_, D.bx = Bx, D.by = By;
  D.chain_at.assign(ntiles + 1, 0);
  D.loop_at.assign(ntiles + 1, 0);
  D.row_at.assign(ntiles * (By + 1), 0);
  TileLines& T = D.lines;
  const std::size_t nc = crossings_.size();
  std::vector<std::size_t> out_seg(nc), stamp_out(nc, 0), stamp_in(nc, 0);
  std::vector<char> used(segments_.size(), 0);
  std::vector<char> wants_cells(ntiles, exporting);
  for (const Block& k : periodic_parts_) wants_cells[tile_of(k.i, k.j)] = 1;
  std::vector<std::uint32_t> seg_slot, at, fill;  // (reused by the tiles)
  std::vector<std::size_t> order;
  const auto& segments = segments_;
  for (std::size_t t = 0; t < ntiles; ++t) {
    D.chain_at[t] = static_cast<std::uint32_t>(T.chains.size());
    D.loop_at[t] = static_cast<std::uint32_t>(T.loops.size());
    const Tile& tile = tiles_[t];
    if (!tile.marched) continue;
    const Vec2 o = m_.node(tile.bi, tile.bj);
    auto end_of = [&](std::size_t id) {
      const std::uint64_t e = buf_.edges[id], node = e >> 1;
      return TileEnd{static_cast<std::uint16_t>(node % row_ - tile.bi),
                     static_cast<std::uint16_t>((node / row_ - tile.bj) << 1 | (e & 1)),
                     static_cast<float>((*ts_)[id])};
    };
    auto add_inner = [&](TileLines& L, std::size_t e) {
      for (std::size_t k = inner_at_[e]; k < inner_at_[e + 1]; ++k) L.add(inner_[k], o);
    };
    // Segment e as a chain of its own.
    auto add_segment = [&](TileLines& L, std::size_t e) {
      const std::uint32_t begin = L.size();
      add_inner(L, e);
      L.chains.push_back({end_of(segments[e].first), end_of(segments[e].second), begin, L.size()});
    };
    if (wants_cells[t]) {
      // The cell both a segment's crossings' edges bound (an edge's two cells differ, so one of
      // a's is b's), counted per cell, then the segments in that order.
      auto cells_of = [&](std::size_t id) {
        const std::uint64_t e = buf_.edges[id], node = e >> 1;
        const std::size_t i = node % row_, j = node / row_;
        return (e & 1) != 0 ? std::array<std::size_t, 4>{i - 1, j, i, j}
                            : std::array<std::size_t, 4>{i, j - 1, i, j};
      };
      at.assign(Bx * By + 1, 0);
      seg_slot.clear();
      for (std::size_t e = tile.s0; e < tile.s1; ++e) {
        const auto a = cells_of(segments[e].first), b = cells_of(segments[e].second);
        const bool first = (a[0] == b[0] && a[1] == b[1]) || (a[0] == b[2] && a[1] == b[3]);
        const std::size_t li = (first ? a[0] : a[2]) - tile.bi;
        const std::size_t lj = (first ? a[1] : a[3]) - tile.bj;
        seg_slot.push_back(static_cast<std::uint32_t>(lj * Bx + li));
        ++at[lj * Bx + li + 1];
      }
      for (std::size_t c = 1; c <= Bx * By; ++c) at[c] += at[c - 1];
      order.resize(seg_slot.size());
      fill.assign(at.begin(), at.end() - 1);
      for (std::size_t k = 0; k < seg_slot.size(); ++k) order[fill[seg_slot[k]]++] = k;
      TileLines& C = D.cells;
      const auto base = static_cast<std::uint32_t>(C.chains.size());
      for (std::size_t r = 0; r <= By; ++r) D.row_at[t * (By + 1) + r] = base + at[r * Bx];
      for (const std::size_t k : order) {
        D.col.push_back(static_cast<std::uint16_t>(seg_slot[k] % Bx));
        add_segment(C, tile.s0 + k);
      }
    }
    if (!exporting && replays_.empty()) continue;
    const std::size_t mark = t + 1;
    bool chainable = true;
    for (std::size_t e = tile.s0; e < tile.s1; ++e) {
      const auto [from, to] = segments[e];
      chainable = chainable && stamp_out[from] != mark && stamp_in[to] != mark;
      stamp_out[from] = mark;
      stamp_in[to] = mark;
      out_seg[from] = e;
    }
    if (!chainable) {
      for (std::size_t e = tile.s0; e < tile.s1; ++e) add_segment(T, e);
      continue;
    }
    for (std::size_t e0 = tile.s0; e0 < tile.s1; ++e0) {
      const std::size_t start = segments[e0].first;
      if (stamp_in[start] == mark) continue;  // not where a line enters the block
      const std::uint32_t begin = T.size();
      std::size_t v = start;
      while (stamp_out[v] == mark) {
        const std::size_t e = out_seg[v];
        used[e] = 1;
        add_inner(T, e);
        v = segments[e].second;
        if (stamp_out[v] == mark) T.add(crossings_[v], o);
      }
      T.chains.push_back({end_of(start), end_of(v), begin, T.size()});
    }
    for (std::size_t e0 = tile.s0; e0 < tile.s1; ++e0) {
      if (used[e0]) continue;
      const std::size_t start = segments[e0].first;
      const std::uint32_t begin = T.size();
      std::size_t v = start;
      do {
        const std::size_t e = out_seg[v];
        used[e] = 1;
        T.add(crossings_[v], o);
        add_inner(T, e);
        v = segments[e].second;
      } while (v != start && stamp_out[v] == mark && !used[out_seg[v]]);
      T.loops.emplace_back(begin, T.size());
    }
  }
  D.chain_at[ntiles] = static_cast<std::uint32_t>(T.chains.size());
  D.loop_at[ntiles] = static_cast<std::uint32_t>(T.loops.size());
  if (exporting) {
    // Made only where every place was marched (the rectangle one period, periodic throughout).
    bool all = true;
    for (const Tile& tile : tiles_) all = all && tile.marched;
    if (all) {
      for (TileLines* l : {&D.lines, &D.cells}) {
        l->chains.shrink_to_fit();
        l->loops.shrink_to_fit();
        l->pts.shrink_to_fit();
      }
      D.col.shrink_to_fit();
      *options_.tiles_out = {made_, made_->bytes()};
    }
  }
}

// A tile's chain taken by the block whose first node is (bi, bj): its ends found or added by
// grid edge, its points translated.
void SquareMarch::take_chain(std::size_t bi, std::size_t bj, const TileLines& L,
                             const TileChain& c) {
  auto end_at = [&](const TileEnd& x) {
    return crossing_on(bi + x.i, bj + x.j(), x.vertical(), static_cast<double>(x.t));
  };
  segments_.emplace_back(end_at(c.from), end_at(c.to));
  const Vec2 o = m_.node(bi, bj);
  for (std::size_t k = c.begin; k < c.end; ++k) inner_.push_back(TileLines::at(o, L.pts[k]));
  inner_at_.push_back(inner_.size());
}

// The blocks of a marched place (`D`: this march's tiles or the ones given) taken from it.
void SquareMarch::replay_tiles(const PeriodTileData* D) {
  // Whole blocks take their tile's chains, translated by whole periods.
  static const TileLines kNoLines;
  const TileLines& T = D ? D->lines : kNoLines;
  for (const Replay& r : replays_)
    for (std::size_t n = D->chain_at[r.tile]; n < D->chain_at[r.tile + 1]; ++n)
      take_chain(r.bi, r.bj, T, T.chains[n]);
  // Blocks along a boundary take the segments of their cells' rows.
  for (const Block& k : periodic_parts_) {
    const std::size_t t = tile_of(k.i, k.j);
    const TileLines& C = D->cells;
    const std::uint32_t* row_at = D->row_at.data() + t * (by_ + 1);
    const std::vector<std::uint16_t>& col = D->col;
    const std::size_t li = (k.i % px_) % bx_, lj = (k.j % py_) % by_;
    const std::size_t oi = k.i - li, oj = k.j - lj;  // the first node of its top block
    for (std::size_t r = lj; r < lj + k.cj; ++r)
      for (auto c = static_cast<std::size_t>(
               std::lower_bound(col.begin() + row_at[r], col.begin() + row_at[r + 1], li) -
               col.begin());
           c < row_at[r + 1] && col[c] < li + k.ci; ++c)
        take_chain(oi, oj, C, C.chains[c]);
  }
  // Loops inside a tile are edges from a point of their own back to it, after every crossing
  // with a grid edge (ids past those edge_crossings reports), so the walk closes them.
  for (const Replay& r : replays_) {
    const Vec2 o = m_.node(r.bi, r.bj);
    for (std::size_t n = D->loop_at[r.tile]; n < D->loop_at[r.tile + 1]; ++n) {
      const auto [begin, end] = T.loops[n];
      const std::size_t id = crossings_.size();
      crossings_.push_back(TileLines::at(o, T.pts[begin]));
      segments_.emplace_back(id, id);
      for (std::size_t k = begin + 1; k < end; ++k) inner_.push_back(TileLines::at(o, T.pts[k]));
      inner_at_.push_back(inner_.size());
    }
  }
}

void SquareMarch::report_edge_crossings() {
  options_.edge_crossings->resize(ts_->size());
  for (std::size_t k = 0; k < ts_->size(); ++k) {
    const std::uint64_t e = buf_.edges[k], node = e >> 1;
    (*options_.edge_crossings)[k] = {node % row_, node / row_, (e & 1) != 0, (*ts_)[k]};
  }
}

ContourSet SquareMarch::run() {
  march_top_blocks();
  march_periodic_parts();
  ts_ = keep_keys_ ? &buf_.ts : nullptr;
  m_.refine(crossings_, buf_.active, buf_.guesses, buf_.guess_values, buf_.ok, ts_);
  inner_.clear();
  inner_at_.assign(segments_.size() + 1, 0);
  if (options_.segment_midpoints) add_midpoints();
  const bool exporting = options_.tiles_out != nullptr;
  if (!given_ && tiling_ && (exporting || !replays_.empty() || !periodic_parts_.empty()))
    make_tiles();
  if (exporting) {
    result_.samples = m_.samples;
    return std::move(result_);
  }
  replay_tiles(given_ ? given_ : made_.get());
  if (options_.edge_crossings) report_edge_crossings();
  result_.samples = m_.samples;
  result_.lines = walk_edges(crossings_, segments_, &inner_at_, &inner_);
  return std::move(result_);
}

}  // namespace

ContourSet march_squares(PlaneFunction& f, Vec2 lo, Vec2 hi, double level,
                         const MarchOptions& options) {
  const double h = options.resolution;
  if (!(h > 0) || !(hi.x > lo.x) || !(hi.y > lo.y)) return {};
  Lease<MarchBuffers> buffers;
  buffers->clear();
  return SquareMarch(f, lo, hi, level, options, *buffers).run();
}

}  // namespace trellis
