// Non-planar slicing: height fields, plane sections, serpentine layers, the paper's test surfaces
// and lattices laid on surfaces. Hand-written: no library slices a height field into continuous
// non-planar serpentines; the mesh parts are a grid index and exact plane/triangle cuts.
#include "trellis/slice/nonplanar.hpp"

#include <fmt/format.h>
#include <muParser.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>

#include "../field/node.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt_mm(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}
std::string fmt_xy(Vec2 p) {
  return "(" + fmt_mm(p.x) + ", " + fmt_mm(p.y) + ")";
}

Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3 unit(Vec3 a) {
  const double n = norm(a);
  return n > 0 ? a * (1.0 / n) : Vec3{0, 0, 1};
}

}  // namespace

// --- the height field ---

struct HeightField::Impl {
  std::string name;
  BBox2 domain;
  std::function<Eval()> make;      // functions
  std::vector<double> profile_xs;  // surfaces constant in Y: x where z is (nearly) linear between

  // Meshes: triangles, facet data, vertex normals and an XY grid of triangle ids.
  std::vector<Vec3> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  double cell = 1;
  int nx = 0, ny = 0;
  std::vector<std::uint32_t> cell_start, cell_tris;

  bool mesh() const { return !triangles.empty(); }

  template <class F>
  void for_cells(const std::array<Vec3, 3>& t, F&& f) const {
    const double x0 = std::min({t[0].x, t[1].x, t[2].x}), x1 = std::max({t[0].x, t[1].x, t[2].x});
    const double y0 = std::min({t[0].y, t[1].y, t[2].y}), y1 = std::max({t[0].y, t[1].y, t[2].y});
    const int i0 = std::clamp(static_cast<int>((x0 - domain.min.x) / cell), 0, nx - 1);
    const int i1 = std::clamp(static_cast<int>((x1 - domain.min.x) / cell), 0, nx - 1);
    const int j0 = std::clamp(static_cast<int>((y0 - domain.min.y) / cell), 0, ny - 1);
    const int j1 = std::clamp(static_cast<int>((y1 - domain.min.y) / cell), 0, ny - 1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) f(j * nx + i);
  }
  std::array<Vec3, 3> tri(std::size_t t) const {
    const auto& v = triangles[t];
    return {vertices[v[0]], vertices[v[1]], vertices[v[2]]};
  }
  // Barycentric coordinates of p in the XY projection of triangle t (tolerance `eps`); false if
  // outside.
  bool locate(std::size_t t, Vec2 p, double b[3], double eps = 1e-9) const {
    const auto q = tri(t);
    const double d = (q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y);
    if (std::abs(d) < 1e-300) return false;
    b[1] = ((p.x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (p.y - q[0].y)) / d;
    b[2] = ((q[1].x - q[0].x) * (p.y - q[0].y) - (p.x - q[0].x) * (q[1].y - q[0].y)) / d;
    b[0] = 1 - b[1] - b[2];
    return b[0] >= -eps && b[1] >= -eps && b[2] >= -eps;
  }
  long find(Vec2 p, double b[3]) const {
    if (!domain.contains(p)) return -1;
    const int i = std::clamp(static_cast<int>((p.x - domain.min.x) / cell), 0, nx - 1);
    const int j = std::clamp(static_cast<int>((p.y - domain.min.y) / cell), 0, ny - 1);
    const std::size_t c = static_cast<std::size_t>(j) * nx + i;
    for (std::uint32_t k = cell_start[c]; k < cell_start[c + 1]; ++k)
      if (locate(cell_tris[k], p, b)) return cell_tris[k];
    return -1;
  }
  double mesh_height(Vec2 p) const {
    double b[3];
    const long t = find(p, b);
    if (t < 0) return kNaN;
    const auto q = tri(static_cast<std::size_t>(t));
    return b[0] * q[0].z + b[1] * q[1].z + b[2] * q[2].z;
  }
};

HeightField HeightField::from_function(std::function<Eval()> make, BBox2 domain, std::string name) {
  if (!(domain.width() > 0 && domain.height() > 0))
    throw GeometryError("surface '" + name + "': empty domain");
  auto impl = std::make_shared<Impl>();
  impl->name = std::move(name);
  impl->domain = domain;
  impl->make = std::move(make);
  HeightField h;
  h.impl_ = impl;
  return h;
}

HeightField HeightField::from_expression(const std::string& expr, BBox2 domain, std::string name) {
  long col = 0;
  try {
    check_expression(expr, &col);
  } catch (const ParseError& e) {
    throw ParseError(e.message(), {"", 0, "height function", col});
  }
  auto make = [expr]() -> Eval {
    auto c = std::make_shared<CompiledExpr>();
    c->parser->SetExpr(expr);
    return [c](double x, double y) { return c->eval({x, y, 0}); };
  };
  return from_function(make, domain, std::move(name));
}

HeightField HeightField::from_mesh(const TriangleMesh& mesh, std::string name) {
  auto impl = std::make_shared<Impl>();
  impl->name = name;
  if (mesh.triangles.empty()) throw GeometryError("surface '" + name + "' has no triangles");
  impl->vertices = mesh.vertices;
  // Drop triangles of zero area; orient every facet upward (any winding is accepted: a height
  // field has one side up everywhere, and folds are found by the overlap test below).
  BBox2 box{{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()},
            {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}};
  double span = 0;
  for (const auto& v : mesh.vertices) {
    box.min = {std::min(box.min.x, v.x), std::min(box.min.y, v.y)};
    box.max = {std::max(box.max.x, v.x), std::max(box.max.y, v.y)};
  }
  span = std::max(box.width(), box.height());
  const double area_eps = 1e-18 * span * span;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    auto v = mesh.triangles[t];
    const Vec3 a = mesh.vertices[v[0]], b = mesh.vertices[v[1]], c = mesh.vertices[v[2]];
    Vec3 n = cross(b - a, c - a);
    const double len = norm(n);
    if (len <= area_eps) continue;
    if (std::abs(n.z) <= 1e-6 * len) {
      const Vec3 m = (a + b + c) * (1.0 / 3);
      throw GeometryError("surface '" + name + "' is not a height field: triangle " +
                          std::to_string(t) + " is vertical at " + fmt_xy(m.xy()) + ", z " +
                          fmt_mm(std::min({a.z, b.z, c.z})) + " to " +
                          fmt_mm(std::max({a.z, b.z, c.z})) + " (a point above another)");
    }
    if (n.z < 0) {
      std::swap(v[1], v[2]);
      n = n * -1.0;
    }
    impl->triangles.push_back(v);
  }
  if (impl->triangles.empty()) throw GeometryError("surface '" + name + "' has no triangles");
  const double pad = 1e-9 * std::max(1.0, span);
  box.min = box.min - Vec2{pad, pad};
  box.max = box.max + Vec2{pad, pad};
  impl->domain = box;
  // Grid of about two triangles per cell.
  const double area = std::max(box.width() * box.height(), 1e-12);
  impl->cell =
      std::max(std::sqrt(area / static_cast<double>(impl->triangles.size()) * 2.0), span * 1e-6);
  impl->nx = std::max(1, static_cast<int>(std::ceil(box.width() / impl->cell)));
  impl->ny = std::max(1, static_cast<int>(std::ceil(box.height() / impl->cell)));
  const std::size_t cells = static_cast<std::size_t>(impl->nx) * impl->ny;
  std::vector<std::uint32_t> count(cells + 1, 0);
  for (std::size_t t = 0; t < impl->triangles.size(); ++t)
    impl->for_cells(impl->tri(t), [&](std::size_t c) { ++count[c + 1]; });
  for (std::size_t c = 0; c < cells; ++c) count[c + 1] += count[c];
  impl->cell_start = count;
  impl->cell_tris.resize(count[cells]);
  for (std::size_t t = 0; t < impl->triangles.size(); ++t)
    impl->for_cells(impl->tri(t), [&](std::size_t c) {
      impl->cell_tris[count[c]++] = static_cast<std::uint32_t>(t);
    });

  // Height-field test: no two facets overlap in XY (separating axis test on their projections,
  // overlaps thinner than a nanometre-scale tolerance ignored: neighbours share edges).
  const double tol = 1e-9 * std::max(1.0, span);
  std::atomic<long> bad_a{-1};
  std::atomic<long> bad_b{-1};
  auto separated = [&](const std::array<Vec3, 3>& p, const std::array<Vec3, 3>& q) {
    for (int pass = 0; pass < 2; ++pass) {
      const auto& s = pass == 0 ? p : q;
      for (int e = 0; e < 3; ++e) {
        const Vec2 a = s[e].xy(), b = s[(e + 1) % 3].xy();
        Vec2 n{-(b.y - a.y), b.x - a.x};
        const double len = std::hypot(n.x, n.y);
        if (len == 0) continue;
        n = n * (1.0 / len);
        double p0 = 1e300, p1 = -1e300, q0 = 1e300, q1 = -1e300;
        for (int k = 0; k < 3; ++k) {
          const double u = n.x * p[k].x + n.y * p[k].y, w = n.x * q[k].x + n.y * q[k].y;
          p0 = std::min(p0, u), p1 = std::max(p1, u), q0 = std::min(q0, w), q1 = std::max(q1, w);
        }
        if (std::min(p1, q1) - std::max(p0, q0) <= tol) return true;
      }
    }
    return false;
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells), [&](const auto& r) {
    for (std::size_t c = r.begin(); c != r.end() && bad_a.load() < 0; ++c)
      for (std::uint32_t i = impl->cell_start[c]; i < impl->cell_start[c + 1]; ++i)
        for (std::uint32_t j = i + 1; j < impl->cell_start[c + 1]; ++j) {
          const auto ta = impl->cell_tris[i], tb = impl->cell_tris[j];
          if (!separated(impl->tri(ta), impl->tri(tb))) {
            long expected = -1;
            if (bad_a.compare_exchange_strong(expected, std::min(ta, tb))) bad_b = std::max(ta, tb);
            return;
          }
        }
  });
  if (bad_a >= 0) {
    const auto p = impl->tri(static_cast<std::size_t>(bad_a)),
               q = impl->tri(static_cast<std::size_t>(bad_b));
    // A point inside both projections: the centroid of whichever lies in the other, else the
    // midpoint of the centroids.
    const Vec3 cp = (p[0] + p[1] + p[2]) * (1.0 / 3), cq = (q[0] + q[1] + q[2]) * (1.0 / 3);
    double b[3];
    Vec2 at = (cp.xy() + cq.xy()) * 0.5;
    if (impl->locate(static_cast<std::size_t>(bad_a), cq.xy(), b))
      at = cq.xy();
    else if (impl->locate(static_cast<std::size_t>(bad_b), cp.xy(), b))
      at = cp.xy();
    auto z_on = [&](long t) {
      double bb[3];
      impl->locate(static_cast<std::size_t>(t), at, bb, 1e9);
      const auto s = impl->tri(static_cast<std::size_t>(t));
      return bb[0] * s[0].z + bb[1] * s[1].z + bb[2] * s[2].z;
    };
    throw GeometryError("surface '" + name + "' is not a height field: triangles " +
                        std::to_string(bad_a.load()) + " and " + std::to_string(bad_b.load()) +
                        " lie above one another near " + fmt_xy(at) + " (z " + fmt_mm(z_on(bad_a)) +
                        " and " + fmt_mm(z_on(bad_b)) + ")");
  }
  HeightField h;
  h.impl_ = impl;
  return h;
}

HeightField HeightField::from_profile(const Profile& profile, double y0, double y1,
                                      std::string name) {
  auto z = profile_function(profile);
  const double x0 = profile.corners.front().x, x1 = profile.corners.back().x;
  auto make = [z]() -> Eval { return [z](double x, double) { return z(x); }; };
  HeightField h = from_function(make, {{x0, y0}, {x1, y1}}, std::move(name));
  auto impl = std::make_shared<Impl>(*h.impl_);
  impl->profile_xs = profile_breaks(profile);
  h.impl_ = impl;
  return h;
}

TriangleMesh surface_mesh(const HeightField& surface, double resolution) {
  const auto& impl = surface.impl();
  TriangleMesh mesh;
  if (impl.mesh()) {
    mesh.vertices = impl.vertices;
    mesh.triangles = impl.triangles;
    return mesh;
  }
  if (!(resolution > 0) || !std::isfinite(resolution))
    throw SettingError("mesh resolution must be a finite number > 0",
                       {"", 0, "surface.resolution"});
  const BBox2 box = surface.domain();
  if (!std::isfinite(box.width()) || !std::isfinite(box.height()))
    throw GeometryError("surface '" + surface.name() + "' has a domain that is not finite",
                        {"", 0, "surface.resolution"});
  // Grid intervals along X and Y, checked as doubles before any count becomes an integer: a
  // grid of more than kMaxGridPoints (about 80 bytes each with its triangles) is refused.
  constexpr double kMaxGridPoints = 5e7;
  const bool profiled = !impl.profile_xs.empty();
  const double nx = profiled ? static_cast<double>(impl.profile_xs.size()) - 1
                             : std::max(1.0, std::ceil(box.width() / resolution));
  const double ny = profiled ? 1.0 : std::max(1.0, std::ceil(box.height() / resolution));
  const double points = (nx + 1) * (ny + 1);
  if (!(points <= kMaxGridPoints))
    throw ResourceError(
        fmt::format("surface '{}': a {:g} x {:g} mm domain at {:g} mm resolution is "
                    "a grid of {:.3g} points (about {:.3g} GB; at most {:g}): raise "
                    "surface.resolution",
                    surface.name(), box.width(), box.height(), resolution, points,
                    points * 80 / 1e9, kMaxGridPoints),
        {"", 0, "surface.resolution"});
  std::vector<double> xs = impl.profile_xs, ys;
  if (xs.empty()) {
    const long n = static_cast<long>(nx);
    for (long i = 0; i <= n; ++i) xs.push_back(box.min.x + box.width() * i / n);
  }
  if (profiled) {
    ys = {box.min.y, box.max.y};
  } else {
    const long n = static_cast<long>(ny);
    for (long j = 0; j <= n; ++j) ys.push_back(box.min.y + box.height() * j / n);
  }
  const auto f = surface.evaluator();
  std::vector<long> id(xs.size() * ys.size(), -1);
  for (std::size_t j = 0; j < ys.size(); ++j)
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const double z = f(xs[i], ys[j]);
      if (!std::isfinite(z)) continue;
      id[j * xs.size() + i] = static_cast<long>(mesh.vertices.size());
      mesh.vertices.push_back({xs[i], ys[j], z});
    }
  auto add = [&](long a, long b, long c) {
    if (a >= 0 && b >= 0 && c >= 0)
      mesh.triangles.push_back({static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b),
                                static_cast<std::uint32_t>(c)});
  };
  for (std::size_t j = 0; j + 1 < ys.size(); ++j)
    for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
      const long a = id[j * xs.size() + i], b = id[j * xs.size() + i + 1],
                 c = id[(j + 1) * xs.size() + i + 1], d = id[(j + 1) * xs.size() + i];
      add(a, b, c);
      add(a, c, d);
    }
  if (mesh.triangles.empty())
    throw GeometryError("surface '" + surface.name() + "' has no footprint at this resolution");
  return mesh;
}

const std::string& HeightField::name() const {
  return impl_->name;
}
BBox2 HeightField::domain() const {
  return impl_->domain;
}
bool HeightField::is_mesh() const {
  return impl_->mesh();
}

HeightField::Eval HeightField::evaluator() const {
  if (impl_->mesh()) {
    auto impl = impl_;
    return [impl](double x, double y) { return impl->mesh_height({x, y}); };
  }
  Eval f = impl_->make();
  const BBox2 d = impl_->domain;
  // Points a rounding error outside the domain (line ends, connectors along its edge) count.
  const double eps = 1e-9 * std::max({1.0, d.width(), d.height()});
  return [f, d, eps](double x, double y) {
    if (x < d.min.x - eps || x > d.max.x + eps || y < d.min.y - eps || y > d.max.y + eps)
      return kNaN;
    const double z = f(x, y);
    return std::isfinite(z) ? z : kNaN;
  };
}

double HeightField::height(Vec2 p) const {
  if (impl_->mesh()) return impl_->mesh_height(p);
  return evaluator()(p.x, p.y);
}

OffsetMode offset_mode_from_string(const std::string& name) {
  if (name == "vertical") return OffsetMode::Vertical;
  if (name == "normal") return OffsetMode::Normal;
  throw SettingError("unknown offset mode '" + name + "' (expected vertical or normal)");
}
const char* to_string(OffsetMode m) {
  return m == OffsetMode::Vertical ? "vertical" : "normal";
}

namespace {

// --- curves on the surface ---

// Starts of a multi-start search: the best samples (value, point), at most `count`, each at
// least `separation` from the ones chosen before (the best few often sit on one hill).
std::vector<std::pair<double, Vec2>> diverse_starts(std::vector<std::pair<double, Vec2>>& samples,
                                                    std::size_t count, double separation) {
  std::sort(samples.begin(), samples.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::pair<double, Vec2>> out;
  for (const auto& s : samples) {
    if (out.size() == count || s.first <= -1e299) break;
    bool far = true;
    for (const auto& o : out)
      far = far && std::hypot(s.second.x - o.second.x, s.second.y - o.second.y) >= separation;
    if (far) out.push_back(s);
  }
  return out;
}

// Sixteen unit directions: creases of folded surfaces and meshes make ridges that a search
// along the axes alone stalls on.
const std::array<Vec2, 16> kCompass = [] {
  std::array<Vec2, 16> d{};
  for (int k = 0; k < 16; ++k)
    d[k] = {std::cos(k * std::numbers::pi / 8), std::sin(k * std::numbers::pi / 8)};
  return d;
}();

// Compass search (sixteen directions, step halved down to `min_step`) for a maximum of fn from
// `at`, whose value is `v`; returns the value found.
template <class F>
double climb(F&& fn, Vec2 at, double v, double step, double min_step) {
  for (; step > min_step; step *= 0.5) {
    bool moved = true;
    for (int guard = 0; moved && guard < 64; ++guard) {
      moved = false;
      for (Vec2 u : kCompass) {
        const Vec2 q = at + u * step;
        const double w = fn(q);
        if (w > v) v = w, at = q, moved = true;
      }
    }
  }
  return v;
}

// Height above XY point p of the surface offset by d along its normals: the upper envelope of
// balls of radius d centred on the surface, max over |q − p| <= d of f(q) + sqrt(d² − |q − p|²).
// Equal to the normal offset where the surface bends gently, and still exact in valleys sharper
// than d (where plain normal offsets cross over each other). Polar samples of the disc, then a
// compass search from the best, and from the next best that lie away from it: on folded
// surfaces the maximum can sit on a crease or at the footprint's edge, off the first hill.
double envelope_height(const HeightField::Eval& f, Vec2 p, double d) {
  const double z0 = f(p.x, p.y);
  if (!std::isfinite(z0) || d <= 0) return z0;
  auto value = [&](Vec2 q) {
    const double r2 = (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y);
    if (r2 > d * d) return -1e300;
    const double z = f(q.x, q.y);
    return std::isfinite(z) ? z + std::sqrt(d * d - r2) : -1e300;
  };
  constexpr int kRadii = 6, kAngles = 16;
  // Unit offsets of the polar samples, computed once.
  static const auto ring = [] {
    std::array<Vec2, kRadii * kAngles> u{};
    for (int i = 1; i <= kRadii; ++i)
      for (int j = 0; j < kAngles; ++j) {
        const double r = static_cast<double>(i) / kRadii, a = 2 * std::numbers::pi * j / kAngles;
        u[static_cast<std::size_t>((i - 1) * kAngles + j)] = {r * std::cos(a), r * std::sin(a)};
      }
    return u;
  }();
  std::array<std::pair<double, Vec2>, kRadii * kAngles + 1> samples;
  samples[0] = {z0 + d, p};
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const Vec2 q = p + ring[i] * d;
    samples[i + 1] = {value(q), q};
  }
  // The best sample's hill first; of the next three best samples, those away from it start
  // searches of their own (on smooth surfaces they sit on the same hill and are skipped).
  std::partial_sort(samples.begin(), samples.begin() + 4, samples.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  const Vec2 first = samples[0].second;
  double vb = climb(value, first, samples[0].first, d / kRadii, 1e-7);
  for (int k = 1; k < 4; ++k) {
    const auto& [v, q] = samples[static_cast<std::size_t>(k)];
    if (v > -1e299 && std::hypot(q.x - first.x, q.y - first.y) > d / 3)
      vb = std::max(vb, climb(value, q, v, d / kRadii, 1e-7));
  }
  return vb;
}

// A point of the (offset) surface above XY point p: NaN outside the footprint. Paths stay in
// their vertical planes in both modes, so the spacing is the path width.
struct SurfacePoint {
  const HeightField::Eval& f;
  OffsetMode mode;
  double offset;
  Vec3 operator()(Vec2 p) const {
    const double z = mode == OffsetMode::Vertical || offset == 0 ? f(p.x, p.y) + offset
                                                                 : envelope_height(f, p, offset);
    if (!std::isfinite(z)) return {kNaN, kNaN, kNaN};
    return {p.x, p.y, z};
  }
};

// Samples the curve c(s) = surface point above a + (b − a)·s for s in [s0, s1] where it exists:
// pieces split where the footprint ends (ends found by bisection), each refined until the curve
// at the quarter points of every chord is within `tol` of it.
std::vector<std::vector<Vec3>> sample_curve(const SurfacePoint& sp, Vec2 a, Vec2 b, double tol,
                                            double base_step, std::size_t* jumps = nullptr) {
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  std::vector<std::vector<Vec3>> pieces;
  if (len <= 0) return pieces;
  auto at = [&](double s) { return sp(a + (b - a) * (s / len)); };
  // At most 20,000 base samples per curve (the refinement adds points where the surface bends),
  // so a curve metres long cannot take millions of evaluations.
  base_step = std::max(base_step, len / 20000);
  const int n = std::max(1, static_cast<int>(std::ceil(len / base_step)));
  std::vector<double> ss(static_cast<std::size_t>(n) + 1);
  std::vector<Vec3> ps(ss.size());
  for (int i = 0; i <= n; ++i) {
    ss[static_cast<std::size_t>(i)] = len * i / n;
    ps[static_cast<std::size_t>(i)] = at(ss[static_cast<std::size_t>(i)]);
  }
  const double min_step = 1e-5;
  std::vector<Vec3> cur;
  // A chord steeper than 100:1 that still rises by more than the tolerance when narrowed to
  // 0.1 µm (bisection keeping the half with the larger rise) is a jump, not a steep slope: a
  // continuous surface's rise vanishes with the interval.
  auto is_jump = [&](double s0, Vec3 p0, double s1, Vec3 p1) {
    if (!(std::abs(p1.z - p0.z) > tol && std::abs(p1.z - p0.z) > 100 * (s1 - s0))) return false;
    for (int k = 0; k < 60 && s1 - s0 > 1e-7; ++k) {
      const double sm = 0.5 * (s0 + s1);
      const Vec3 pm = at(sm);
      if (!is_finite(pm)) return false;
      if (std::abs(pm.z - p0.z) >= std::abs(p1.z - pm.z))
        s1 = sm, p1 = pm;
      else
        s0 = sm, p0 = pm;
    }
    return std::abs(p1.z - p0.z) > tol;
  };
  // Refines between (s0,p0) and (s1,p1), appending points after p0 up to p1.
  auto refine = [&](auto&& self, double s0, Vec3 p0, double s1, Vec3 p1, int depth) -> void {
    if (s1 - s0 > min_step && depth < 40) {
      const double sm = 0.5 * (s0 + s1);
      const Vec3 pm = at(sm);
      bool split = !is_finite(pm);
      if (!split) {
        for (double f : {0.25, 0.5, 0.75}) {
          const Vec3 q = f == 0.5 ? pm : at(s0 + (s1 - s0) * f);
          if (!is_finite(q) || distance_to_segment(q, p0, p1) > tol) {
            split = true;
            break;
          }
        }
      }
      if (split && is_finite(pm)) {
        self(self, s0, p0, sm, pm, depth + 1);
        self(self, sm, pm, s1, p1, depth + 1);
        return;
      }
    }
    if (is_jump(s0, p0, s1, p1)) {
      // The surface jumps here (a discontinuous height function): split the path instead of
      // printing a bridge through the air.
      if (jumps) ++*jumps;
      if (cur.size() >= 2 && distance(cur.front(), cur.back()) > 1e-4) pieces.push_back(cur);
      cur.clear();
    }
    cur.push_back(p1);
  };
  // Bisection for the footprint edge between a finite and a missing sample.
  auto edge = [&](double s_in, double s_out) {
    for (int k = 0; k < 60 && std::abs(s_out - s_in) > 1e-7; ++k) {
      const double m = 0.5 * (s_in + s_out);
      if (is_finite(at(m)))
        s_in = m;
      else
        s_out = m;
    }
    return s_in;
  };
  auto close = [&] {
    if (cur.size() >= 2 && distance(cur.front(), cur.back()) > 1e-4) pieces.push_back(cur);
    cur.clear();
  };
  double prev_s = 0;
  Vec3 prev = ps[0];
  if (is_finite(prev)) cur.push_back(prev);
  for (std::size_t i = 1; i < ss.size(); ++i) {
    const Vec3 p = ps[i];
    const bool fin_prev = is_finite(prev), fin = is_finite(p);
    if (fin_prev && fin) {
      refine(refine, prev_s, prev, ss[i], p, 0);
    } else if (fin_prev && !fin) {
      const double e = edge(prev_s, ss[i]);
      if (e > prev_s) refine(refine, prev_s, prev, e, at(e), 0);
      close();
    } else if (!fin_prev && fin) {
      const double e = edge(ss[i], prev_s);
      cur.push_back(at(e));
      if (ss[i] > e) refine(refine, e, cur.back(), ss[i], p, 0);
    }
    prev_s = ss[i];
    prev = p;
  }
  close();
  return pieces;
}

// A connector from a to b (ends of pieces on neighbouring lines, both on the footprint's edge)
// whose straight way crosses a hole: each sample inside the hole is pushed along `away` (the
// lines' direction, away from the hole) to just inside the hole's edge (by `margin`), so the
// connector hugs the edge in
// the strip between the two lines, where no other line runs. Empty if it cannot.
std::vector<Vec3> hug_connector(const SurfacePoint& sp, Vec3 a, Vec3 b, Vec2 away, double step,
                                double reach, double margin) {
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  const int n = std::max(2, static_cast<int>(std::ceil(len / step)));
  std::vector<Vec3> out{a};
  for (int i = 1; i < n; ++i) {
    const Vec2 q = a.xy() + (b.xy() - a.xy()) * (static_cast<double>(i) / n);
    Vec3 p = sp(q);
    if (!is_finite(p)) {
      double lo = 0, hi = step;  // inside at lo; march out to a finite hi, then bisect
      while (hi <= reach && !is_finite(sp(q + away * hi))) lo = hi, hi *= 2;
      if (hi > reach) return {};
      for (int k = 0; k < 50 && hi - lo > 1e-7; ++k) {
        const double m = 0.5 * (lo + hi);
        (is_finite(sp(q + away * m)) ? hi : lo) = m;
      }
      // A margin inside the footprint, so chords between edge points (sagitta step²/8R) stay on it.
      p = sp(q + away * (hi + margin));
      if (!is_finite(p)) return {};
    }
    out.push_back(p);
  }
  out.push_back(b);
  // Every chord must stay over the footprint (the self-check's test); otherwise travel.
  for (std::size_t i = 1; i < out.size(); ++i)
    if (!is_finite(sp((out[i - 1].xy() + out[i].xy()) * 0.5))) return {};
  return out;
}

// Whether the footprint goes on past the end `a` of a piece (coming from `before`): a hole, not
// the outer edge. Marches on in steps of `step` until the domain ends.
bool hole_ahead(const SurfacePoint& sp, Vec3 a, Vec3 before, const BBox2& box, double step) {
  Vec2 t{a.x - before.x, a.y - before.y};
  const double len = std::hypot(t.x, t.y);
  if (len <= 0) return false;
  t = t * (1 / len);
  for (Vec2 q = a.xy() + t * step;
       q.x >= box.min.x && q.x <= box.max.x && q.y >= box.min.y && q.y <= box.max.y;
       q = q + t * step)
    if (is_finite(sp(q))) return true;
  return false;
}

// The u-interval of the line {p : dot(p, n) = v} (direction d) inside a box, empty if none.
bool clip_line(const BBox2& box, Vec2 d, Vec2 n, double v, double* u0, double* u1) {
  double lo = -1e300, hi = 1e300;
  const Vec2 o = n * v;  // a point of the line; points are o + d·u
  const double oc[2] = {o.x, o.y}, dc[2] = {d.x, d.y};
  const double mn[2] = {box.min.x, box.min.y}, mx[2] = {box.max.x, box.max.y};
  for (int k = 0; k < 2; ++k) {
    if (std::abs(dc[k]) < 1e-15) {
      if (oc[k] < mn[k] || oc[k] > mx[k]) return false;
      continue;
    }
    double a = (mn[k] - oc[k]) / dc[k], b = (mx[k] - oc[k]) / dc[k];
    if (a > b) std::swap(a, b);
    lo = std::max(lo, a), hi = std::min(hi, b);
  }
  if (hi <= lo) return false;
  *u0 = lo, *u1 = hi;
  return true;
}

struct Line {
  double v = 0;
  std::vector<std::vector<Vec3>> pieces;  // in increasing u
  std::size_t jumps = 0;                  // where the surface jumps (split, sample_curve)
};

// Exact sections of a mesh by the lines v = v_i (direction d): triangle cuts chained in u.
// Throws when two cuts overlap in u at different heights (a fold the facet test cannot see).
void mesh_sections(const HeightField::Impl& m, Vec2 d, Vec2 n, std::vector<Line>& lines, double v0,
                   double w, const std::string& name) {
  std::vector<std::vector<std::uint32_t>> bucket(lines.size());
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const auto q = m.tri(t);
    double lo = 1e300, hi = -1e300;
    for (const auto& p : q) {
      const double v = n.x * p.x + n.y * p.y;
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
    const long i0 = std::max(0L, static_cast<long>(std::ceil((lo - v0) / w - 1e-12)));
    const long i1 = std::min(static_cast<long>(lines.size()) - 1,
                             static_cast<long>(std::floor((hi - v0) / w + 1e-12)));
    for (long i = i0; i <= i1; ++i)
      bucket[static_cast<std::size_t>(i)].push_back(static_cast<std::uint32_t>(t));
  }
  std::mutex error_mutex;
  std::string error;
  tbb::parallel_for(std::size_t{0}, lines.size(), [&](std::size_t li) {
    const double vl = lines[li].v;
    struct Cut {
      double u0, u1;
      Vec3 p0, p1;
    };
    std::vector<Cut> cuts;
    for (auto t : bucket[li]) {
      const auto q = m.tri(t);
      // Vertices on the line count as above it, so each crossing is found once.
      Vec3 hits[3];
      int nh = 0;
      for (int e = 0; e < 3; ++e) {
        const Vec3 a = q[e], b = q[(e + 1) % 3];
        const double va = n.x * a.x + n.y * a.y - vl, vb = n.x * b.x + n.y * b.y - vl;
        if ((va >= 0) != (vb >= 0)) {
          const double s = va / (va - vb);
          hits[nh++] = a + (b - a) * s;
        }
      }
      if (nh != 2) continue;
      double u0 = d.x * hits[0].x + d.y * hits[0].y, u1 = d.x * hits[1].x + d.y * hits[1].y;
      Vec3 p0 = hits[0], p1 = hits[1];
      if (u1 < u0) std::swap(u0, u1), std::swap(p0, p1);
      if (u1 - u0 < 1e-12) continue;
      cuts.push_back({u0, u1, p0, p1});
    }
    std::sort(cuts.begin(), cuts.end(), [](const Cut& a, const Cut& b) { return a.u0 < b.u0; });
    auto& pieces = lines[li].pieces;
    double end_u = -1e300;
    const double eps = 1e-7;
    for (const auto& c : cuts) {
      if (!pieces.empty() && c.u0 < end_u - eps) {
        std::lock_guard lock(error_mutex);
        if (error.empty())
          error = "surface '" + name + "' is not a height field: above " + fmt_xy(c.p0.xy()) +
                  " it is at z " + fmt_mm(c.p0.z) + " and at z " + fmt_mm(pieces.back().back().z);
        return;
      }
      if (!pieces.empty() && c.u0 <= end_u + eps &&
          std::abs(c.p0.z - pieces.back().back().z) < 1e-6)
        pieces.back().push_back(c.p1);
      else
        pieces.push_back({c.p0, c.p1});
      end_u = c.u1;
    }
  });
  if (!error.empty()) throw GeometryError(error);
}

// The extent of a function's footprint across direction d (along n): a grid of samples, then
// each side refined by bisection on "does the line at v meet the surface" — so the lines can be
// centred on the footprint, not on the domain around it.
void footprint_vrange(const HeightField& surface, Vec2 d, Vec2 n, double w, double* vlo,
                      double* vhi) {
  const BBox2 box = surface.domain();
  auto f = surface.evaluator();
  const double step = std::max(w / 4, std::max(box.width(), box.height()) / 2000);
  const long nx = static_cast<long>(std::ceil(box.width() / step));
  const long ny = static_cast<long>(std::ceil(box.height() / step));
  double lo = 1e300, hi = -1e300;
  for (long j = 0; j <= ny; ++j)
    for (long i = 0; i <= nx; ++i) {
      const double x = box.min.x + box.width() * i / nx, y = box.min.y + box.height() * j / ny;
      if (!std::isfinite(f(x, y))) continue;
      const double v = n.x * x + n.y * y;
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
  if (lo > hi)
    throw GeometryError("surface '" + surface.name() + "' has no footprint in its domain");
  double dlo = 1e300, dhi = -1e300;
  for (Vec2 c : {box.min, box.max, Vec2{box.min.x, box.max.y}, Vec2{box.max.x, box.min.y}}) {
    const double v = n.x * c.x + n.y * c.y;
    dlo = std::min(dlo, v), dhi = std::max(dhi, v);
  }
  auto meets = [&](double v) {
    double u0, u1;
    if (!clip_line(box, d, n, v, &u0, &u1)) return false;
    const double s = std::min(step / 2, 0.05);
    for (double u = u0; u <= u1; u += s)
      if (std::isfinite(f(n.x * v + d.x * u, n.y * v + d.y * u))) return true;
    return std::isfinite(f(n.x * v + d.x * u1, n.y * v + d.y * u1));
  };
  auto refine = [&](double in, double out) {
    if (meets(out)) return out;
    for (int k = 0; k < 30 && std::abs(out - in) > 1e-6; ++k) {
      const double m = 0.5 * (in + out);
      (meets(m) ? in : out) = m;
    }
    return in;
  };
  *vlo = refine(lo, std::max(dlo, lo - 2 * step));
  *vhi = refine(hi, std::min(dhi, hi + 2 * step));
}

// The range of v = n·p over the footprint.
void line_range(const HeightField& surface, Vec2 d, Vec2 n, double w, double* vlo, double* vhi) {
  *vlo = 1e300, *vhi = -1e300;
  const auto& impl = surface.impl();
  if (impl.mesh()) {
    for (const auto& t : impl.triangles)
      for (auto vi : t) {
        const double v = n.x * impl.vertices[vi].x + n.y * impl.vertices[vi].y;
        *vlo = std::min(*vlo, v), *vhi = std::max(*vhi, v);
      }
  } else {
    footprint_vrange(surface, d, n, w, vlo, vhi);
  }
}

// Line offsets `w` apart along the surface: the arc length across the lines, s(v), integrated
// in steps of w/8 and averaged over 17 points along each step's line, then inverted.
std::vector<double> surface_spaced(const HeightField& surface, Vec2 d, Vec2 n, double vlo,
                                   double vhi, double w) {
  auto f = surface.evaluator();
  const BBox2 box = surface.domain();
  const long steps = std::max(1L, static_cast<long>(std::ceil((vhi - vlo) / (w / 8))));
  const double dv = (vhi - vlo) / static_cast<double>(steps);
  std::vector<double> s(static_cast<std::size_t>(steps) + 1, 0.0);
  for (long k = 0; k < steps; ++k) {
    const double v = vlo + dv * static_cast<double>(k);
    double u0, u1, sum = 0;
    int count = 0;
    if (dv > 0 && clip_line(box, d, n, v + dv / 2, &u0, &u1))
      for (int j = 0; j <= 16; ++j) {
        const double u = u0 + (u1 - u0) * j / 16.0;
        const Vec2 p = n * v + d * u, q = n * (v + dv) + d * u;
        const double z0 = f(p.x, p.y), z1 = f(q.x, q.y);
        if (!std::isfinite(z0) || !std::isfinite(z1)) continue;
        sum += std::hypot(dv, z1 - z0);
        ++count;
      }
    s[static_cast<std::size_t>(k) + 1] =
        s[static_cast<std::size_t>(k)] + (count ? sum / count : dv);
  }
  const double total = s.back();
  const auto lines = static_cast<std::size_t>(std::max(1.0, std::round(total / w)));
  const double s0 = 0.5 * (total - static_cast<double>(lines - 1) * w);
  std::vector<double> out;
  std::size_t k = 0;
  for (std::size_t i = 0; i < lines; ++i) {
    const double target = s0 + static_cast<double>(i) * w;
    while (k + 1 < s.size() - 1 && s[k + 1] < target) ++k;
    const double ds = s[k + 1] - s[k];
    const double t = ds > 0 ? std::clamp((target - s[k]) / ds, 0.0, 1.0) : 0.0;
    out.push_back(vlo + dv * (static_cast<double>(k) + t));
  }
  return out;
}

}  // namespace

std::vector<double> nonplanar_line_positions(const HeightField& surface, double angle_deg,
                                             const NonplanarParams& prm) {
  const double a = angle_deg * std::numbers::pi / 180;
  const Vec2 d{std::cos(a), std::sin(a)}, n{-std::sin(a), std::cos(a)};
  double vlo, vhi;
  line_range(surface, d, n, prm.width, &vlo, &vhi);
  const double w = prm.width;
  if (prm.spacing_along_surface) return surface_spaced(surface, d, n, vlo, vhi, w);
  const std::size_t count = static_cast<std::size_t>(std::max(1.0, std::round((vhi - vlo) / w)));
  const double v0 = vlo + 0.5 * ((vhi - vlo) - static_cast<double>(count - 1) * w);
  std::vector<double> out(count);
  for (std::size_t i = 0; i < count; ++i) out[i] = v0 + static_cast<double>(i) * w;
  return out;
}

namespace {

// The plane sections of one layer: lines across the footprint spaced by the width (in the
// slicing direction or along the surface), each cut into pieces where the surface exists,
// sampled within the chord tolerance.
std::vector<Line> layer_lines(const HeightField& surface, double angle_deg, double offset,
                              const NonplanarParams& prm,
                              const std::function<void(double)>& advance = {}) {
  const double a = angle_deg * std::numbers::pi / 180;
  const Vec2 d{std::cos(a), std::sin(a)}, n{-std::sin(a), std::cos(a)};
  const BBox2 box = surface.domain();
  const auto& impl = surface.impl();
  const double w = prm.width;
  const std::vector<double> vs = nonplanar_line_positions(surface, angle_deg, prm);
  std::vector<Line> lines(vs.size());
  for (std::size_t i = 0; i < vs.size(); ++i) lines[i].v = vs[i];
  const double v0 = vs.front();
  const double tol = prm.chord_tolerance;
  // Mesh sections walk evenly spaced planes; surface spacing samples the mesh like a function.
  if (impl.mesh() && !prm.spacing_along_surface &&
      (prm.offset == OffsetMode::Vertical || offset == 0)) {
    mesh_sections(impl, d, n, lines, v0, w, surface.name());
    tbb::parallel_for(std::size_t{0}, lines.size(), [&](std::size_t i) {
      for (auto& p : lines[i].pieces) {
        p = simplify_polyline(p, tol);
        if (offset != 0)
          for (auto& q : p) q.z += offset;
      }
    });
    if (advance) advance(1.0);
    return lines;
  }
  // Functions (and meshes in normal mode): adaptive sampling along each line; the deviation is
  // refined at half the tolerance and simplified with the other half.
  tbb::enumerable_thread_specific<HeightField::Eval> evals([&] { return surface.evaluator(); });
  const double step = std::clamp(w / 4, 0.01, 0.1);
  tbb::parallel_for(std::size_t{0}, lines.size(), [&](std::size_t i) {
    double u0, u1;
    if (!clip_line(box, d, n, lines[i].v, &u0, &u1)) {
      if (advance) advance(1.0 / static_cast<double>(lines.size()));
      return;
    }
    auto& f = evals.local();
    const SurfacePoint sp{f, prm.offset, offset};
    const Vec2 o = n * lines[i].v;
    lines[i].pieces = sample_curve(sp, o + d * u0, o + d * u1, tol * 0.5, step, &lines[i].jumps);
    for (auto& p : lines[i].pieces) p = simplify_polyline(p, tol * 0.5);
    if (advance) advance(1.0 / static_cast<double>(lines.size()));
  });
  return lines;
}

}  // namespace

NonplanarResult slice_nonplanar(const HeightField& surface, const NonplanarParams& prm,
                                const Progress& progress) {
  if (!(prm.width > 0) || !(prm.layer_height >= 0) || prm.layers < 1 || prm.angles.empty() ||
      prm.layer_tools.empty() || !(prm.chord_tolerance > 0))
    throw SettingError(
        "non-planar slicing needs width > 0, layer height >= 0, layers >= 1, at least one angle "
        "and tool, and a chord tolerance > 0");
  for (int t : prm.layer_tools)
    if (t < 0) throw SettingError("tool numbers start at 0", {"", 0, "layer tools"});
  const double max_join = prm.max_join > 0 ? prm.max_join : 4 * prm.width;
  NonplanarResult res;
  res.toolpath.source = "trellis nonplanar (" + surface.name() + ")";
  res.toolpath.layers.resize(static_cast<std::size_t>(prm.layers));
  res.layers.resize(res.toolpath.layers.size());
  // Vertical mode: one set of sections per direction a layer uses (1,000 angles over 6 layers
  // are 6 directions, as estimated), lifted per layer.
  std::map<double, std::vector<Line>> base;
  if (prm.offset == OffsetMode::Vertical)
    for (std::size_t k = 0; k < res.layers.size() && k < prm.angles.size(); ++k) {
      progress.check("non-planar slicing");
      const double a = prm.angles[k];
      if (!base.count(a)) base[a] = layer_lines(surface, a, 0, prm);
    }
  std::vector<std::vector<Line>> per_layer(res.layers.size());
  // The sections (normal offsets: the slow part) from worker threads, as layers finish.
  const char* stage = prm.offset == OffsetMode::Vertical ? "sections" : "normal offsets";
  std::atomic<double> sectioned{0};  // layers' worth of lines done
  const double total = static_cast<double>(res.layers.size());
  progress(stage, 0.0);
  std::function<void(double)> advance;
  if (progress.report)
    advance = [&](double share) { progress(stage, (sectioned.fetch_add(share) + share) / total); };
  tbb::parallel_for(std::size_t{0}, res.layers.size(), [&](std::size_t k) {
    progress.check("non-planar slicing");
    const double angle = prm.angles[k % prm.angles.size()];
    const double off = static_cast<double>(k) * prm.layer_height;
    if (prm.offset == OffsetMode::Vertical) {
      per_layer[k] = base.at(angle);
      for (auto& l : per_layer[k])
        for (auto& p : l.pieces)
          for (auto& q : p) q.z += off;
    } else {
      per_layer[k] = layer_lines(surface, angle, off, prm, advance);
      return;
    }
    if (advance) advance(1.0);
  });
  progress(stage, 1.0);
  // Join each layer's pieces by nearest neighbour, starting where the previous layer ended.
  Vec3 cursor{kNaN, kNaN, kNaN};
  HeightField::Eval f = surface.evaluator();
  for (std::size_t k = 0; k < res.layers.size(); ++k) {
    progress.check("non-planar slicing");
    progress("layers", static_cast<double>(k) / static_cast<double>(res.layers.size()));
    auto& rep = res.layers[k];
    rep.angle = prm.angles[k % prm.angles.size()];
    rep.tool = prm.layer_tools[k % prm.layer_tools.size()];
    rep.offset = static_cast<double>(k) * prm.layer_height;
    auto& layer = res.toolpath.layers[k];
    layer.z = rep.offset;
    std::vector<std::vector<Vec3>> pieces;
    std::vector<char> extreme;  // pieces of the first and last line that has any
    std::vector<long> line_of;  // line index of each piece
    {
      long first = -1, last = -1;
      for (std::size_t i = 0; i < per_layer[k].size(); ++i)
        if (!per_layer[k][i].pieces.empty()) {
          if (first < 0) first = static_cast<long>(i);
          last = static_cast<long>(i);
        }
      for (std::size_t i = 0; i < per_layer[k].size(); ++i) rep.jumps += per_layer[k][i].jumps;
      for (std::size_t i = 0; i < per_layer[k].size(); ++i)
        for (auto& p : per_layer[k][i].pieces) {
          pieces.push_back(std::move(p));
          line_of.push_back(static_cast<long>(i));
          extreme.push_back(static_cast<long>(i) == first || static_cast<long>(i) == last);
        }
    }
    rep.lines = pieces.size();
    if (pieces.empty()) continue;
    std::vector<char> used(pieces.size(), 0);
    const SurfacePoint sp{f, prm.offset, rep.offset};
    Path cur;
    auto flush = [&] {
      if (cur.points.size() >= 2) {
        cur.role = PathRole::Nonplanar;
        cur.tool = rep.tool;
        cur.width = prm.width;
        cur.height = prm.layer_height;
        cur.speed = prm.speed;
        layer.paths.push_back(std::move(cur));
      }
      cur = Path{};
    };
    std::size_t next = 0;
    long cur_line = -10;
    bool reverse = false;
    // The unused piece end nearest to `from` (among outer lines' pieces if `outer_only`),
    // another line's before one of `avoid_line`: the rest of the line just printed lies beyond
    // a gap or a jump of the surface, always a travel away. Returns false when none is left.
    auto nearest = [&](Vec3 from, bool outer_only, long avoid_line = -10) {
      double best = 1e300;
      bool other_line = false;
      for (std::size_t i = 0; i < pieces.size(); ++i) {
        if (used[i] || (outer_only && !extreme[i])) continue;
        const bool other = line_of[i] != avoid_line;
        if (other_line && !other) continue;
        for (int e = 0; e < 2; ++e) {
          // Horizontal distance; of two ends over a step of the surface (one above the other)
          // the one on the same side is the nearer.
          const Vec3 end = e ? pieces[i].back() : pieces[i].front();
          const double dd = distance_xy(from, end) + 0.01 * std::abs(end.z - from.z);
          if (dd < best || (other && !other_line))
            best = dd, next = i, reverse = e == 1, other_line = other_line || other;
        }
      }
      return best < 1e300;
    };
    // A serpentine starts at an outer line (otherwise nearest-neighbour strands the lines on
    // one side), at the end nearest to where the previous layer ended.
    if (is_finite(cursor)) nearest(cursor, true);
    for (std::size_t done = 0; done < pieces.size(); ++done) {
      auto piece = std::move(pieces[next]);
      used[next] = 1;
      if (reverse) std::reverse(piece.begin(), piece.end());
      bool joined = false;
      if (!cur.points.empty()) {
        const Vec3 a = cur.points.back(), b = piece.front();
        // A connector between neighbouring lines stays in the strip between them, where no
        // other line runs, so any length is fine; others only up to max_join.
        const bool neighbours = std::abs(line_of[next] - cur_line) == 1;
        if (neighbours || distance_xy(a, b) <= max_join) {
          auto conn = sample_curve(sp, a.xy(), b.xy(), prm.chord_tolerance * 0.5,
                                   std::clamp(prm.width / 4, 0.01, 0.1));
          // Its ends must meet the pieces' in 3D too, and its chords lie on the surface: two
          // ends over a step of the surface lie one above the other, and a connector along
          // the step can reach the far side only by a chord through the air.
          auto on_surface = [&](const std::vector<Vec3>& c) {
            for (std::size_t i = 1; i < c.size(); ++i) {
              const Vec3 m = (c[i - 1] + c[i]) * 0.5;
              if (!(std::abs(sp(m.xy()).z - m.z) <= 2 * prm.chord_tolerance)) return false;
            }
            return true;
          };
          if (conn.size() == 1 && distance(conn[0].front(), a) < 1e-6 &&
              distance(conn[0].back(), b) < 1e-6 && on_surface(conn[0])) {
            auto c = simplify_polyline(conn[0], prm.chord_tolerance * 0.5);
            double clen = 0;
            for (std::size_t i = 1; i < c.size(); ++i) clen += distance(c[i - 1], c[i]);
            rep.connector_length += clen;
            cur.points.insert(cur.points.end(), c.begin() + 1, c.end() - 1);
            joined = true;
          } else if (neighbours && cur.points.size() >= 2 &&
                     hole_ahead(sp, a, cur.points[cur.points.size() - 2], surface.domain(),
                                prm.width)) {
            // Around a hole: hug its edge, pushed back the way the last piece came.
            const double ang = rep.angle * std::numbers::pi / 180;
            const Vec2 d{std::cos(ang), std::sin(ang)};
            const Vec3 t = cur.points.back() - cur.points[cur.points.size() - 2];
            const Vec2 away = (t.x * d.x + t.y * d.y) > 0 ? d * -1.0 : d;
            auto c = hug_connector(sp, a, b, away, std::clamp(prm.width / 4, 0.01, 0.1),
                                   std::max(10 * distance_xy(a, b), 10 * prm.width),
                                   prm.chord_tolerance);
            if (!c.empty() && on_surface(c)) {
              double clen = 0;
              for (std::size_t i = 1; i < c.size(); ++i) clen += distance(c[i - 1], c[i]);
              rep.connector_length += clen;
              ++rep.hole_joins;
              cur.points.insert(cur.points.end(), c.begin() + 1, c.end() - 1);
              joined = true;
            }
          }
        }
        if (!joined && !extreme[next]) {
          // A travel it is: start the next serpentine at an outer line instead, as a layer
          // starts, so that one travel crosses a surface step rather than one per line.
          const std::size_t taken = next;
          const bool was_reversed = reverse;
          if (nearest(a, true)) {
            if (was_reversed) std::reverse(piece.begin(), piece.end());
            pieces[taken] = std::move(piece);
            used[taken] = 0;
            piece = std::move(pieces[next]);
            used[next] = 1;
            if (reverse) std::reverse(piece.begin(), piece.end());
          }
        }
        if (!joined) flush();
      }
      cur_line = line_of[next];
      if (!joined) {
        cur.points = std::move(piece);
      } else {
        const bool same = distance(cur.points.back(), piece.front()) < 1e-9;
        cur.points.insert(cur.points.end(), piece.begin() + (same ? 1 : 0), piece.end());
      }
      nearest(cur.points.back(), false, cur_line);
    }
    cursor = cur.points.back();
    flush();
    rep.paths = layer.paths.size();
    rep.travel_moves = rep.paths - 1;
    for (const auto& p : layer.paths) rep.length += p.length();
    for (const auto& p : layer.paths)
      for (std::size_t i = 1; i < p.points.size(); ++i) {
        const Vec3 s = p.points[i] - p.points[i - 1];
        if (s.z < 0)
          res.max_descent_deg = std::max(
              res.max_descent_deg, std::atan2(-s.z, std::hypot(s.x, s.y)) * 180 / std::numbers::pi);
      }
  }
  progress("layers", 1.0);
  return res;
}

namespace {

// Distance from q to the surface z = f(x, y), by a grid search around q then a shrinking pattern
// search (no normals used: an independent measure for the normal-offset check).
double distance_to_surface(const HeightField::Eval& f, Vec3 q, double radius) {
  auto g = [&](Vec2 p) {  // minus the squared distance, to climb
    const double z = f(p.x, p.y);
    if (!std::isfinite(z)) return -1e300;
    return -((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) + (z - q.z) * (z - q.z));
  };
  // Samples about 0.05 mm apart (the nearest point may sit on a crease or at a corner of the
  // footprint), then climbs from the best eight that lie apart; close to the surface (chords)
  // from two.
  const double r = radius + 0.05;
  const int n = std::clamp(static_cast<int>(std::ceil(r / 0.05)), 4, 32);
  std::vector<std::pair<double, Vec2>> samples;
  samples.reserve(static_cast<std::size_t>((2 * n + 1) * (2 * n + 1)));
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j) {
      const Vec2 p{q.x + r * i / n, q.y + r * j / n};
      samples.push_back({g(p), p});
    }
  double best = -1e300;
  for (const auto& [v, p] : diverse_starts(samples, radius > 0.2 ? 8 : 2, r / 4))
    best = std::max(best, climb(g, p, v, r / n, 1e-7));
  return std::sqrt(-best);
}

}  // namespace

SurfaceDeviation surface_deviation(const Toolpath& tp, const HeightField& surface,
                                   const NonplanarParams& prm) {
  SurfaceDeviation out;
  std::mutex m;
  tbb::enumerable_thread_specific<HeightField::Eval> evals([&] { return surface.evaluator(); });
  tbb::parallel_for(std::size_t{0}, tp.layers.size(), [&](std::size_t k) {
    auto& f = evals.local();
    const double off = static_cast<double>(k) * prm.layer_height;
    // Vertices: vertical mode exactly |z − f − k·h|; otherwise (and for chord midpoints) the
    // distance to the surface by minimisation, minus k·h.
    auto dev = [&](Vec3 q, bool chord) {
      if (prm.offset == OffsetMode::Vertical) {
        const double z = f(q.x, q.y);
        if (!std::isfinite(z)) return 1e300;
        if (!chord) return std::abs(q.z - z - off);
        q.z -= off;
        return distance_to_surface(f, q, std::abs(q.z - z));
      }
      return std::abs(distance_to_surface(f, q, off) - off);
    };
    SurfaceDeviation local;
    // Vertical mode: the distance from a chord midpoint to any surface point bounds its distance
    // to the surface from above — to the point below it (the vertical gap) and to the surface
    // point under its foot on the tangent plane (tight on slopes). Midpoints are visited by
    // falling bound and the minimisation stops once no bound can beat the largest distance
    // found: the same maximum, a fraction of the work.
    std::vector<std::pair<double, Vec3>> mids;
    for (const auto& p : tp.layers[k].paths)
      for (std::size_t i = 0; i < p.points.size(); ++i) {
        const double d = dev(p.points[i], false);
        if (d > local.max_point) local.max_point = d, local.worst = p.points[i];
        if (i == 0) continue;
        const Vec3 mid = (p.points[i - 1] + p.points[i]) * 0.5;
        double bound = 1e300;
        if (prm.offset == OffsetMode::Vertical) {
          const double z = f(mid.x, mid.y);
          if (std::isfinite(z)) {
            bound = std::abs(mid.z - off - z);
            const double h = 1e-3;
            const double fx = (f(mid.x + h, mid.y) - f(mid.x - h, mid.y)) / (2 * h);
            const double fy = (f(mid.x, mid.y + h) - f(mid.x, mid.y - h)) / (2 * h);
            if (std::isfinite(fx) && std::isfinite(fy)) {
              const Vec3 q{mid.x, mid.y, mid.z - off};
              const double len = std::sqrt(fx * fx + fy * fy + 1);
              const Vec3 n{-fx / len, -fy / len, 1 / len};
              const double along = (q.z - z) * n.z;  // signed distance to the tangent plane
              const Vec3 foot = q - n * along;
              const double zf = f(foot.x, foot.y);
              if (std::isfinite(zf)) bound = std::min(bound, distance(q, Vec3{foot.x, foot.y, zf}));
            }
          }
        }
        mids.emplace_back(bound, mid);
      }
    std::stable_sort(mids.begin(), mids.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    for (const auto& [bound, mid] : mids) {
      if (bound <= local.max_chord) break;
      const double c = dev(mid, true);
      if (c > local.max_chord) local.max_chord = c, local.worst_chord = mid;
    }
    std::lock_guard lock(m);
    if (local.max_point > out.max_point) out.max_point = local.max_point, out.worst = local.worst;
    if (local.max_chord > out.max_chord)
      out.max_chord = local.max_chord, out.worst_chord = local.worst_chord;
  });
  return out;
}

double footprint_coverage(const Toolpath& tp, std::size_t layer, const HeightField& surface,
                          double width, double pixel) {
  if (layer >= tp.layers.size()) return 0;
  const BBox2 box = surface.domain();
  BeadRaster raster(box, pixel);
  const long nx = raster.nx(), ny = raster.ny();
  for (const auto& p : tp.layers[layer].paths)
    for (std::size_t i = 1; i < p.points.size(); ++i)
      raster.paint(p.points[i - 1].xy(), p.points[i].xy(), width / 2);
  std::atomic<long> inside{0}, hit{0};
  tbb::enumerable_thread_specific<HeightField::Eval> evals([&] { return surface.evaluator(); });
  tbb::parallel_for(0L, ny, [&](long j) {
    auto& f = evals.local();
    long in = 0, h = 0;
    for (long i = 0; i < nx; ++i) {
      if (!std::isfinite(f(box.min.x + (i + 0.5) * pixel, box.min.y + (j + 0.5) * pixel))) continue;
      ++in;
      h += raster.covered(i, j);
    }
    inside += in, hit += h;
  });
  return inside > 0 ? static_cast<double>(hit) / static_cast<double>(inside) : 0;
}

Toolpath project_onto_surface(const Toolpath& planar, const HeightField& surface,
                              const ProjectParams& prm) {
  if (planar.layers.empty()) throw GeometryError("nothing to project: the toolpath has no layers");
  if (!(prm.chord_tolerance > 0)) throw SettingError("the chord tolerance must be > 0");
  const Vec3 dir = unit(prm.direction);
  if (!(norm(prm.direction) > 0) || dir.z >= -1e-9)
    throw SettingError("the projection direction must point down towards the surface (z < 0)");
  const bool vertical = std::hypot(dir.x, dir.y) < 1e-12;
  const BBox2 box = surface.domain();
  const double reach = std::hypot(box.width(), box.height());
  Toolpath out;
  out.source = planar.source + " on " + surface.name();
  out.layers.resize(planar.layers.size());
  const double z0 = planar.layers.front().z;
  std::mutex m;
  std::string error;
  tbb::enumerable_thread_specific<HeightField::Eval> evals([&] { return surface.evaluator(); });
  tbb::parallel_for(std::size_t{0}, planar.layers.size(), [&](std::size_t k) {
    auto& f = evals.local();
    const auto& in = planar.layers[k];
    const double off = prm.layer_height > 0 ? static_cast<double>(k) * prm.layer_height : in.z - z0;
    // Where the ray from the planar point along `dir` meets the surface; NaN if it does not.
    auto base = [&](Vec3 p) -> Vec2 {
      if (vertical) return p.xy();
      // g(s) = height of the ray above the surface; first sign change from above, refined.
      auto g = [&](double s) {
        const Vec3 q = p + dir * s;
        const double z = f(q.x, q.y);
        return std::isfinite(z) ? q.z - z : kNaN;
      };
      const double step = 0.05;
      double s0 = -reach, g0 = g(s0);
      for (double s = -reach + step; s <= reach; s += step) {
        const double gs = g(s);
        if (std::isfinite(g0) && std::isfinite(gs) && g0 >= 0 && gs <= 0) {
          double lo = s0, hi = s;
          for (int it = 0; it < 60; ++it) {
            const double mid = 0.5 * (lo + hi);
            (g(mid) >= 0 ? lo : hi) = mid;
          }
          return (p + dir * lo).xy();
        }
        s0 = s, g0 = gs;
      }
      return {kNaN, kNaN};
    };
    const SurfacePoint sp{f, prm.offset, off};
    auto& layer = out.layers[k];
    layer.z = off;
    for (std::size_t pi = 0; pi < in.paths.size(); ++pi) {
      const Path& src = in.paths[pi];
      Path dst = src;
      dst.points.clear();
      for (std::size_t i = 1; i < src.points.size(); ++i) {
        const Vec2 a = base(src.points[i - 1]), b = base(src.points[i]);
        std::vector<std::vector<Vec3>> pieces;
        if (std::isfinite(a.x) && std::isfinite(b.x))
          pieces = sample_curve(sp, a, b, prm.chord_tolerance * 0.5, 0.1);
        if (pieces.size() != 1 || distance_xy(pieces[0].front(), sp(a)) > 1e-6 ||
            distance_xy(pieces[0].back(), sp(b)) > 1e-6) {
          std::lock_guard lock(m);
          if (error.empty())
            error = "layer " + std::to_string(k + 1) + " path " + std::to_string(pi + 1) +
                    " leaves the footprint of surface '" + surface.name() + "' between " +
                    fmt_xy(src.points[i - 1].xy()) + " and " + fmt_xy(src.points[i].xy());
          return;
        }
        auto seg = simplify_polyline(pieces[0], prm.chord_tolerance * 0.5);
        dst.points.insert(dst.points.end(), seg.begin() + (dst.points.empty() ? 0 : 1), seg.end());
      }
      if (dst.points.size() >= 2) layer.paths.push_back(std::move(dst));
    }
  });
  if (!error.empty()) throw GeometryError(error);
  return out;
}

}  // namespace trellis
