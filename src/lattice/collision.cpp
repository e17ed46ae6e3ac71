#include "trellis/lattice/collision.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "trellis/core/error.hpp"

namespace trellis {

void NozzleModel::validate() const {
  auto check = [](bool ok, const char* what) {
    if (!ok) throw SettingError(what);
  };
  check(std::isfinite(radius) && radius > 0 && radius < 1000,
        "nozzle radius must be in (0, 1000) mm");
  check(std::isfinite(tip_clearance) && tip_clearance >= 0 && tip_clearance < 1000,
        "tip clearance must be in [0, 1000) mm");
  check(std::isfinite(node_clearance) && node_clearance >= 0 && node_clearance < 1000,
        "node clearance must be in [0, 1000) mm");
  check(std::isfinite(cone_half_angle_deg) && cone_half_angle_deg >= 0 && cone_half_angle_deg <= 90,
        "cone half-angle must be in [0, 90] degrees");
  check(std::isfinite(end_overlap) && end_overlap >= 0 && end_overlap < 100,
        "end overlap must be in [0, 100) mm");
}

bool is_steep(Vec3 a, Vec3 b, const NozzleModel& nozzle) {
  const Vec3 d = b - a;
  const double len = norm(d);
  if (len <= 0) return false;
  return std::abs(d.z) >=
         len * std::cos(nozzle.cone_half_angle_deg * std::numbers::pi / 180) - 1e-12;
}

namespace {

struct P2 {
  double t, w;
};

// Parameter intervals of the printed segment that are not exempt.
int allowed_intervals(Vec3 pa, Vec3 pb, const Vec3* shared, int n_shared, double clearance,
                      double (*out)[2]) {
  int n = 1;
  out[0][0] = 0;
  out[0][1] = 1;
  if (clearance <= 0) return n;
  const Vec3 d = pb - pa;
  const double dd = dot(d, d);
  for (int k = 0; k < n_shared; ++k) {
    const Vec3 f = pa - shared[k];
    // |f + t d|^2 < c^2
    double t1, t2;
    if (dd <= 0) {
      if (dot(f, f) >= clearance * clearance) continue;
      return 0;
    }
    const double b = dot(f, d) / dd, c = (dot(f, f) - clearance * clearance) / dd;
    const double disc = b * b - c;
    if (disc <= 0) continue;
    const double r = std::sqrt(disc);
    t1 = -b - r;
    t2 = -b + r;
    double next[4][2];
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const double lo = out[i][0], hi = out[i][1];
      if (t2 <= lo || t1 >= hi) {
        next[m][0] = lo;
        next[m++][1] = hi;
        continue;
      }
      if (t1 > lo) {
        next[m][0] = lo;
        next[m++][1] = t1;
      }
      if (t2 < hi) {
        next[m][0] = t2;
        next[m++][1] = hi;
      }
    }
    n = std::min(m, 3);
    for (int i = 0; i < n; ++i) {
      out[i][0] = next[i][0];
      out[i][1] = next[i][1];
    }
    if (n == 0) return 0;
  }
  return n;
}

}  // namespace

bool nozzle_hits(const NozzleModel& nozzle, Vec3 qa, Vec3 qb, Vec3 pa, Vec3 pb, const Vec3* shared,
                 int n_shared, Contact* contact) {
  const double R = nozzle.radius, tc = nozzle.tip_clearance;
  // Quick rejections: height and footprint.
  if (std::max(pa.z, pb.z) - std::min(qa.z, qb.z) <= tc) return false;
  if (std::min(pa.x, pb.x) - std::max(qa.x, qb.x) >= R ||
      std::min(qa.x, qb.x) - std::max(pa.x, pb.x) >= R ||
      std::min(pa.y, pb.y) - std::max(qa.y, qb.y) >= R ||
      std::min(qa.y, qb.y) - std::max(pa.y, pb.y) >= R)
    return false;
  double intervals[3][2];
  const int n_int = allowed_intervals(pa, pb, shared, n_shared, nozzle.node_clearance, intervals);
  // D(t, w) = |A + t U - w V|^2 in XY; height h(t, w) = pa.z + t Uz - qa.z - w Vz - tc >= 0.
  const double Ax = pa.x - qa.x, Ay = pa.y - qa.y;
  const double Ux = pb.x - pa.x, Uy = pb.y - pa.y, Uz = pb.z - pa.z;
  const double Vx = qb.x - qa.x, Vy = qb.y - qa.y, Vz = qb.z - qa.z;
  auto h = [&](P2 p) { return pa.z + p.t * Uz - qa.z - p.w * Vz - tc; };
  const double R2 = R * R;
  for (int k = 0; k < n_int; ++k) {
    const double t0 = intervals[k][0], t1 = intervals[k][1];
    // Clip the box [t0,t1]x[0,1] to h >= 0 (one Sutherland-Hodgman pass).
    const P2 box[4] = {{t0, 0}, {t1, 0}, {t1, 1}, {t0, 1}};
    P2 poly[5];
    int n = 0;
    for (int i = 0; i < 4; ++i) {
      const P2 a = box[i], b = box[(i + 1) % 4];
      const double ha = h(a), hb = h(b);
      if (ha >= 0) poly[n++] = a;
      if ((ha >= 0) != (hb >= 0)) {
        const double s = ha / (ha - hb);
        poly[n++] = {a.t + s * (b.t - a.t), a.w + s * (b.w - a.w)};
      }
    }
    if (n == 0) continue;
    double best = std::numeric_limits<double>::infinity();
    P2 arg{};
    auto consider = [&](P2 p) {
      const double fx = Ax + p.t * Ux - p.w * Vx, fy = Ay + p.t * Uy - p.w * Vy;
      const double d = fx * fx + fy * fy;
      if (d < best) {
        best = d;
        arg = p;
      }
    };
    for (int i = 0; i < n; ++i) {
      const P2 a = poly[i], b = poly[(i + 1) % n];
      const double fx = Ax + a.t * Ux - a.w * Vx, fy = Ay + a.t * Uy - a.w * Vy;
      const double dt = b.t - a.t, dw = b.w - a.w;
      const double gx = dt * Ux - dw * Vx, gy = dt * Uy - dw * Vy;
      const double gg = gx * gx + gy * gy;
      double s = gg > 0 ? -(fx * gx + fy * gy) / gg : 0;
      s = std::clamp(s, 0.0, 1.0);
      consider({a.t + s * dt, a.w + s * dw});
    }
    // Interior stationary point (the XY lines cross) if the quadratic is strictly convex.
    const double uu = Ux * Ux + Uy * Uy, vv = Vx * Vx + Vy * Vy, uv = Ux * Vx + Uy * Vy;
    const double det = uu * vv - uv * uv;
    if (det > 1e-12 * uu * vv && det > 0) {
      const double ua = Ux * Ax + Uy * Ay, va = Vx * Ax + Vy * Ay;
      // [uu -uv; -uv vv] [t; w] = [-ua; va]
      const P2 p{(-ua * vv + uv * va) / det, (uu * va - uv * ua) / det};
      if (p.t >= t0 && p.t <= t1 && p.w >= 0 && p.w <= 1 && h(p) >= 0) consider(p);
    }
    if (best < R2 * (1 - 1e-12)) {
      if (contact) {
        contact->point = pa + (pb - pa) * arg.t;
        contact->tip = qa + (qb - qa) * arg.w;
      }
      return true;
    }
  }
  return false;
}

void FootprintIndex::range(Vec3 a, Vec3 b, double pad, int& ix0, int& ix1, int& iy0,
                           int& iy1) const {
  auto cx = [&](double x) { return std::clamp(static_cast<int>((x - x0_) / cell_), 0, nx_ - 1); };
  auto cy = [&](double y) { return std::clamp(static_cast<int>((y - y0_) / cell_), 0, ny_ - 1); };
  ix0 = cx(std::min(a.x, b.x) - pad);
  ix1 = cx(std::max(a.x, b.x) + pad);
  iy0 = cy(std::min(a.y, b.y) - pad);
  iy1 = cy(std::max(a.y, b.y) + pad);
}

double FootprintIndex::visits() const {
  double v = 0;
  for (std::size_t c = 0; c + 1 < offsets_.size(); ++c) {
    const double n = double(offsets_[c + 1] - offsets_[c]);
    v += n * n;
  }
  return v;
}

FootprintIndex::FootprintIndex(const std::vector<Vec3>& ends, double pad) {
  count_ = ends.size() / 2;
  BBox3 box;
  std::vector<double> extents;
  extents.reserve(count_);
  for (std::size_t i = 0; i < count_; ++i) {
    box.add(ends[2 * i]);
    box.add(ends[2 * i + 1]);
    const Vec3 d = ends[2 * i + 1] - ends[2 * i];
    extents.push_back(std::max(std::abs(d.x), std::abs(d.y)));
  }
  if (box.empty()) box.add({});
  double typical = 0;
  if (!extents.empty()) {
    std::nth_element(extents.begin(),
                     extents.begin() + static_cast<std::ptrdiff_t>(extents.size() / 2),
                     extents.end());
    typical = extents[extents.size() / 2];
  }
  const double w = box.max.x - box.min.x + 2 * pad, h = box.max.y - box.min.y + 2 * pad;
  double cell = std::max({typical, 2 * pad, 1e-6});
  const double max_cells = 4.0 * static_cast<double>(count_) + 16;
  while ((w / cell + 1) * (h / cell + 1) > max_cells) cell *= 1.5;
  cell_ = cell;
  x0_ = box.min.x - pad;
  y0_ = box.min.y - pad;
  nx_ = static_cast<int>(w / cell) + 1;
  ny_ = static_cast<int>(h / cell) + 1;
  const std::size_t cells = static_cast<std::size_t>(nx_) * ny_;
  offsets_.assign(cells + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<std::uint32_t> fill;
    if (pass == 1) {
      for (std::size_t i = 1; i <= cells; ++i) offsets_[i] += offsets_[i - 1];
      items_.resize(offsets_[cells]);
      fill.assign(offsets_.begin(), offsets_.end() - 1);
    }
    for (std::size_t s = 0; s < count_; ++s) {
      int ix0, ix1, iy0, iy1;
      range(ends[2 * s], ends[2 * s + 1], pad, ix0, ix1, iy0, iy1);
      for (int iy = iy0; iy <= iy1; ++iy)
        for (int ix = ix0; ix <= ix1; ++ix) {
          const std::size_t c = static_cast<std::size_t>(iy) * nx_ + ix;
          if (pass == 0)
            ++offsets_[c + 1];
          else
            items_[fill[c]++] = static_cast<std::uint32_t>(s);
        }
    }
  }
}

namespace {

StrutLists to_lists(const std::vector<std::vector<EdgeId>>& lists) {
  StrutLists out;
  out.offsets.assign(lists.size() + 1, 0);
  for (std::size_t i = 0; i < lists.size(); ++i)
    out.offsets[i + 1] = out.offsets[i] + static_cast<std::uint32_t>(lists[i].size());
  out.items.reserve(out.offsets.back());
  for (const auto& l : lists) out.items.insert(out.items.end(), l.begin(), l.end());
  return out;
}

}  // namespace

BlockingGraph blocking_graph(const Graph& g, const NozzleModel& nozzle, int threads) {
  nozzle.validate();
  const std::size_t m = g.edges.size();
  // Struts as printed: extended by the end overlap at both ends.
  std::vector<Vec3> ends;
  ends.reserve(2 * m);
  for (const auto& e : g.edges) {
    Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
    const double len = distance(a, b);
    if (nozzle.end_overlap > 0 && len > 0) {
      const Vec3 d = (b - a) * (nozzle.end_overlap / len);
      a = a - d;
      b = b + d;
    }
    ends.push_back(a);
    ends.push_back(b);
  }
  const FootprintIndex index(ends, nozzle.radius);
  // blockers[u]: struts s that obstruct u's nozzle if printed before it.
  std::vector<std::vector<EdgeId>> blockers(m);
  struct Scratch {
    std::vector<std::uint32_t> stamp;
    std::uint32_t tick = 0;
    std::size_t tested = 0;
  };
  tbb::enumerable_thread_specific<Scratch> scratch([&] {
    Scratch s;
    s.stamp.assign(m, 0);
    return s;
  });
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m, 64), [&](const auto& r) {
      Scratch& sc = scratch.local();
      for (std::size_t ui = r.begin(); ui != r.end(); ++ui) {
        const auto u = static_cast<EdgeId>(ui);
        const Edge& eu = g.edges[u];
        const Vec3 qa = ends[2 * u], qb = ends[2 * u + 1];
        const double qz = std::min(qa.z, qb.z) + nozzle.tip_clearance;
        if (++sc.tick == 0) {
          std::fill(sc.stamp.begin(), sc.stamp.end(), 0);
          sc.tick = 1;
        }
        index.for_candidates(qa, qb, sc.stamp, sc.tick, [&](std::uint32_t s) {
          if (s == u) return;
          const Edge& es = g.edges[s];
          const Vec3 pa = ends[2 * s], pb = ends[2 * s + 1];
          if (std::max(pa.z, pb.z) <= qz) return;
          ++sc.tested;
          Vec3 shared[2];
          int n = 0;
          if (es.a == eu.a || es.a == eu.b) shared[n++] = g.nodes[es.a];
          if (es.b == eu.a || es.b == eu.b) shared[n++] = g.nodes[es.b];
          if (nozzle_hits(nozzle, qa, qb, pa, pb, shared, n)) blockers[u].push_back(s);
        });
        std::sort(blockers[u].begin(), blockers[u].end());
      }
    });
  });
  std::vector<std::vector<EdgeId>> blocks(m);
  for (EdgeId u = 0; u < m; ++u)
    for (EdgeId s : blockers[u]) blocks[s].push_back(u);
  BlockingGraph out;
  out.blocks = to_lists(blocks);
  out.blocked_by = to_lists(blockers);
  for (const auto& s : scratch) out.pairs_tested += s.tested;
  return out;
}

}  // namespace trellis
