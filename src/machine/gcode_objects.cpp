#include "gcode_objects.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "trellis/machine/machine_check.hpp"

namespace trellis {

namespace {

// Convex hull, counter-clockwise (Andrew's monotone chain); fewer than 3 points as they are.
std::vector<Vec2> convex_hull(std::vector<Vec2> p) {
  std::sort(p.begin(), p.end(),
            [](Vec2 a, Vec2 b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  p.erase(std::unique(p.begin(), p.end(), [](Vec2 a, Vec2 b) { return a.x == b.x && a.y == b.y; }),
          p.end());
  if (p.size() < 3) return p;
  auto cross = [](Vec2 o, Vec2 a, Vec2 b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
  };
  std::vector<Vec2> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);
  return h;
}

std::string written_name(const std::string& label) {
  std::string n = label.empty() ? std::string("part") : label;
  for (char& c : n)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '-' || c == '.'))
      c = '_';
  return n;
}

std::string klipper_definition(const std::string& name, const std::vector<Vec2>& hull) {
  double cx = 0, cy = 0;
  for (const Vec2& q : hull) cx += q.x, cy += q.y;
  if (!hull.empty()) cx /= static_cast<double>(hull.size()), cy /= static_cast<double>(hull.size());
  std::string s =
      fmt::format("EXCLUDE_OBJECT_DEFINE NAME={} CENTER={:.3f},{:.3f} POLYGON=[", name, cx, cy);
  for (std::size_t i = 0; i < hull.size(); ++i)
    s += fmt::format("{}[{:.3f},{:.3f}]", i ? "," : "", hull[i].x, hull[i].y);
  return s + "]\n";
}

}  // namespace

std::string GcodeObjects::start(int part) const {
  const std::string& n = names[static_cast<std::size_t>(part - 1)];
  if (style == ObjectStyle::Klipper) return "EXCLUDE_OBJECT_START NAME=" + n + "\n";
  return fmt::format("M486 S{} A\"{}\"\n", part - 1, n);
}

std::string GcodeObjects::end(int part) const {
  if (style == ObjectStyle::Klipper)
    return "EXCLUDE_OBJECT_END NAME=" + names[static_cast<std::size_t>(part - 1)] + "\n";
  return "M486 S-1\n";
}

GcodeObjects gcode_objects(const std::vector<std::string>& labels, const LayerSource& layers,
                           const MachineProfile& p, Vec2 shift,
                           std::vector<std::pair<std::string, std::string>>& warnings) {
  GcodeObjects o;
  if (!p.label_objects || labels.empty() || !p.marlin_family()) return o;
  o.style = p.flavor == Flavor::Klipper ? ObjectStyle::Klipper : ObjectStyle::M486;
  for (const std::string& label : labels) {
    std::string n = written_name(label);
    if (n != label)
      warnings.emplace_back("label_renamed",
                            fmt::format("part label '{}' is written as '{}' in the G-code (labels "
                                        "there are letters, digits, '_', '-' and '.')",
                                        label, n));
    if (std::find(o.names.begin(), o.names.end(), n) != o.names.end())
      throw MachineError(fmt::format("two parts are written as '{}' in the G-code: give them "
                                     "labels of letters, digits, '_', '-' and '.' that differ "
                                     "(or set gcode.label_objects = false)",
                                     n),
                         {"", 0, "gcode.label_objects"});
    o.names.push_back(std::move(n));
  }
  if (o.style == ObjectStyle::M486) {
    o.definitions = fmt::format("M486 T{}\n", o.names.size());
    return o;
  }
  // Each part's hull, grown a layer at a time.
  std::vector<std::vector<Vec2>> hulls(o.names.size());
  layers([&](std::size_t, const Layer& l) {
    std::vector<std::vector<Vec2>> add(hulls.size());
    for (const auto& path : l.paths)
      if (path.part >= 1 && path.part <= static_cast<int>(hulls.size()))
        for (const auto& q : path.points)
          add[static_cast<std::size_t>(path.part - 1)].push_back({q.x + shift.x, q.y + shift.y});
    for (std::size_t i = 0; i < hulls.size(); ++i) {
      if (add[i].empty()) continue;
      add[i].insert(add[i].end(), hulls[i].begin(), hulls[i].end());
      hulls[i] = convex_hull(std::move(add[i]));
    }
  });
  for (std::size_t i = 0; i < o.names.size(); ++i)
    o.definitions += klipper_definition(o.names[i], hulls[i]);
  return o;
}

}  // namespace trellis
