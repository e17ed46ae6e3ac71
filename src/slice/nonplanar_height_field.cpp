// The height field z = f(x, y) a non-planar print is laid on: from a function, an expression, a
// profile or a mesh (checked to be a height field: no vertical facet, no point above another,
// with an XY grid of its triangles), and meshed back for previews.
#include <fmt/format.h>
#include <muParser.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cstdio>

#include "../field/node.hpp"
#include "nonplanar_internal.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"

namespace trellis {

namespace nonplanar_detail {

std::string fmt_mm(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}
std::string fmt_xy(Vec2 p) {
  return "(" + fmt_mm(p.x) + ", " + fmt_mm(p.y) + ")";
}

}  // namespace nonplanar_detail

using namespace nonplanar_detail;

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

}  // namespace trellis
