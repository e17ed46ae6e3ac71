// The non-planar paper's test surfaces (corrugations, Miura-Ori, the "M" curve), a spherical cap
// for lattices on surfaces, and the print-angle test path.
#include <cmath>
#include <numbers>

#include "trellis/core/error.hpp"
#include "trellis/slice/nonplanar.hpp"

namespace trellis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One piece of a filleted profile over [x0, x1]: a line, or a circular arc about (cx, cz).
struct Piece {
  double x0, x1;
  bool arc = false;
  double z0 = 0, z1 = 0;         // line
  double cx = 0, cz = 0, r = 0;  // arc
  bool upper = false;            // arc: the upper half (a peak)
  double eval(double x) const {
    if (!arc) return x1 > x0 ? z0 + (z1 - z0) * (x - x0) / (x1 - x0) : z0;
    const double d = std::max(0.0, r * r - (x - cx) * (x - cx));
    return upper ? cz + std::sqrt(d) : cz - std::sqrt(d);
  }
};

std::vector<Piece> profile_pieces(const Profile& p) {
  const auto& c = p.corners;
  if (c.size() < 2) throw GeometryError("a profile needs at least two corners");
  for (std::size_t i = 1; i < c.size(); ++i)
    if (!(c[i].x > c[i - 1].x))
      throw GeometryError("profile corner " + std::to_string(i) +
                          " does not lie to the right of the one before (a profile must be a "
                          "height field)");
  std::vector<Piece> out;
  Vec2 from = c[0];
  for (std::size_t i = 1; i + 1 < c.size(); ++i) {
    const Vec2 a0 = c[i] - c[i - 1], b0 = c[i + 1] - c[i];
    const double la = std::hypot(a0.x, a0.y), lb = std::hypot(b0.x, b0.y);
    const Vec2 a = a0 * (1 / la), b = b0 * (1 / lb);
    const double turn = a.x * b.y - a.y * b.x;
    const double phi = std::acos(std::clamp(a.x * b.x + a.y * b.y, -1.0, 1.0));
    double r = p.fillet_radius;
    if (r <= 0 || phi < 1e-9) continue;  // a sharp (or straight) corner: the line goes on
    double t = r * std::tan(phi / 2);
    // Fillets never eat more than half of a neighbouring straight piece.
    const double tmax = 0.5 * std::min(la, lb);
    if (t > tmax) t = tmax, r = t / std::tan(phi / 2);
    const Vec2 t1 = c[i] - a * t, t2 = c[i] + b * t;
    const Vec2 left{-a.y, a.x};
    const Vec2 centre = turn > 0 ? t1 + left * r : t1 - left * r;
    out.push_back({from.x, t1.x, false, from.y, t1.y});
    Piece arc{t1.x, t2.x, true};
    arc.cx = centre.x, arc.cz = centre.y, arc.r = r, arc.upper = turn < 0;
    out.push_back(arc);
    from = t2;
  }
  out.push_back({from.x, c.back().x, false, from.y, c.back().y});
  // Sharp corners were skipped above: split the straight runs at them.
  std::vector<Piece> split;
  for (const auto& pc : out) {
    if (pc.arc) {
      split.push_back(pc);
      continue;
    }
    Piece cur = pc;
    for (const auto& k : c)
      if (k.x > cur.x0 + 1e-12 && k.x < cur.x1 - 1e-12) {
        Piece left = cur;
        left.x1 = k.x, left.z1 = k.y;
        split.push_back(left);
        cur.x0 = k.x, cur.z0 = k.y;
      }
    split.push_back(cur);
  }
  return split;
}

double tri01(double t) {
  return 1 - std::abs(2 * (t - std::floor(t)) - 1);
}

}  // namespace

std::function<double(double)> profile_function(const Profile& p) {
  auto pieces = std::make_shared<std::vector<Piece>>(profile_pieces(p));
  return [pieces](double x) {
    const auto& v = *pieces;
    x = std::clamp(x, v.front().x0, v.back().x1);
    auto it = std::lower_bound(v.begin(), v.end(), x,
                               [](const Piece& pc, double xx) { return pc.x1 < xx; });
    if (it == v.end()) --it;
    return it->eval(x);
  };
}

std::vector<double> profile_breaks(const Profile& p, double tol) {
  std::vector<double> xs;
  for (const auto& pc : profile_pieces(p)) {
    xs.push_back(pc.x0);
    if (pc.arc && pc.r > tol) {
      // Chord within tol of an arc of radius r spans 2·acos(1 − tol/r).
      const double a0 = std::atan2(pc.eval(pc.x0) - pc.cz, pc.x0 - pc.cx);
      const double a1 = std::atan2(pc.eval(pc.x1) - pc.cz, pc.x1 - pc.cx);
      const double step = 2 * std::acos(1 - tol / pc.r);
      const int n = std::max(1, static_cast<int>(std::ceil(std::abs(a1 - a0) / step)));
      for (int k = 1; k < n; ++k) xs.push_back(pc.cx + pc.r * std::cos(a0 + (a1 - a0) * k / n));
    }
  }
  xs.push_back(p.corners.back().x);
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end(), [](double a, double b) { return b - a < 1e-9; }),
           xs.end());
  return xs;
}

Profile corrugation_profile(const CorrugationParams& p) {
  if (!(p.length > 0 && p.width > 0) || p.periods < 0 || p.flat_length < 0 ||
      2 * p.flat_length >= p.length || p.fillet_diameter < 0 || p.amplitude_scale < 0 ||
      !(p.angle_deg >= 0 && p.angle_deg < 90))
    throw SettingError(
        "corrugation: length and width > 0, flat ends shorter than half the length, periods, "
        "fillet and amplitude scale >= 0, angle in [0, 90)");
  const double halves = 2 * p.periods;
  if (std::abs(halves - std::round(halves)) > 1e-9)
    throw SettingError("corrugation periods must be a multiple of 0.5 (so the wave ends level)");
  Profile prof;
  prof.fillet_radius = p.fillet_diameter / 2;
  const double wave = p.length - 2 * p.flat_length;
  prof.corners.push_back({0, 0});
  const long quarters = std::lround(4 * p.periods);
  const double slope = std::tan(p.angle_deg * std::numbers::pi / 180) * p.amplitude_scale;
  if (quarters == 0 || slope == 0) {
    prof.corners.push_back({p.length, 0});
    return prof;
  }
  const double q = wave / static_cast<double>(quarters);
  const double a = slope * q;  // a quarter period rises by the amplitude at the slope
  prof.corners.push_back({p.flat_length, 0});
  for (long k = 1; k < quarters; k += 2)
    prof.corners.push_back(
        {p.flat_length + static_cast<double>(k) * q, ((k / 2) % 2 == 0) ? a : -a});
  prof.corners.push_back({p.length - p.flat_length, 0});
  prof.corners.push_back({p.length, 0});
  return prof;
}

HeightField corrugation(const CorrugationParams& p) {
  char name[160];
  std::snprintf(name, sizeof name, "corrugation %gx%g mm, %g periods at %g deg x %g, fillet %g mm",
                p.length, p.width, p.periods, p.angle_deg, p.amplitude_scale, p.fillet_diameter);
  return HeightField::from_profile(corrugation_profile(p), 0, p.width, name);
}

HeightField m_curve(const MCurveParams& p) {
  if (!(p.length > 0 && p.width > 0 && p.height >= 0 && p.fillet_diameter >= 0))
    throw SettingError("M curve: length, width > 0, height and fillet >= 0");
  Profile prof;
  prof.fillet_radius = p.fillet_diameter / 2;
  const double L = p.length, H = p.height;
  prof.corners = {{0, 0}, {L / 4, H}, {L / 2, H / 4}, {3 * L / 4, H}, {L, 0}};
  char name[96];
  std::snprintf(name, sizeof name, "M curve %gx%g mm, %g mm high", L, p.width, H);
  return HeightField::from_profile(prof, 0, p.width, name);
}

HeightField miura(const MiuraParams& p) {
  if (!(p.length > 0 && p.width > 0 && p.depth >= 0 && p.periods_x > 0 && p.periods_y > 0 &&
        p.taper_length >= 0 && 2 * p.taper_length <= p.length))
    throw SettingError("Miura-Ori: length, width, periods > 0, depth and taper >= 0");
  const double px = p.length / p.periods_x, py = p.width / p.periods_y;
  auto make = [p, px, py]() -> HeightField::Eval {
    return [p, px, py](double x, double y) {
      // Folds across the width whose crease lines zig-zag along the length: parallelogram
      // facets, the Miura-Ori pattern as a height field.
      const double c = p.shift * tri01(x / px);
      double z = p.depth * tri01((y - c) / py);
      if (p.taper_length > 0) z *= std::clamp(std::min(x, p.length - x) / p.taper_length, 0.0, 1.0);
      return z;
    };
  };
  char name[128];
  std::snprintf(name, sizeof name, "Miura-Ori %gx%g mm, fold depth %g mm", p.length, p.width,
                p.depth);
  return HeightField::from_function(make, {{0, 0}, {p.length, p.width}}, name);
}

HeightField sphere_cap(double radius, double diameter) {
  const double r = diameter / 2;
  if (!(radius > 0 && r > 0 && r <= radius))
    throw SettingError("sphere cap: radius > 0 and a footprint diameter of at most 2 × radius");
  const double base = std::sqrt(radius * radius - r * r);
  auto make = [radius, r, base]() -> HeightField::Eval {
    return [radius, r, base](double x, double y) {
      const double q = x * x + y * y;
      if (q > r * r) return kNaN;
      return std::sqrt(radius * radius - q) - base;
    };
  };
  char name[96];
  std::snprintf(name, sizeof name, "sphere cap R %g mm over %g mm", radius, diameter);
  return HeightField::from_function(make, {{-r, -r}, {r, r}}, name);
}

Toolpath angle_test(const AngleTestParams& p) {
  if (p.angles.empty() || !(p.length > 0 && p.spacing > 0 && p.rise > 0 && p.flat > 0))
    throw SettingError("angle test: at least one angle; length, spacing, rise and flat > 0");
  Toolpath tp;
  tp.source = "trellis surface angle-test";
  tp.layers.emplace_back();
  tp.layers[0].z = p.base_z;
  for (std::size_t i = 0; i < p.angles.size(); ++i) {
    const double a = p.angles[i];
    if (!(a >= -90 && a <= 90))
      throw SettingError("angle test: angles must lie in [-90, 90] degrees");
    Path path;
    path.role = PathRole::Nonplanar;
    const double y = static_cast<double>(i) * p.spacing;
    Vec3 q{0, y, p.base_z};
    path.points.push_back(q);
    const double rad = std::abs(a) * std::numbers::pi / 180;
    const double dz = a > 0 ? p.rise : -p.rise;
    const double dx = a == 0 ? p.rise : (std::abs(a) >= 90 ? 0 : p.rise / std::tan(rad));
    int sign = 1;
    while (q.x < p.length) {
      q.x = std::min(p.length, q.x + p.flat);
      path.points.push_back(q);
      if (q.x >= p.length) break;
      if (a == 0) continue;
      if (q.x + dx > p.length) break;
      q.x += dx;
      q.z += sign * dz;
      path.points.push_back(q);
      sign = -sign;
    }
    tp.layers[0].paths.push_back(std::move(path));
  }
  return tp;
}

}  // namespace trellis
