// Where a non-planar layer's lines lie (centred on the footprint, spaced by the width in the
// slicing direction or along the surface) and their sections: exact plane cuts of a mesh, or
// curves sampled on the (offset) surface.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <mutex>

#include "nonplanar_internal.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

using namespace nonplanar_detail;

namespace {

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

namespace nonplanar_detail {

// The plane sections of one layer: lines across the footprint spaced by the width (in the
// slicing direction or along the surface), each cut into pieces where the surface exists,
// sampled within the chord tolerance.
std::vector<Line> layer_lines(const HeightField& surface, double angle_deg, double offset,
                              const NonplanarParams& prm,
                              const std::function<void(double)>& advance) {
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

}  // namespace nonplanar_detail

}  // namespace trellis
