// The non-planar slicer's parts (src/slice/nonplanar*.cpp): the height field's insides, curves
// sampled on the (offset) surface (nonplanar_curves.cpp), the lines a layer is cut into
// (nonplanar_lines.cpp) and their joining into serpentines (nonplanar_join.cpp).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "trellis/slice/nonplanar.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

namespace nonplanar_detail {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Millimetres and XY points as error messages print them (3 decimals; nonplanar_height_field.cpp).
std::string fmt_mm(double v);
std::string fmt_xy(Vec2 p);

inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline Vec3 unit(Vec3 a) {
  const double n = norm(a);
  return n > 0 ? a * (1.0 / n) : Vec3{0, 0, 1};
}

}  // namespace nonplanar_detail

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
    if (t < 0) return nonplanar_detail::kNaN;
    const auto q = tri(static_cast<std::size_t>(t));
    return b[0] * q[0].z + b[1] * q[1].z + b[2] * q[2].z;
  }
};

namespace nonplanar_detail {

// --- curves on the surface (nonplanar_curves.cpp) ---

// Starts of a multi-start search: the best samples (value, point), at most `count`, each at
// least `separation` from the ones chosen before (the best few often sit on one hill).
std::vector<std::pair<double, Vec2>> diverse_starts(std::vector<std::pair<double, Vec2>>& samples,
                                                    std::size_t count, double separation);

// Sixteen unit directions: creases of folded surfaces and meshes make ridges that a search
// along the axes alone stalls on.
inline const std::array<Vec2, 16> kCompass = [] {
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
double envelope_height(const HeightField::Eval& f, Vec2 p, double d);

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
                                            double base_step, std::size_t* jumps = nullptr);

// A connector from a to b (ends of pieces on neighbouring lines) that hugs a hole's edge in the
// strip between the two lines; empty if it cannot.
std::vector<Vec3> hug_connector(const SurfacePoint& sp, Vec3 a, Vec3 b, Vec2 away, double step,
                                double reach, double margin);

// Whether the footprint goes on past the end `a` of a piece (coming from `before`): a hole, not
// the outer edge.
bool hole_ahead(const SurfacePoint& sp, Vec3 a, Vec3 before, const BBox2& box, double step);

// --- a layer's lines (nonplanar_lines.cpp) ---

struct Line {
  double v = 0;
  std::vector<std::vector<Vec3>> pieces;  // in increasing u
  std::size_t jumps = 0;                  // where the surface jumps (split, sample_curve)
};

// The plane sections of one layer: lines across the footprint spaced by the width (in the
// slicing direction or along the surface), each cut into pieces where the surface exists,
// sampled within the chord tolerance.
std::vector<Line> layer_lines(const HeightField& surface, double angle_deg, double offset,
                              const NonplanarParams& prm,
                              const std::function<void(double)>& advance = {});

// --- serpentines (nonplanar_join.cpp) ---

// Joins a layer's line pieces into serpentines by nearest neighbour, starting where the
// previous layer ended (`cursor`, moved to where this one ends): paths into `layer`, its counts
// into `rep`, the steepest descent into max_descent_deg.
void join_layer(const HeightField& surface, const NonplanarParams& prm, const HeightField::Eval& f,
                double max_join, std::vector<Line>& lines, Vec3& cursor, NonplanarLayerReport& rep,
                Layer& layer, double& max_descent_deg);

}  // namespace nonplanar_detail

}  // namespace trellis
