// Nodes of the field tree: primitives, CSG, transforms, TPMS, user functions, material grades.
// Hand-written because the kernel is small and the slicers need batch evaluation and interval
// bounds, which general SDF libraries (OpenVDB works on grids, not trees) do not give.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numbers>
#include <unordered_map>

#include "expr_program.hpp"
#include "node.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

// ---------------------------------------------------------------- state and defaults

std::vector<double>& EvalState::value_buffer(std::size_t depth, std::size_t n) {
  if (values.size() <= depth) values.resize(depth + 1);
  auto& b = values[depth];
  if (b.size() < n) b.resize(n);
  return b;
}
std::vector<Vec3>& EvalState::grid_point_buffer(std::size_t depth, std::size_t n) {
  if (grid_points.size() <= depth) grid_points.resize(depth + 1);
  auto& b = grid_points[depth];
  if (b.size() < n) b.resize(n);
  return b;
}
std::vector<Vec3>& EvalState::point_buffer(std::size_t depth, std::size_t n) {
  if (points.size() <= depth) points.resize(depth + 1);
  auto& b = points[depth];
  if (b.size() < n) b.resize(n);
  return b;
}
int EvalState::material_index(const std::string& name) const {
  if (!materials) return -1;
  for (std::size_t i = 0; i < materials->size(); ++i)
    if ((*materials)[i] == name) return static_cast<int>(i);
  return -1;
}

namespace {

// sqrt(x² + y²) without std::hypot's overflow care (5× faster; our coordinates are ≤ 1e6 mm).
inline double len2(double x, double y) {
  return std::sqrt(x * x + y * y);
}

double half_diagonal(const BBox3& b) {
  return 0.5 * norm(b.max - b.min);
}
BBox3 box_of(Vec3 lo, Vec3 hi) {
  BBox3 b;
  b.add(lo);
  b.add(hi);
  return b;
}
BBox3 infinite_box() {
  return box_of({-kInf, -kInf, -kInf}, {kInf, kInf, kInf});
}
// Exact signed distance to an axis-aligned box of half sizes h centred at c.
// The box SDF from q_i = |p_i − c_i| − h_i.
double box_sdf_q(double qx, double qy, double qz) {
  // Inside on every axis the root term is √0 = 0: skipped (the same value).
  if (qx <= 0 && qy <= 0 && qz <= 0) return 0.0 + std::max({qx, qy, qz});
  const double ox = std::max(qx, 0.0), oy = std::max(qy, 0.0), oz = std::max(qz, 0.0);
  return std::sqrt(ox * ox + oy * oy + oz * oz) + std::min(std::max({qx, qy, qz}), 0.0);
}
double box_sdf(Vec3 p, Vec3 c, Vec3 h) {
  return box_sdf_q(std::abs(p.x - c.x) - h.x, std::abs(p.y - c.y) - h.y, std::abs(p.z - c.z) - h.z);
}
// Interval of the box SDF over a query box, exact: the SDF is non-decreasing in each
// q_i = |p_i − c_i| − h_i, and the query box holds the points where every q_i is least (the
// nearest coordinate on each axis) and where every one is greatest (the farthest).
Interval box_sdf_bound(const BBox3& q, Vec3 c, Vec3 h) {
  auto axis = [](double lo, double hi, double c, double h, double& qlo, double& qhi) {
    lo -= c;
    hi -= c;
    qlo = (lo > 0 ? lo : (hi < 0 ? -hi : 0.0)) - h;
    qhi = std::max(std::abs(lo), std::abs(hi)) - h;
  };
  double xl, xh, yl, yh, zl, zh;
  axis(q.min.x, q.max.x, c.x, h.x, xl, xh);
  axis(q.min.y, q.max.y, c.y, h.y, yl, yh);
  axis(q.min.z, q.max.z, c.z, h.z, zl, zh);
  return {box_sdf_q(xl, yl, zl), box_sdf_q(xh, yh, zh)};
}

}  // namespace

Interval FieldNode::bound(const BBox3& box, EvalState& s, std::size_t depth) const {
  const double L = lipschitz();
  if (!std::isfinite(L)) return {-kInf, kInf};
  const double v = value(box.center(), s, depth);
  const double hd = half_diagonal(box);
  return {v - L * hd, v + L * hd};
}

void FieldNode::fractions(Vec3 p, double* out, EvalState& s, std::size_t depth) const {
  if (!material.empty()) {
    const int i = s.material_index(material);
    if (i >= 0) out[i] = 1.0;
    return;
  }
  if (!children.empty()) children.front()->fractions(p, out, s, depth + 1);
}

void FieldNode::fractions(const Vec3* p, std::size_t n, std::size_t m, double* out, EvalState& s,
                          std::size_t depth) const {
  for (std::size_t i = 0; i < n; ++i) fractions(p[i], out + i * m, s, depth);
}

void FieldNode::eval_grid(const GridPlane& g, double* out, EvalState& s, std::size_t depth) const {
  std::vector<Vec3>& p = s.grid_point_buffer(depth, g.size());
  for (std::size_t j = 0; j < g.rows; ++j)
    for (std::size_t i = 0; i < g.w; ++i) p[j * g.w + i] = {g.xs[i], g.ys[j], g.z};
  eval(p.data(), out, g.size(), s, depth);
}

namespace {
BBox3 grid_box(const GridPlane& g) {
  BBox3 b;
  double x0 = g.xs[0], x1 = g.xs[0], y0 = g.ys[0], y1 = g.ys[0];
  for (std::size_t i = 1; i < g.w; ++i) x0 = std::min(x0, g.xs[i]), x1 = std::max(x1, g.xs[i]);
  for (std::size_t j = 1; j < g.rows; ++j) y0 = std::min(y0, g.ys[j]), y1 = std::max(y1, g.ys[j]);
  b.add({x0, y0, g.z});
  b.add({x1, y1, g.z});
  return b;
}
}  // namespace

bool FieldNode::has_expressions() const {
  for (const auto& c : children)
    if (c->has_expressions()) return true;
  return false;
}

void FieldNode::own_materials(std::vector<std::string>& table) const {
  if (!material.empty() && std::find(table.begin(), table.end(), material) == table.end())
    table.push_back(material);
}

void FieldNode::collect_materials(std::vector<std::string>& table) const {
  std::vector<const FieldNode*> todo{this};  // depth first, children in order
  while (!todo.empty()) {
    const FieldNode* n = todo.back();
    todo.pop_back();
    n->own_materials(table);
    for (auto c = n->children.rbegin(); c != n->children.rend(); ++c) todo.push_back(c->get());
  }
}

namespace {

// ---------------------------------------------------------------- primitives

template <class F>
struct PointwiseNode : FieldNode {
  void eval(const Vec3* p, double* out, std::size_t n, EvalState&, std::size_t) const override {
    const auto& self = static_cast<const F&>(*this);
    for (std::size_t i = 0; i < n; ++i) out[i] = self.at(p[i]);
  }
};

struct SphereNode : PointwiseNode<SphereNode> {
  bool exact_outside() const override { return true; }
  double r;
  explicit SphereNode(double r_) : r(r_) {}
  double at(Vec3 p) const { return norm(p) - r; }
  BBox3 extent() const override { return box_of({-r, -r, -r}, {r, r, r}); }
  Interval bound(const BBox3& b, EvalState&, std::size_t) const override {
    // Exact: nearest and farthest points of the box from the origin.
    auto axis = [](double lo, double hi, double& near, double& far) {
      near = (lo > 0) ? lo : (hi < 0 ? -hi : 0.0);
      far = std::max(std::abs(lo), std::abs(hi));
    };
    double nx, fx, ny, fy, nz, fz;
    axis(b.min.x, b.max.x, nx, fx);
    axis(b.min.y, b.max.y, ny, fy);
    axis(b.min.z, b.max.z, nz, fz);
    return {std::sqrt(nx * nx + ny * ny + nz * nz) - r, std::sqrt(fx * fx + fy * fy + fz * fz) - r};
  }
};

struct BoxNode : PointwiseNode<BoxNode> {
  bool exact_outside() const override { return true; }
  Vec3 h;
  explicit BoxNode(Vec3 size) : h(size * 0.5) {}
  double at(Vec3 p) const { return box_sdf(p, {}, h); }
  Interval bound(const BBox3& b, EvalState&, std::size_t) const override {
    return box_sdf_bound(b, {}, h);
  }
  BBox3 extent() const override { return box_of(h * -1.0, h); }
};

struct CylinderNode : PointwiseNode<CylinderNode> {
  bool exact_outside() const override { return true; }
  double r, hh;
  CylinderNode(double r_, double h_) : r(r_), hh(h_ / 2) {}
  double at(Vec3 p) const {
    const double dx = len2(p.x, p.y) - r, dy = std::abs(p.z) - hh;
    const double ox = std::max(dx, 0.0), oy = std::max(dy, 0.0);
    return std::min(std::max(dx, dy), 0.0) + std::sqrt(ox * ox + oy * oy);
  }
  BBox3 extent() const override { return box_of({-r, -r, -hh}, {r, r, hh}); }
};

// Capped cone, base radius r at z = -h/2, tip at z = +h/2; exact distance (after I. Quilez).
struct ConeNode : PointwiseNode<ConeNode> {
  bool exact_outside() const override { return true; }
  double r, hh;
  ConeNode(double r_, double h_) : r(r_), hh(h_ / 2) {}
  double at(Vec3 p) const {
    const double qx = len2(p.x, p.y), qy = p.z;
    const double k1x = 0, k1y = hh, k2x = -r, k2y = 2 * hh;
    const double cax = qx - std::min(qx, qy < 0 ? r : 0.0), cay = std::abs(qy) - hh;
    const double t =
        std::clamp(((k1x - qx) * k2x + (k1y - qy) * k2y) / (k2x * k2x + k2y * k2y), 0.0, 1.0);
    const double cbx = qx - k1x + k2x * t, cby = qy - k1y + k2y * t;
    const double s = (cbx < 0 && cay < 0) ? -1.0 : 1.0;
    return s * std::sqrt(std::min(cax * cax + cay * cay, cbx * cbx + cby * cby));
  }
  BBox3 extent() const override { return box_of({-r, -r, -hh}, {r, r, hh}); }
};

struct TorusNode : PointwiseNode<TorusNode> {
  bool exact_outside() const override { return true; }
  double R, r;
  TorusNode(double R_, double r_) : R(R_), r(r_) {}
  double at(Vec3 p) const { return len2(len2(p.x, p.y) - R, p.z) - r; }
  BBox3 extent() const override { return box_of({-R - r, -R - r, -r}, {R + r, R + r, r}); }
};

// f(x,y,z) cut to a box: max(f, box distance).
struct FunctionNode : FieldNode {
  Vec3 lo, hi;
  Expression expr;
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s, std::size_t) const override {
    auto& c = s.expr(expr);
    const Vec3 center = (lo + hi) * 0.5, half = (hi - lo) * 0.5;
    for (std::size_t i = 0; i < n; ++i)
      out[i] = std::max(c.eval(p[i]), box_sdf(p[i], center, half));
  }
  Interval bound(const BBox3& b, EvalState&, std::size_t) const override {
    // Outside the box the value is at least the box distance; inside nothing is known.
    const Interval bi = box_sdf_bound(b, (lo + hi) * 0.5, (hi - lo) * 0.5);
    return {bi.lo, kInf};
  }
  double lipschitz() const override { return kInf; }
  BBox3 extent() const override { return box_of(lo, hi); }
  bool has_expressions() const override { return true; }
};

// ---------------------------------------------------------------- TPMS

// sin and cos together for |x| < 1e6: quadrant reduction with a two-part π/2 and Taylor
// polynomials on [−π/4, π/4] (error below 3e-14), the quadrant picked by selects rather than
// branches, so scattered arguments do not mispredict and a loop of it vectorises.
[[gnu::always_inline]] inline void sincos_moderate(double x, double* sn, double* cs) {
  constexpr double two_over_pi = 0.63661977236758134308;
  constexpr double p1 = 1.57079632673412561417;      // π/2 high part
  constexpr double p2 = 6.07710050650619224932e-11;  // π/2 − p1
  // Round to nearest by the 1.5·2^52 trick (std::nearbyint is a libm call without SSE4.1);
  // exact for |x·2/π| < 2^51.
  constexpr double magic = 6755399441055744.0;
  const double k = (x * two_over_pi + magic) - magic;  // (no -ffast-math: not folded)
  const double r = (x - k * p1) - k * p2;
  const double r2 = r * r;
  const double s =
      r *
      (1 + r2 * (-1.0 / 6 +
                 r2 * (1.0 / 120 + r2 * (-1.0 / 5040 +
                                         r2 * (1.0 / 362880 + r2 * (-1.0 / 39916800 +
                                                                    r2 * (1.0 / 6227020800.0)))))));
  const double c =
      1 + r2 * (-0.5 + r2 * (1.0 / 24 +
                             r2 * (-1.0 / 720 + r2 * (1.0 / 40320 +
                                                      r2 * (-1.0 / 3628800 +
                                                            r2 * (1.0 / 479001600.0 +
                                                                  r2 * (-1.0 / 87178291200.0)))))));
  const int q = static_cast<int>(k);
  const double a = (q & 1) ? c : s, b = (q & 1) ? s : c;
  *sn = (q & 2) ? -a : a;
  *cs = ((q + 1) & 2) ? -b : b;
}

// sin and cos together, for the moderate arguments of TPMS; three times faster than libm's
// sincos, whose full-range reduction TPMS evaluation does not need.
[[gnu::always_inline]] inline void fast_sincos(double x, double* sn, double* cs) {
  if (!(std::abs(x) < 1e6)) {  // far outside any part (or NaN): libm's full reduction
    *sn = std::sin(x);
    *cs = std::cos(x);
    return;
  }
  sincos_moderate(x, sn, cs);
}

// Sines and cosines of n values. Cloned for x86-64-v3 (AVX2 + FMA: about 1 ns a value instead
// of 3) with a baseline fallback chosen at load time; hand-written because libm has no batch
// sincos.
__attribute__((target_clones("arch=x86-64-v3", "default"))) void sincos_batch(const double* x,
                                                                              double* sn,
                                                                              double* cs,
                                                                              std::size_t n) {
  bool moderate = true;
  for (std::size_t i = 0; i < n; ++i) moderate &= std::abs(x[i]) < 1e6;  // false for NaN too
  if (!moderate) {
    for (std::size_t i = 0; i < n; ++i) fast_sincos(x[i], &sn[i], &cs[i]);
    return;
  }
  for (std::size_t i = 0; i < n; ++i) sincos_moderate(x[i], &sn[i], &cs[i]);
}

// The memo's slow paths (kept out of line: the hit path below is inlined at every call).
[[gnu::noinline]] void memo_sincos_miss(SinCosMemo& m, double x, double* sn, double* cs) {
  if (!(std::abs(x) < 1e6)) {  // far arguments and NaN: not kept
    fast_sincos(x, sn, cs);
    return;
  }
  if (m.slots.empty()) m.slots.resize(std::size_t{1} << SinCosMemo::kBits);
  std::uint64_t u;
  std::memcpy(&u, &x, sizeof u);
  SinCosMemo::Entry& e = m.slots[(u * 0x9E3779B97F4A7C15ull) >> (64 - SinCosMemo::kBits)];
  fast_sincos(x, &e.s, &e.c);
  e.key = u;
  *sn = e.s;
  *cs = e.c;
}

// fast_sincos(x) through the memo: the same numbers. (About 98% of the calls hit.)
[[gnu::always_inline]] inline void memo_sincos(SinCosMemo& m, double x, double* sn, double* cs) {
  std::uint64_t u;
  std::memcpy(&u, &x, sizeof u);
  if (!m.slots.empty() && std::abs(x) < 1e6) {
    const SinCosMemo::Entry& e = m.slots[(u * 0x9E3779B97F4A7C15ull) >> (64 - SinCosMemo::kBits)];
    if (e.key == u) {
      *sn = e.s;
      *cs = e.c;
      return;
    }
  }
  memo_sincos_miss(m, x, sn, cs);
}

struct TpmsNode : FieldNode {
  TpmsKind kind;
  Vec3 k;  // 2π / cell  (the network field φ; sheets are SheetNode around it)

  // The sines and cosines of one point's three scaled coordinates: z is usually a layer's,
  // asked again and again (Newton steps along a layer's curves), so its sine goes through the
  // memo; x and y rarely repeat.
  void point_sines(Vec3 p, EvalState& s, double* sx, double* cx, double* sy, double* cy, double* sz,
                   double* cz) const {
    fast_sincos(k.x * p.x, sx, cx);
    fast_sincos(k.y * p.y, sy, cy);
    memo_sincos(s.sincos, k.z * p.z, sz, cz);
  }
  // φ and, if `grad`, its gradient (analytic) at one point.
  double phi(Vec3 p, EvalState& s, Vec3* grad) const {
    double sx, cx, sy, cy, sz, cz;
    point_sines(p, s, &sx, &cx, &sy, &cy, &sz, &cz);
    return combine(sx, cx, sy, cy, sz, cz, grad);
  }
  // φ (and its gradient if `grad`) from the sines and cosines of the three scaled coordinates,
  // for the kind K (the per-node loops are instantiated per kind: no switch at every node).
  template <TpmsKind K>
  static double combine_k(Vec3 k, double sx, double cx, double sy, double cy, double sz, double cz,
                          Vec3* grad) {
    if constexpr (K == TpmsKind::Gyroid) {
      if (grad)
        *grad = {k.x * (cx * cy - sz * sx), k.y * (-sx * sy + cy * cz), k.z * (-sy * sz + cz * cx)};
      return sx * cy + sy * cz + sz * cx;
    } else if constexpr (K == TpmsKind::SchwarzP) {
      if (grad) *grad = {-k.x * sx, -k.y * sy, -k.z * sz};
      return cx + cy + cz;
    } else if constexpr (K == TpmsKind::SchwarzD) {
      if (grad)
        *grad = {k.x * (cx * sy * sz + cx * cy * cz - sx * sy * cz - sx * cy * sz),
                 k.y * (sx * cy * sz - sx * sy * cz + cx * cy * cz - cx * sy * sz),
                 k.z * (sx * sy * cz - sx * cy * sz - cx * sy * sz + cx * cy * cz)};
      return sx * sy * sz + sx * cy * cz + cx * sy * cz + cx * cy * sz;
    } else if constexpr (K == TpmsKind::Neovius) {
      if (grad)
        *grad = {k.x * (-3 * sx - 4 * sx * cy * cz), k.y * (-3 * sy - 4 * cx * sy * cz),
                 k.z * (-3 * sz - 4 * cx * cy * sz)};
      return 3 * (cx + cy + cz) + 4 * cx * cy * cz;
    } else if constexpr (K == TpmsKind::Iwp) {
      // cos 2a = 2cos²a − 1, d/da cos 2a = −2 sin 2a = −4 sin a cos a.
      if (grad)
        *grad = {k.x * (-2 * sx * (cy + cz) + 4 * sx * cx),
                 k.y * (-2 * sy * (cx + cz) + 4 * sy * cy),
                 k.z * (-2 * sz * (cx + cy) + 4 * sz * cz)};
      return 2 * (cx * cy + cy * cz + cz * cx) -
             ((2 * cx * cx - 1) + (2 * cy * cy - 1) + (2 * cz * cz - 1));
    } else {
      return 0;
    }
  }
  // Calls fn(std::integral_constant<TpmsKind, kind>).
  template <class Fn>
  decltype(auto) with_kind(Fn fn) const {
    switch (kind) {
      case TpmsKind::Gyroid:
        return fn(std::integral_constant<TpmsKind, TpmsKind::Gyroid>{});
      case TpmsKind::SchwarzP:
        return fn(std::integral_constant<TpmsKind, TpmsKind::SchwarzP>{});
      case TpmsKind::SchwarzD:
        return fn(std::integral_constant<TpmsKind, TpmsKind::SchwarzD>{});
      case TpmsKind::Neovius:
        return fn(std::integral_constant<TpmsKind, TpmsKind::Neovius>{});
      case TpmsKind::Iwp:
        return fn(std::integral_constant<TpmsKind, TpmsKind::Iwp>{});
    }
    return fn(std::integral_constant<TpmsKind, TpmsKind::Iwp>{});
  }
  double combine(double sx, double cx, double sy, double cy, double sz, double cz,
                 Vec3* grad = nullptr) const {
    return with_kind([&](auto K) { return combine_k<K.value>(k, sx, cx, sy, cy, sz, cz, grad); });
  }
  bool gradient(Vec3 p, Vec3& g, EvalState& s, std::size_t) const override {
    phi(p, s, &g);
    return true;
  }
  bool value_gradient(Vec3 p, double& v, Vec3& g, EvalState& s, std::size_t) const override {
    v = phi(p, s, &g);  // the same sines and sums as eval's and gradient's
    return true;
  }
  bool gradients(const Vec3* p, Vec3* g, std::size_t n, EvalState& s,
                 std::size_t depth) const override {
    with_kind([&](auto K) {
      sweep(p, n, s, depth,
            [&](std::size_t i, double sx, double cx, double sy, double cy, double sz, double cz) {
              combine_k<K.value>(k, sx, cx, sy, cy, sz, cz, &g[i]);
            });
    });
    return true;
  }
  // Bound on |φ|.
  double phi_max() const {
    switch (kind) {
      case TpmsKind::Gyroid:
        return 1.5;
      case TpmsKind::SchwarzP:
        return 3;
      case TpmsKind::SchwarzD:
        return 1.5;  // |D| <= sqrt(2) actually; keep a margin
      case TpmsKind::Neovius:
        return 13;
      case TpmsKind::Iwp:
        return 9;
    }
    return 13;
  }
  // Max |∇φ| in units of the largest k: √3 for gyroid, P and D, 7 for Neovius, 3√3 for IWP
  // (maxima of the unit-cell gradient norm; 1% margin). |∇φ|² = Σ kᵢ² (∂ᵢφ̃)² ≤ kmax² C².
  double phi_lipschitz() const {
    double c = std::sqrt(3.0);
    if (kind == TpmsKind::Neovius) c = 7.0;
    if (kind == TpmsKind::Iwp) c = 3 * std::sqrt(3.0);
    return 1.01 * c * std::max({k.x, k.y, k.z});
  }
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    with_kind([&](auto K) {
      sweep(p, n, s, depth,
            [&](std::size_t i, double sx, double cx, double sy, double cy, double sz, double cz) {
              out[i] = combine_k<K.value>(k, sx, cx, sy, cy, sz, cz, nullptr);
            });
    });
  }
  // Sines per column and per row (the same fast_sincos values as the point path's for these
  // coordinates, so the same numbers), combined at every node.
  template <class Fn>
  void sweep_grid(const GridPlane& g, EvalState& s, std::size_t depth, Fn fn) const {
    std::vector<double>& b = s.value_buffer(depth + 1, 2 * (g.w + g.rows));
    double *sx = b.data(), *cx = sx + g.w, *sy = cx + g.w, *cy = sy + g.rows;
    // Neighbouring blocks share their columns and rows: through the memo.
    for (std::size_t i = 0; i < g.w; ++i) memo_sincos(s.sincos, k.x * g.xs[i], &sx[i], &cx[i]);
    for (std::size_t j = 0; j < g.rows; ++j) memo_sincos(s.sincos, k.y * g.ys[j], &sy[j], &cy[j]);
    double sz, cz;
    memo_sincos(s.sincos, k.z * g.z, &sz, &cz);
    for (std::size_t j = 0; j < g.rows; ++j) {
      const double syj = sy[j], cyj = cy[j];
      for (std::size_t i = 0; i < g.w; ++i) fn(j * g.w + i, sx[i], cx[i], syj, cyj, sz, cz);
    }
  }
  void eval_grid(const GridPlane& g, double* out, EvalState& s, std::size_t depth) const override {
    with_kind([&](auto K) {
      sweep_grid(
          g, s, depth,
          [&](std::size_t i, double sx, double cx, double sy, double cy, double sz, double cz) {
            out[i] = combine_k<K.value>(k, sx, cx, sy, cy, sz, cz, nullptr);
          });
    });
  }
  bool gradients_grid(const GridPlane& g, Vec3* out, EvalState& s,
                      std::size_t depth) const override {
    with_kind([&](auto K) {
      sweep_grid(g, s, depth,
                 [&](std::size_t i, double sx, double cx, double sy, double cy, double sz,
                     double cz) { combine_k<K.value>(k, sx, cx, sy, cy, sz, cz, &out[i]); });
    });
    return true;
  }
  // Calls fn(i, sin/cos of the three scaled coordinates) for each point. Rows of a grid (z
  // constant, y once a row, x repeating row after row) reuse the sines of the row above; other
  // batches compute them in vectorised batches; a few points one by one.
  template <class Fn>
  void sweep(const Vec3* p, std::size_t n, EvalState& s, std::size_t depth, Fn fn) const {
    if (n < 4) {
      for (std::size_t i = 0; i < n; ++i) {
        double sx, cx, sy, cy, sz, cz;
        point_sines(p[i], s, &sx, &cx, &sy, &cy, &sz, &cz);
        fn(i, sx, cx, sy, cy, sz, cz);
      }
      return;
    }
    std::size_t row = 1;
    while (row < n && p[row].y == p[0].y) ++row;
    if (row > 1 && 2 * row <= n && p[row].x == p[0].x) {
      sweep_rows(p, n, s, depth, fn);
      return;
    }
    std::vector<double>& b = s.value_buffer(depth + 1, 7 * n);
    double* t = b.data();
    double *sx = t + n, *cx = t + 2 * n, *sy = t + 3 * n, *cy = t + 4 * n, *sz = t + 5 * n,
           *cz = t + 6 * n;
    for (std::size_t i = 0; i < n; ++i) t[i] = k.x * p[i].x;
    sincos_batch(t, sx, cx, n);
    for (std::size_t i = 0; i < n; ++i) t[i] = k.y * p[i].y;
    sincos_batch(t, sy, cy, n);
    bool flat = true;
    for (std::size_t i = 1; i < n; ++i) flat &= p[i].z == p[0].z;
    if (flat) {
      double s0, c0;
      fast_sincos(k.z * p[0].z, &s0, &c0);
      for (std::size_t i = 0; i < n; ++i) fn(i, sx[i], cx[i], sy[i], cy[i], s0, c0);
      return;
    }
    for (std::size_t i = 0; i < n; ++i) t[i] = k.z * p[i].z;
    sincos_batch(t, sz, cz, n);
    for (std::size_t i = 0; i < n; ++i) fn(i, sx[i], cx[i], sy[i], cy[i], sz[i], cz[i]);
  }
  // Sines reused for a repeated y or z, and for the x of the point one row back (found by exact
  // comparison, so any batch is evaluated correctly).
  template <class Fn>
  void sweep_rows(const Vec3* p, std::size_t n, EvalState& s, std::size_t depth, Fn fn) const {
    std::vector<double>& sc = s.value_buffer(depth + 1, 2 * n);
    double py = std::numeric_limits<double>::quiet_NaN(), pz = py;
    double sx = 0, cx = 0, sy = 0, cy = 0, sz = 0, cz = 0;
    std::size_t row = 0;  // length of the first row (0 until the row changes)
    for (std::size_t i = 0; i < n; ++i) {
      if (row && p[i].x == p[i - row].x) {
        sx = sc[2 * (i - row)];
        cx = sc[2 * (i - row) + 1];
      } else {
        fast_sincos(k.x * p[i].x, &sx, &cx);
      }
      sc[2 * i] = sx;
      sc[2 * i + 1] = cx;
      if (!(p[i].y == py)) {
        if (i > 0 && row == 0) row = i;
        fast_sincos(k.y * p[i].y, &sy, &cy), py = p[i].y;
      }
      if (!(p[i].z == pz)) fast_sincos(k.z * p[i].z, &sz, &cz), pz = p[i].z;
      fn(i, sx, cx, sy, cy, sz, cz);
    }
  }
  // Bound on |∂i∂j φ̃| (unit-cell coordinates) over all i, j: gyroid √2 (Cauchy–Schwarz on
  // −sx·cy − sz·cx), P 1, D 4 (four unit products), Neovius 7 (−3cx − 4cx·cy·cz), IWP 8
  // (−2cx(cy + cz) + 4cos 2x).
  double phi_hessian_max() const {
    switch (kind) {
      case TpmsKind::Gyroid:
        return std::sqrt(2.0);
      case TpmsKind::SchwarzP:
        return 1;
      case TpmsKind::SchwarzD:
        return 4;
      case TpmsKind::Neovius:
        return 7;
      case TpmsKind::Iwp:
        return 8;
    }
    return 8;
  }
  // The centre value ± the smaller of two spreads: Lipschitz (max |∇φ| × half diagonal) and
  // second order (Taylor at the centre: Σ|∂iφ|·di + ½·A·(Σ ki·di)², A the Hessian bound above,
  // di the half extents), which is several times tighter on the small blocks contouring asks
  // about wherever the gradient in the block's plane is moderate (a narrow band around the sheet).
  Interval bound(const BBox3& b, EvalState& st, std::size_t) const override {
    Vec3 g;
    const Vec3 p = b.center();
    double sx, cx, sy, cy, sz, cz;
    memo_sincos(st.sincos, k.x * p.x, &sx, &cx);
    memo_sincos(st.sincos, k.y * p.y, &sy, &cy);
    memo_sincos(st.sincos, k.z * p.z, &sz, &cz);
    const double f = combine(sx, cx, sy, cy, sz, cz, &g);
    double spread = phi_lipschitz() * half_diagonal(b);
    const double dx = 0.5 * (b.max.x - b.min.x), dy = 0.5 * (b.max.y - b.min.y),
                 dz = 0.5 * (b.max.z - b.min.z);
    const double s = k.x * dx + k.y * dy + k.z * dz;
    const double taylor = 1.01 * (std::abs(g.x) * dx + std::abs(g.y) * dy + std::abs(g.z) * dz +
                                  0.5 * phi_hessian_max() * s * s) +
                          1e-12;
    if (std::isfinite(taylor)) spread = std::min(spread, taylor);
    return {std::max(f - spread, -phi_max()), std::min(f + spread, phi_max())};
  }
  double lipschitz() const override { return phi_lipschitz(); }
  // Every term is a product of sines and cosines of k·x, k·y, k·z (or of their doubles).
  Vec3 period() const override {
    constexpr double tau = 2 * std::numbers::pi;
    return {tau / k.x, tau / k.y, tau / k.z};
  }
  // Gyroid and Schwarz D: every term has an odd number of sines (odd); the others are sums and
  // products of cosines (even).
  int inversion_parity() const override {
    return kind == TpmsKind::Gyroid || kind == TpmsKind::SchwarzD ? -1 : 1;
  }
  BBox3 extent() const override { return infinite_box(); }
};

// ---------------------------------------------------------------- sheets, blends, expressions

struct SheetNode : FieldNode {
  bool c_constant = true;
  double c = 0;
  Expression c_expr;
  double thickness = 0;  // > 0: c = t·|∇φ|/2
  static constexpr double kStep = 1e-5;

  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    children[0]->eval(p, out, n, s, depth + 1);
    if (thickness > 0) {
      for (std::size_t i = 0; i < n; ++i) {
        const Vec3 q = p[i];
        const Vec3 pts[6] = {{q.x + kStep, q.y, q.z}, {q.x - kStep, q.y, q.z},
                             {q.x, q.y + kStep, q.z}, {q.x, q.y - kStep, q.z},
                             {q.x, q.y, q.z + kStep}, {q.x, q.y, q.z - kStep}};
        double v[6];
        children[0]->eval(pts, v, 6, s, depth + 1);
        const double gx = (v[0] - v[1]), gy = (v[2] - v[3]), gz = (v[4] - v[5]);
        const double g = std::sqrt(gx * gx + gy * gy + gz * gz) / (2 * kStep);
        const double cc = 0.5 * thickness * g;
        out[i] = out[i] * out[i] - cc * cc;
      }
      return;
    }
    if (c_constant) {
      for (std::size_t i = 0; i < n; ++i) out[i] = out[i] * out[i] - c * c;
      return;
    }
    auto& ce = s.expr(c_expr);
    for (std::size_t i = 0; i < n; ++i) {
      const double cv = ce.eval(p[i]);
      out[i] = out[i] * out[i] - cv * cv;
    }
  }
  void eval_grid(const GridPlane& g, double* out, EvalState& s, std::size_t depth) const override {
    if (!c_constant || thickness > 0) {
      FieldNode::eval_grid(g, out, s, depth);
      return;
    }
    children[0]->eval_grid(g, out, s, depth + 1);
    for (std::size_t i = 0, n = g.size(); i < n; ++i) out[i] = out[i] * out[i] - c * c;
  }
  Interval bound(const BBox3& b, EvalState& s, std::size_t depth) const override {
    if (!c_constant || thickness > 0) return {-kInf, kInf};
    const Interval f = children[0]->bound(b, s, depth + 1);
    const double sq_lo = (f.lo <= 0 && f.hi >= 0) ? 0.0 : std::min(f.lo * f.lo, f.hi * f.hi);
    const double sq_hi = std::max(f.lo * f.lo, f.hi * f.hi);
    return {sq_lo - c * c, sq_hi - c * c};
  }
  double lipschitz() const override { return kInf; }
  BBox3 extent() const override { return children[0]->extent(); }
  bool has_expressions() const override { return !c_constant || FieldNode::has_expressions(); }
};

struct BlendNode : FieldNode {
  Expression w;
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    children[0]->eval(p, out, n, s, depth + 1);
    children[1]->eval(p, s.value_buffer(depth, n).data(), n, s, depth + 1);
    const double* b = s.values[depth].data();
    auto& we = s.expr(w);
    for (std::size_t i = 0; i < n; ++i) {
      double t = we.eval(p[i]);
      t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0;
      out[i] = (1 - t) * out[i] + t * b[i];
    }
  }
  Interval bound(const BBox3& bx, EvalState& s, std::size_t depth) const override {
    // A convex combination lies between the two children's bounds.
    const Interval a = children[0]->bound(bx, s, depth + 1),
                   b = children[1]->bound(bx, s, depth + 1);
    return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
  }
  double lipschitz() const override { return kInf; }
  BBox3 extent() const override {
    BBox3 e = children[0]->extent();
    const BBox3 o = children[1]->extent();
    e.add(o.min);
    e.add(o.max);
    return e;
  }
  bool has_expressions() const override { return true; }
};

struct ExpressionNode : FieldNode {
  Expression e;
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s, std::size_t) const override {
    auto& c = s.expr(e);
    for (std::size_t i = 0; i < n; ++i) out[i] = c.eval(p[i]);
  }
  double lipschitz() const override { return kInf; }
  BBox3 extent() const override { return infinite_box(); }
  bool has_expressions() const override { return true; }
};

// ---------------------------------------------------------------- CSG

enum class Op { Union, Intersection, Difference };

// Polynomial smooth minimum: min(a,b) - h²k/4, h = max(k-|a-b|, 0)/k; lies in [min - k/4, min].
double smin(double a, double b, double k) {
  if (k <= 0) return std::min(a, b);
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

// Distance between two boxes (0 if they touch or overlap).
double box_gap(const BBox3& a, const BBox3& b) {
  const double dx = std::max({0.0, a.min.x - b.max.x, b.min.x - a.max.x});
  const double dy = std::max({0.0, a.min.y - b.max.y, b.min.y - a.max.y});
  const double dz = std::max({0.0, a.min.z - b.max.z, b.min.z - a.max.z});
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

struct CsgNode : FieldNode {
  Op op;
  double k = 0;                // smooth blend radius, 0 = sharp
  std::vector<BBox3> extents;  // children's, cached
  std::vector<char> exact;     // children's exact_outside(), cached
  void cache() {
    for (const auto& c : children) {
      extents.push_back(c->extent());
      exact.push_back(c->exact_outside());
    }
  }
  bool exact_outside() const override {
    if (op != Op::Union || k > 0) return false;
    for (char e : exact)
      if (!e) return false;
    return true;
  }
  // Child c's bound; an exact child whose extent is away from the box is bounded below by the
  // gap without evaluating it.
  Interval child_bound(std::size_t c, const BBox3& b, EvalState& s, std::size_t depth) const {
    if (exact[c]) {
      const double gap = box_gap(b, extents[c]);
      if (gap > 0) return {gap, kInf};
    }
    return children[c]->bound(b, s, depth + 1);
  }

  double combine(double acc, double v) const {
    switch (op) {
      case Op::Union:
        return smin(acc, v, k);
      case Op::Intersection:
        return -smin(-acc, -v, k);
      case Op::Difference:
        return -smin(-acc, v, k);
    }
    return acc;
  }
  // Whether child c cannot change any of the values `out` (range [lo, hi]) over the box.
  bool irrelevant(const Interval& v, double lo, double hi) const {
    switch (op) {
      case Op::Union:
        return v.lo >= hi + k;  // min(out, v) = out everywhere
      case Op::Intersection:
        return v.hi <= lo - k;  // max(out, v) = out
      case Op::Difference:
        return -v.lo <= lo - k;  // max(out, -v) = out
    }
    return false;
  }
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    children[0]->eval(p, out, n, s, depth + 1);
    // For batches, skip children whose bound over the batch's box shows they change nothing
    // (a plate with many holes evaluates only the holes near the batch).
    // Exact children far from the batch cost a box gap; for batches, any child's bound.
    const bool prune = children.size() > 2;
    BBox3 box;
    if (prune)
      for (std::size_t i = 0; i < n; ++i) box.add(p[i]);
    for (std::size_t c = 1; c < children.size(); ++c) {
      if (prune && (n >= 16 || exact[c])) {
        double lo = out[0], hi = out[0];
        for (std::size_t i = 1; i < n; ++i) {
          lo = std::min(lo, out[i]);
          hi = std::max(hi, out[i]);
        }
        const double gap = exact[c] ? box_gap(box, extents[c]) : 0.0;
        if (gap > 0 ? irrelevant({gap, kInf}, lo, hi)
                    : (n >= 16 && irrelevant(child_bound(c, box, s, depth), lo, hi)))
          continue;
      }
      // Buffers are fetched after each child ran: a child may grow this depth's buffer.
      children[c]->eval(p, s.value_buffer(depth, n).data(), n, s, depth + 1);
      const double* v = s.values[depth].data();
      for (std::size_t i = 0; i < n; ++i) out[i] = combine(out[i], v[i]);
    }
  }
  // As eval, children combined grid by grid; a child whose bound over the grid shows it changes
  // none of the values so far is skipped (exactly: the values are the same as eval's).
  void eval_grid(const GridPlane& g, double* out, EvalState& s, std::size_t depth) const override {
    children[0]->eval_grid(g, out, s, depth + 1);
    const std::size_t n = g.size();
    // A child's bound costs about as much as its grid of a few dozen nodes: asked for exact
    // children (a box gap) and for larger grids.
    const BBox3 box = n >= 16 ? grid_box(g) : BBox3{};
    for (std::size_t c = 1; c < children.size(); ++c) {
      if (n >= 16 && (exact[c] || n >= 64)) {
        double lo = out[0], hi = out[0];
        for (std::size_t i = 1; i < n; ++i) {
          lo = std::min(lo, out[i]);
          hi = std::max(hi, out[i]);
        }
        if (irrelevant(child_bound(c, box, s, depth), lo, hi)) continue;
      }
      children[c]->eval_grid(g, s.value_buffer(depth, n).data(), s, depth + 1);
      const double* v = s.values[depth].data();
      for (std::size_t i = 0; i < n; ++i) out[i] = combine(out[i], v[i]);
    }
  }
  Interval bound(const BBox3& b, EvalState& s, std::size_t depth) const override {
    Interval acc = child_bound(0, b, s, depth);
    for (std::size_t c = 1; c < children.size(); ++c) {
      const Interval v = child_bound(c, b, s, depth);
      switch (op) {
        case Op::Union:
          acc = {std::min(acc.lo, v.lo) - k * 0.25, std::min(acc.hi, v.hi)};
          break;
        case Op::Intersection:
          acc = {std::max(acc.lo, v.lo), std::max(acc.hi, v.hi) + k * 0.25};
          break;
        case Op::Difference:
          acc = {std::max(acc.lo, -v.hi), std::max(acc.hi, -v.lo) + k * 0.25};
          break;
      }
    }
    return acc;
  }
  double lipschitz() const override {
    double L = 0;
    for (const auto& c : children) L = std::max(L, c->lipschitz());
    return L;
  }
  BBox3 extent() const override {
    BBox3 e = children[0]->extent();
    for (std::size_t c = 1; c < children.size() && op != Op::Difference; ++c) {
      const BBox3 o = children[c]->extent();
      if (op == Op::Union) {
        e.add(o.min);
        e.add(o.max);
      } else {
        e.min = {std::max(e.min.x, o.min.x), std::max(e.min.y, o.min.y),
                 std::max(e.min.z, o.min.z)};
        e.max = {std::min(e.max.x, o.max.x), std::min(e.max.y, o.max.y),
                 std::min(e.max.z, o.max.z)};
      }
    }
    const double pad = k * 0.25;
    if (pad > 0 && !e.empty()) {
      e.min = e.min - Vec3{pad, pad, pad};
      e.max = e.max + Vec3{pad, pad, pad};
    }
    return e;
  }
  // A union takes the materials (and process values) of the child that holds the point (the
  // deepest inside); the other operations those of their first child.
  std::size_t holder(Vec3 p, EvalState& s, std::size_t depth) const {
    std::size_t pick = 0;
    if (op == Op::Union) {
      double best = kInf;
      for (std::size_t c = 0; c < children.size(); ++c) {
        const double v = children[c]->value(p, s, depth + 1);
        if (v < best) {
          best = v;
          pick = c;
        }
      }
    }
    return pick;
  }
  void fractions(Vec3 p, double* out, EvalState& s, std::size_t depth) const override {
    children[holder(p, s, depth)]->fractions(p, out, s, depth + 1);
  }
  void process(Vec3 p, ProcessValues& out, EvalState& s, std::size_t depth) const override {
    children[holder(p, s, depth)]->process(p, out, s, depth + 1);
  }
};

// ---------------------------------------------------------------- transforms

struct Mat3 {
  std::array<double, 9> m{1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3 operator*(Vec3 v) const {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
            m[6] * v.x + m[7] * v.y + m[8] * v.z};
  }
  Mat3 operator*(const Mat3& o) const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double acc = 0;
        for (int t = 0; t < 3; ++t) acc += m[i * 3 + t] * o.m[t * 3 + j];
        r.m[i * 3 + j] = acc;
      }
    return r;
  }
  Mat3 transposed() const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.m[i * 3 + j] = m[j * 3 + i];
    return r;
  }
};

// p_local = A (p - t); value = child(p_local) * s. Covers translate, scale and rotate.
struct TransformNode : FieldNode {
  Mat3 to_local;           // A
  Mat3 to_world;           // A^-1
  Vec3 offset;             // t
  double value_scale = 1;  // min scale factor, keeps distances conservative
  double lipschitz_factor = 1;

  Vec3 local(Vec3 p) const { return to_local * (p - offset); }
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    auto& q = s.point_buffer(depth, n);
    for (std::size_t i = 0; i < n; ++i) q[i] = local(p[i]);
    children[0]->eval(q.data(), out, n, s, depth + 1);
    if (value_scale != 1)
      for (std::size_t i = 0; i < n; ++i) out[i] *= value_scale;
  }
  BBox3 map_box(const BBox3& b, bool to_child) const {
    if (!std::isfinite(b.min.x) || !std::isfinite(b.max.x) || !std::isfinite(b.min.y) ||
        !std::isfinite(b.max.y) || !std::isfinite(b.min.z) || !std::isfinite(b.max.z))
      return infinite_box();
    BBox3 r;
    for (int c = 0; c < 8; ++c) {
      const Vec3 v{(c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y,
                   (c & 4) ? b.max.z : b.min.z};
      r.add(to_child ? local(v) : to_world * v + offset);
    }
    return r;
  }
  Interval bound(const BBox3& b, EvalState& s, std::size_t depth) const override {
    const Interval c = children[0]->bound(map_box(b, true), s, depth + 1);
    return {c.lo * value_scale, c.hi * value_scale};
  }
  double lipschitz() const override { return children[0]->lipschitz() * lipschitz_factor; }
  // A translation keeps the child's period (other transforms: none is claimed).
  Vec3 period() const override {
    if (to_local.m != Mat3{}.m || value_scale != 1) return {0, 0, 0};
    return children[0]->period();
  }
  // A linear map keeps the origin (−A·p = A·(−p)); a translation moves the centre.
  int inversion_parity() const override {
    return offset.x == 0 && offset.y == 0 && offset.z == 0 ? children[0]->inversion_parity() : 0;
  }
  bool exact_outside() const override {
    return lipschitz_factor == 1 && children[0]->exact_outside();
  }
  bool gradient(Vec3 p, Vec3& g, EvalState& s, std::size_t depth) const override {
    Vec3 gl;
    if (!children[0]->gradient(local(p), gl, s, depth + 1)) return false;
    // ∇(f(A(p − t))·s) = s·Aᵀ ∇f
    g = to_local.transposed() * gl * value_scale;
    return true;
  }
  BBox3 extent() const override { return map_box(children[0]->extent(), false); }
  void fractions(Vec3 p, double* out, EvalState& s, std::size_t depth) const override {
    children[0]->fractions(local(p), out, s, depth + 1);
  }
  void process(Vec3 p, ProcessValues& out, EvalState& s, std::size_t depth) const override {
    children[0]->process(local(p), out, s, depth + 1);
  }
};

// ---------------------------------------------------------------- material grades, clip box

struct GradeNode : PropertyNode {
  std::vector<Expression> exprs;
  std::vector<std::string> names;
  void fractions(Vec3 p, double* out, EvalState& s, std::size_t depth) const override {
    fractions(&p, 1, 0, out, s, depth);
  }
  // Each expression over the whole row, then each point normalised (the values clamped to
  // [0, 1] and divided by their sum, in the order of the list).
  void fractions(const Vec3* p, std::size_t n, std::size_t m, double* out, EvalState& s,
                 std::size_t depth) const override {
    const std::size_t k = exprs.size();
    // All the expressions in one program (their shared subexpressions evaluated once), unless
    // one has no translation (then each through its own).
    ExprProgram* program = s.program(this, exprs);
    // The distance d only if some expression reads it (a mesh's distance costs more than the
    // expressions).
    bool need_d = program && program->uses_d();
    if (!program)
      for (const auto& e : exprs) need_d |= s.expr(e).uses_d;
    // The distances in this node's buffer (the child evaluates in deeper ones); the pointer
    // taken again after the child ran, which may have grown the list of buffers.
    const double* d = nullptr;
    if (need_d) {
      children[0]->eval(p, s.value_buffer(depth, n).data(), n, s, depth + 1);
      d = s.value_buffer(depth, n).data();
    }
    // Row i of v: expression i at every point.
    std::vector<double>& v = s.value_buffer(depth + 1, k * n);
    if (program)
      program->run(p, d, n, v.data());
    else
      for (std::size_t i = 0; i < k; ++i) s.expr(exprs[i]).eval(p, d, n, v.data() + i * n);
    for (std::size_t j = 0; j < n; ++j)
      for (std::size_t i = 0; i < k; ++i) {
        const double f = v[i * n + j];
        if (!std::isfinite(f))
          throw GeometryError(
              fmt::format("the fraction of '{}' = {} is {} at ({:g}, {:g}, {:g}): "
                          "a fraction must be a finite number everywhere in the part",
                          names[i], exprs[i].text, f, p[j].x, p[j].y, p[j].z),
              {"", 0, "fgrade"});
      }
    int idx[16];
    std::vector<int> idx_more;
    int* index = idx;
    if (k > 16) {
      idx_more.resize(k);
      index = idx_more.data();
    }
    for (std::size_t i = 0; i < k; ++i) index[i] = s.material_index(names[i]);
    for (std::size_t j = 0; j < n; ++j) {
      double sum = 0;
      for (std::size_t i = 0; i < k; ++i) {
        double& f = v[i * n + j];
        f = std::clamp(f, 0.0, 1.0);
        sum += f;
      }
      double* o = out + j * m;
      for (std::size_t i = 0; i < k; ++i)
        if (index[i] >= 0) o[index[i]] += sum > 0 ? v[i * n + j] / sum : 0.0;
    }
  }
  bool has_expressions() const override { return true; }
  void own_materials(std::vector<std::string>& table) const override {
    for (const auto& m : names)
      if (std::find(table.begin(), table.end(), m) == table.end()) table.push_back(m);
    FieldNode::own_materials(table);
  }
};

struct ClipBoxNode : FieldNode {
  Vec3 lo, hi;
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    children[0]->eval(p, out, n, s, depth + 1);
    const Vec3 c = (lo + hi) * 0.5, h = (hi - lo) * 0.5;
    for (std::size_t i = 0; i < n; ++i) out[i] = std::max(out[i], box_sdf(p[i], c, h));
  }
  // box_sdf's per-axis terms once per column and per row (the same arithmetic, so the same
  // values); a grid inside the box on every axis needs no square root.
  void eval_grid(const GridPlane& g, double* out, EvalState& s, std::size_t depth) const override {
    children[0]->eval_grid(g, out, s, depth + 1);
    const Vec3 c = (lo + hi) * 0.5, h = (hi - lo) * 0.5;
    std::vector<double>& buf = s.value_buffer(depth, g.w + g.rows);  // free: children use deeper
    double *qx = buf.data(), *qy = qx + g.w;
    const double qz = std::abs(g.z - c.z) - h.z;
    bool inside = qz < 0;
    for (std::size_t i = 0; i < g.w; ++i) {
      qx[i] = std::abs(g.xs[i] - c.x) - h.x;
      inside = inside && qx[i] < 0;
    }
    for (std::size_t j = 0; j < g.rows; ++j) {
      qy[j] = std::abs(g.ys[j] - c.y) - h.y;
      inside = inside && qy[j] < 0;
    }
    const double oz = std::max(qz, 0.0);
    for (std::size_t j = 0; j < g.rows; ++j) {
      double* o = out + j * g.w;
      const double qyj = qy[j], oy = std::max(qyj, 0.0);
      if (inside) {
        for (std::size_t i = 0; i < g.w; ++i)
          o[i] = std::max(o[i], 0.0 + std::min(std::max({qx[i], qyj, qz}), 0.0));
        continue;
      }
      for (std::size_t i = 0; i < g.w; ++i) {
        const double ox = std::max(qx[i], 0.0);
        o[i] = std::max(o[i], std::sqrt(ox * ox + oy * oy + oz * oz) +
                                  std::min(std::max({qx[i], qyj, qz}), 0.0));
      }
    }
  }
  Interval bound(const BBox3& b, EvalState& s, std::size_t depth) const override {
    const Interval a = children[0]->bound(b, s, depth + 1);
    const Interval bb = box_sdf_bound(b, (lo + hi) * 0.5, (hi - lo) * 0.5);
    return {std::max(a.lo, bb.lo), std::max(a.hi, bb.hi)};
  }
  double lipschitz() const override { return std::max(1.0, children[0]->lipschitz()); }
  BBox3 extent() const override {
    BBox3 e = children[0]->extent();
    e.min = {std::max(e.min.x, lo.x), std::max(e.min.y, lo.y), std::max(e.min.z, lo.z)};
    e.max = {std::min(e.max.x, hi.x), std::min(e.max.y, hi.y), std::min(e.max.z, hi.z)};
    return e;
  }
};

void require_positive(double v, const char* what) {
  if (!(v > 0) || !std::isfinite(v))
    throw GeometryError(std::string(what) + " must be a positive number");
}

template <class N>
Field make_leaf(std::shared_ptr<N> node, std::string material) {
  node->material = std::move(material);
  return Field(std::move(node));
}

Field make_csg(std::vector<Field> children, Op op, double k, const char* name) {
  if (children.empty()) throw GeometryError(std::string(name) + " needs at least one child");
  if (!(k >= 0) || !std::isfinite(k)) throw GeometryError("blend radius must be >= 0");
  if (children.size() == 1) return children.front();
  auto n = std::make_shared<CsgNode>();
  n->op = op;
  n->k = k;
  for (auto& c : children) {
    if (c.empty()) throw GeometryError(std::string(name) + ": empty child");
    n->children.push_back(c.ptr());
  }
  n->cache();
  return Field(n);
}

Mat3 rotation_x(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return Mat3{{1, 0, 0, 0, c, -s, 0, s, c}};
}
Mat3 rotation_y(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return Mat3{{c, 0, s, 0, 1, 0, -s, 0, c}};
}
Mat3 rotation_z(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return Mat3{{c, -s, 0, s, c, 0, 0, 0, 1}};
}

void require_child(const Field& f, const char* what) {
  if (f.empty()) throw GeometryError(std::string(what) + " needs a child");
}

}  // namespace

// ---------------------------------------------------------------- Field

Field::Field(std::shared_ptr<const FieldNode> node) : node_(std::move(node)) {
  auto table = std::make_shared<std::vector<std::string>>();
  if (node_) node_->collect_materials(*table);
  materials_ = std::move(table);
}

BBox3 Field::extent() const {
  return node_ ? node_->extent() : BBox3{};
}
const std::vector<std::string>& Field::materials() const {
  static const std::vector<std::string> none;
  return materials_ ? *materials_ : none;
}
bool Field::has_expressions() const {
  return node_ && node_->has_expressions();
}
bool Field::has_process() const {
  return node_ && node_->has_process();
}
double Field::smallest_period() const {
  double cell = std::numeric_limits<double>::infinity();
  std::vector<const FieldNode*> todo;
  std::unordered_map<const FieldNode*, char> seen;
  if (node_) todo.push_back(node_.get());
  while (!todo.empty()) {
    const FieldNode* n = todo.back();
    todo.pop_back();
    if (!seen.emplace(n, 1).second) continue;
    const Vec3 p = n->period();
    if (p.x > 0 || p.y > 0 || p.z > 0) {  // the outermost periodic node: its period holds
      for (double a : {p.x, p.y, p.z})
        if (a > 0) cell = std::min(cell, a);
      continue;
    }
    for (const auto& c : n->children) todo.push_back(c.get());
  }
  return cell;
}

double Field::nodes() const {
  if (!node_) return 0;
  // Subtree sizes, each distinct node once (shared subtrees: a DAG from Python), without
  // recursion (a chain of 10^5 transforms).
  std::unordered_map<const FieldNode*, double> size;
  std::vector<std::pair<const FieldNode*, bool>> todo{{node_.get(), false}};
  while (!todo.empty()) {
    const auto [node, children_done] = todo.back();
    todo.pop_back();
    if (size.count(node)) continue;
    if (!children_done) {
      todo.push_back({node, true});
      for (const auto& c : node->children)
        if (!size.count(c.get())) todo.push_back({c.get(), false});
      continue;
    }
    double n = 1;
    for (const auto& c : node->children) n += size.at(c.get());
    size[node] = n;
  }
  return size.at(node_.get());
}
double Field::lipschitz() const {
  return node_ ? node_->lipschitz() : std::numeric_limits<double>::infinity();
}

Vec3 Field::period() const {
  return node_ ? node_->period() : Vec3{0, 0, 0};
}

int Field::inversion_parity() const {
  return node_ ? node_->inversion_parity() : 0;
}

const char* to_string(TpmsKind kind) {
  switch (kind) {
    case TpmsKind::Gyroid:
      return "gyroid";
    case TpmsKind::SchwarzP:
      return "schwarz_p";
    case TpmsKind::SchwarzD:
      return "schwarz_d";
    case TpmsKind::Neovius:
      return "neovius";
    case TpmsKind::Iwp:
      return "iwp";
  }
  return "?";
}

Field sphere(double radius, std::string material) {
  require_positive(radius, "sphere radius");
  return make_leaf(std::make_shared<SphereNode>(radius), std::move(material));
}
Field cube(double side, std::string material) {
  return rectprism({side, side, side}, std::move(material));
}
Field rectprism(Vec3 size, std::string material) {
  require_positive(size.x, "rectprism size x");
  require_positive(size.y, "rectprism size y");
  require_positive(size.z, "rectprism size z");
  return make_leaf(std::make_shared<BoxNode>(size), std::move(material));
}
Field cylinder(double radius, double height, std::string material) {
  require_positive(radius, "cylinder radius");
  require_positive(height, "cylinder height");
  return make_leaf(std::make_shared<CylinderNode>(radius, height), std::move(material));
}
Field cone(double radius, double height, std::string material) {
  require_positive(radius, "cone radius");
  require_positive(height, "cone height");
  return make_leaf(std::make_shared<ConeNode>(radius, height), std::move(material));
}
Field torus(double major_radius, double minor_radius, std::string material) {
  require_positive(major_radius, "torus major radius");
  require_positive(minor_radius, "torus minor radius");
  return make_leaf(std::make_shared<TorusNode>(major_radius, minor_radius), std::move(material));
}
Field function(Vec3 min, Vec3 max, Expression expr, std::string material) {
  if (!(min.x < max.x && min.y < max.y && min.z < max.z) || !is_finite(min) || !is_finite(max))
    throw GeometryError("function box: min must be below max on every axis");
  check_expression(expr.text);
  auto n = std::make_shared<FunctionNode>();
  n->lo = min;
  n->hi = max;
  n->expr = std::move(expr);
  return make_leaf(std::move(n), std::move(material));
}
Field tpms(TpmsKind kind, Vec3 cell, Expression c, std::string material) {
  require_positive(cell.x, "TPMS cell size x");
  require_positive(cell.y, "TPMS cell size y");
  require_positive(cell.z, "TPMS cell size z");
  auto n = std::make_shared<TpmsNode>();
  n->kind = kind;
  const double tau = 2 * std::numbers::pi;
  n->k = {tau / cell.x, tau / cell.y, tau / cell.z};
  Field network = make_leaf(std::move(n), std::move(material));
  return c.text.empty() ? network : sheet(network, std::move(c));
}

Field sheet(Field phi, Expression c, double uniform_thickness) {
  require_child(phi, "sheet");
  auto n = std::make_shared<SheetNode>();
  if (uniform_thickness > 0) {
    if (!std::isfinite(uniform_thickness)) throw GeometryError("sheet thickness must be finite");
    n->thickness = uniform_thickness;
  } else {
    double v = 0;
    if (constant_expression(c.text, &v)) {
      if (!(v >= 0) || !std::isfinite(v)) throw GeometryError("sheet c must be >= 0");
      n->c = v;
    } else {
      check_expression(c.text);
      n->c_constant = false;
      n->c_expr = std::move(c);
    }
  }
  n->children.push_back(phi.ptr());
  return Field(n);
}
Field blend(Field a, Field b, Expression w) {
  require_child(a, "blend");
  require_child(b, "blend");
  check_expression(w.text);
  auto n = std::make_shared<BlendNode>();
  n->w = std::move(w);
  n->children = {a.ptr(), b.ptr()};
  return Field(n);
}
Field expression_field(Expression e) {
  check_expression(e.text);
  auto n = std::make_shared<ExpressionNode>();
  n->e = std::move(e);
  return Field(n);
}

Field unite(std::vector<Field> children) {
  return make_csg(std::move(children), Op::Union, 0, "union");
}
Field intersect(std::vector<Field> children) {
  return make_csg(std::move(children), Op::Intersection, 0, "intersection");
}
Field subtract(std::vector<Field> children) {
  return make_csg(std::move(children), Op::Difference, 0, "difference");
}
Field smooth_unite(std::vector<Field> children, double k) {
  return make_csg(std::move(children), Op::Union, k, "smooth union");
}
Field smooth_intersect(std::vector<Field> children, double k) {
  return make_csg(std::move(children), Op::Intersection, k, "smooth intersection");
}
Field smooth_subtract(std::vector<Field> children, double k) {
  return make_csg(std::move(children), Op::Difference, k, "smooth difference");
}

Field translate(Field child, Vec3 offset) {
  require_child(child, "translate");
  if (!is_finite(offset)) throw GeometryError("translate: offset must be finite");
  auto n = std::make_shared<TransformNode>();
  n->offset = offset;
  n->children.push_back(child.ptr());
  return Field(n);
}
Field scale(Field child, Vec3 f) {
  require_child(child, "scale");
  require_positive(f.x, "scale factor x");
  require_positive(f.y, "scale factor y");
  require_positive(f.z, "scale factor z");
  auto n = std::make_shared<TransformNode>();
  n->to_local = Mat3{{1 / f.x, 0, 0, 0, 1 / f.y, 0, 0, 0, 1 / f.z}};
  n->to_world = Mat3{{f.x, 0, 0, 0, f.y, 0, 0, 0, f.z}};
  const double lo = std::min({f.x, f.y, f.z}), hi = std::max({f.x, f.y, f.z});
  n->value_scale = lo;
  n->lipschitz_factor = hi / lo;
  n->children.push_back(child.ptr());
  return Field(n);
}
Field rotate(Field child, Vec3 degrees) {
  require_child(child, "rotate");
  if (!is_finite(degrees)) throw GeometryError("rotate: angles must be finite");
  const double d2r = std::numbers::pi / 180;
  const Mat3 R =
      rotation_z(degrees.z * d2r) * rotation_y(degrees.y * d2r) * rotation_x(degrees.x * d2r);
  auto n = std::make_shared<TransformNode>();
  n->to_world = R;
  n->to_local = R.transposed();
  n->children.push_back(child.ptr());
  return Field(n);
}
Field fgrade(Field child, std::vector<Expression> fractions, std::vector<std::string> materials) {
  require_child(child, "fgrade");
  if (fractions.size() != materials.size())
    throw GeometryError("fgrade: " + std::to_string(fractions.size()) + " expressions but " +
                        std::to_string(materials.size()) + " materials");
  if (fractions.empty()) throw GeometryError("fgrade: needs at least one material");
  for (const auto& e : fractions) check_expression(e.text);
  auto n = std::make_shared<GradeNode>();
  n->exprs = std::move(fractions);
  n->names = std::move(materials);
  n->children.push_back(child.ptr());
  return Field(n);
}
Field clip_box(Field child, Vec3 min, Vec3 max) {
  require_child(child, "root");
  if (!(min.x < max.x && min.y < max.y && min.z < max.z) || !is_finite(min) || !is_finite(max))
    throw GeometryError("root box: min must be below max on every axis");
  auto n = std::make_shared<ClipBoxNode>();
  n->lo = min;
  n->hi = max;
  n->children.push_back(child.ptr());
  return Field(n);
}

// ---------------------------------------------------------------- a sheet design, split

namespace {

bool contains_tpms(const FieldNode& n) {
  if (dynamic_cast<const TpmsNode*>(&n) || dynamic_cast<const SheetNode*>(&n)) return true;
  for (const auto& c : n.children)
    if (contains_tpms(*c)) return true;
  return false;
}

// Down from n to the one sheet, through root boxes, sharp intersections (their other children
// are envelopes, without a TPMS) and property nodes; false where the design is anything else.
bool split_into(const NodePtr& n, SheetSplit& out, std::vector<Field>& envelopes) {
  if (const auto* sh = dynamic_cast<const SheetNode*>(n.get())) {
    out.phi = Field(sh->children[0]);
    out.c = sh->c_constant ? Expression{fmt::format("{}", sh->c)} : sh->c_expr;
    out.thickness = sh->thickness;
    return true;
  }
  if (const auto* box = dynamic_cast<const ClipBoxNode*>(n.get())) {
    BBox3 b;
    b.add(box->lo);
    b.add(box->hi);
    out.boxes.push_back(b);
    return split_into(n->children[0], out, envelopes);
  }
  if (dynamic_cast<const PropertyNode*>(n.get())) return split_into(n->children[0], out, envelopes);
  const auto* csg = dynamic_cast<const CsgNode*>(n.get());
  if (!csg || csg->op != Op::Intersection || csg->k > 0) return false;
  const NodePtr* lattice = nullptr;
  for (const auto& c : n->children) {
    if (!contains_tpms(*c)) {
      envelopes.emplace_back(c);
      continue;
    }
    if (lattice) return false;  // two lattices intersected
    lattice = &c;
  }
  return lattice && split_into(*lattice, out, envelopes);
}

}  // namespace

std::optional<SheetSplit> split_sheet(const Field& design) {
  if (design.empty()) return std::nullopt;
  SheetSplit out;
  std::vector<Field> envelopes;
  if (!split_into(design.ptr(), out, envelopes)) return std::nullopt;
  if (!envelopes.empty()) out.envelope = intersect(std::move(envelopes));
  return out;
}

bool has_tpms(const Field& design) {
  return !design.empty() && contains_tpms(design.node());
}

// ---------------------------------------------------------------- Evaluator

Evaluator::Evaluator(const Field& field) : field_(field), state_(std::make_unique<State>()) {
  if (field_.empty()) throw GeometryError("empty design");
  state_->materials = &field_.materials();
}
Evaluator::~Evaluator() = default;
Evaluator::Evaluator(Evaluator&&) noexcept = default;
Evaluator& Evaluator::operator=(Evaluator&&) noexcept = default;

double Evaluator::value(Vec3 p) {
  return field_.node().value(p, *state_, 0);
}
void Evaluator::values(const Vec3* points, double* out, std::size_t n) {
  field_.node().eval(points, out, n, *state_, 0);
}
void Evaluator::values_grid(const double* xs, std::size_t w, const double* ys, std::size_t rows,
                            double z, double* out) {
  if (w == 0 || rows == 0) return;
  field_.node().eval_grid({xs, w, ys, rows, z}, out, *state_, 0);
}
bool Evaluator::gradients_grid(const double* xs, std::size_t w, const double* ys, std::size_t rows,
                               double z, Vec3* out) {
  if (w == 0 || rows == 0) return true;
  return field_.node().gradients_grid({xs, w, ys, rows, z}, out, *state_, 0);
}
Vec3 Evaluator::gradient(Vec3 p, double h) {
  Vec3 g;
  if (field_.node().gradient(p, g, *state_, 0)) return g;
  const Vec3 pts[6] = {{p.x + h, p.y, p.z}, {p.x - h, p.y, p.z}, {p.x, p.y + h, p.z},
                       {p.x, p.y - h, p.z}, {p.x, p.y, p.z + h}, {p.x, p.y, p.z - h}};
  double v[6];
  values(pts, v, 6);
  const double inv = 0.5 / h;
  return {(v[0] - v[1]) * inv, (v[2] - v[3]) * inv, (v[4] - v[5]) * inv};
}
double Evaluator::value_gradient(Vec3 p, Vec3* g, double h) {
  double v;
  if (field_.node().value_gradient(p, v, *g, *state_, 0)) return v;
  *g = gradient(p, h);
  return value(p);
}
void Evaluator::gradients(const Vec3* p, Vec3* out, std::size_t n, double h) {
  if (field_.node().gradients(p, out, n, *state_, 0)) return;
  for (std::size_t i = 0; i < n; ++i) out[i] = gradient(p[i], h);
}
Interval Evaluator::bound(const BBox3& box) {
  return field_.node().bound(box, *state_, 0);
}
ProcessValues Evaluator::process(Vec3 p) {
  ProcessValues v;
  field_.node().process(p, v, *state_, 0);
  return v;
}
std::vector<double> Evaluator::fractions(Vec3 p) {
  std::vector<double> out(field_.materials().size(), 0.0);
  if (!out.empty()) field_.node().fractions(p, out.data(), *state_, 0);
  return out;
}
void Evaluator::fractions(const Vec3* points, std::size_t n, double* out) {
  const std::size_t m = field_.materials().size();
  std::fill(out, out + n * m, 0.0);
  if (m > 0 && n > 0) field_.node().fractions(points, n, m, out, *state_, 0);
}

}  // namespace trellis
