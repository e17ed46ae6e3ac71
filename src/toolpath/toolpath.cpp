#include "trellis/toolpath/toolpath.hpp"

#include <iterator>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {
constexpr const char* kRoleNames[] = {"strut", "contour", "handle", "perimeter", "infill",
                                      "other", "skin",    "purge",  "hatch",     "nonplanar"};
static_assert(std::size(kRoleNames) == kPathRoleCount);
}  // namespace

const char* to_string(PathRole role) {
  return kRoleNames[static_cast<int>(role)];
}

PathRole path_role_from_string(const std::string& name) {
  for (std::size_t i = 0; i < kPathRoleCount; ++i)
    if (name == kRoleNames[i]) return static_cast<PathRole>(i);
  throw ParseError(
      "unknown path role '" + name +
      "' (expected strut, contour, handle, perimeter, infill, skin, purge, hatch, nonplanar "
      "or other)");
}

double Path::length() const {
  double len = 0;
  for (std::size_t i = 1; i < points.size(); ++i) len += distance(points[i - 1], points[i]);
  return len;
}

std::size_t Toolpath::path_count() const {
  std::size_t n = 0;
  for (const auto& l : layers) n += l.paths.size();
  return n;
}

double Toolpath::extrusion_length() const {
  double len = 0;
  for (const auto& l : layers)
    for (const auto& p : l.paths) len += p.length();
  return len;
}

int parameter_set_of(const Toolpath& toolpath, PathRole role, double power, double speed) {
  const auto& sets = toolpath.parameter_sets;
  for (std::size_t i = 0; i < sets.size(); ++i)
    if (sets[i].role == role && sets[i].power == power && sets[i].speed == speed)
      return static_cast<int>(i);
  return -1;
}

BBox3 points_box(const Toolpath& toolpath) {
  BBox3 box;
  for (const auto& l : toolpath.layers)
    for (const auto& p : l.paths)
      for (const auto& q : p.points) box.add(q);
  return box;
}

double travel_into(Vec3 from, const Path& path) {
  double d = 0;
  for (const Vec3& v : path.via) d += distance(from, v), from = v;
  return d + distance(from, path.points.front());
}

TravelStats travel_stats(const Toolpath& toolpath, double min_move) {
  TravelStats s;
  const Vec3* last = nullptr;
  for (const auto& layer : toolpath.layers)
    for (const auto& path : layer.paths) {
      if (path.points.empty()) continue;
      if (last) {
        const double d = travel_into(*last, path);
        if (d > min_move) {
          ++s.moves;
          s.length += d;
        }
      }
      last = &path.points.back();
    }
  return s;
}

void extend_path_ends(Path& path, double length) {
  auto& q = path.points;
  if (length <= 0 || q.size() < 2) return;
  auto push = [&](Vec3& end, Vec3 from) {
    const Vec3 d = end - from;
    const double len = norm(d);
    if (len > 0) end = end + d * (length / len);
  };
  const Vec3 second = q[1], before_last = q[q.size() - 2];
  push(q.front(), second);
  push(q.back(), before_last);
}

LayerSource layers_of(const Toolpath& toolpath) {
  return [&toolpath](const LayerVisitor& visit) {
    for (std::size_t i = 0; i < toolpath.layers.size(); ++i) visit(i, toolpath.layers[i]);
  };
}

}  // namespace trellis
