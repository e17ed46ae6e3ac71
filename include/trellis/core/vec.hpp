// Small value types for points and boxes. Millimetres throughout the library.
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>

namespace trellis {

struct Vec2 {
  double x = 0, y = 0;
  Vec2 operator+(Vec2 o) const { return {x + o.x, y + o.y}; }
  Vec2 operator-(Vec2 o) const { return {x - o.x, y - o.y}; }
  Vec2 operator*(double s) const { return {x * s, y * s}; }
  bool operator==(const Vec2&) const = default;
};

// Squared distance in the plane; lengths by its square root (std::hypot guards against overflow
// at several times the cost, which shows on the per-layer hot paths).
inline double dist2(Vec2 a, Vec2 b) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  return dx * dx + dy * dy;
}

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3 operator+(Vec3 o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(Vec3 o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  bool operator==(const Vec3&) const = default;
  Vec2 xy() const { return {x, y}; }
};

inline double dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline double norm(Vec3 a) {
  return std::sqrt(dot(a, a));
}
inline double distance(Vec3 a, Vec3 b) {
  return norm(a - b);
}
inline double distance_xy(Vec3 a, Vec3 b) {
  return std::hypot(a.x - b.x, a.y - b.y);
}
inline bool is_finite(Vec3 a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

// Distance from p to segment ab and the parameter t in [0,1] of the closest point.
inline double distance_to_segment(Vec3 p, Vec3 a, Vec3 b, double* t_out = nullptr) {
  const Vec3 ab = b - a;
  const double len2 = dot(ab, ab);
  double t = len2 > 0 ? dot(p - a, ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  if (t_out) *t_out = t;
  return distance(p, a + ab * t);
}

// A closed range of values; infinite ends mean "not known".
struct Interval {
  double lo = 0, hi = 0;
};

// An axis-aligned rectangle in XY.
struct BBox2 {
  Vec2 min{0, 0}, max{0, 0};
  double width() const { return max.x - min.x; }
  double height() const { return max.y - min.y; }
  bool contains(Vec2 p) const {
    return p.x >= min.x && p.x <= max.x && p.y >= min.y && p.y <= max.y;
  }
};

struct BBox3 {
  Vec3 min{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
           std::numeric_limits<double>::infinity()};
  Vec3 max{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
           -std::numeric_limits<double>::infinity()};
  void add(Vec3 p) {
    min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
    max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
  }
  bool empty() const { return min.x > max.x; }
  Vec3 center() const { return (min + max) * 0.5; }
};

}  // namespace trellis
