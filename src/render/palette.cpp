#include "trellis/render/palette.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

const char kPaletteText[] =
#include "palette_json.inc"
    ;

Rgb rgb_of(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) throw Error("palette.json: a colour is not [r, g, b]");
  return {j[0].get<int>(), j[1].get<int>(), j[2].get<int>()};
}

Palette parse_palette() {
  const auto j = nlohmann::json::parse(palette_json());
  Palette p;
  for (const auto& r : j.at("roles"))
    p.roles.emplace_back(r.at(0).get<std::string>(), rgb_of(r.at(1)));
  for (const auto& t : j.at("tools")) p.tools.push_back(rgb_of(t));
  p.no_value = rgb_of(j.at("no_value"));
  for (const auto& s : j.at("continuous"))
    p.continuous.emplace_back(s.at(0).get<double>(), rgb_of(s.at(1)));
  for (int k = 0; k < 2; ++k) p.mixture2[k] = rgb_of(j.at("mixture2").at(k));
  for (int k = 0; k < 3; ++k) p.mixture3[k] = rgb_of(j.at("mixture3").at(k));
  if (p.roles.size() != kPathRoleCount || p.tools.empty() || p.continuous.size() < 2)
    throw Error("palette.json: roles must list every PathRole, tools and continuous stops");
  for (std::size_t r = 0; r < p.roles.size(); ++r)
    if (p.roles[r].first != to_string(static_cast<PathRole>(r)))
      throw Error("palette.json: role " + std::to_string(r) + " is '" + p.roles[r].first +
                  "', PathRole says '" + to_string(static_cast<PathRole>(r)) + "'");
  return p;
}

// As the viewer's lerp: each channel a + (b - a) t, rounded half up.
Rgb lerp(const Rgb& a, const Rgb& b, double t) {
  Rgb c;
  for (int i = 0; i < 3; ++i) c[i] = static_cast<int>(std::floor(a[i] + (b[i] - a[i]) * t + 0.5));
  return c;
}

}  // namespace

const std::string& palette_json() {
  static const std::string text(kPaletteText, sizeof kPaletteText - 1);
  return text;
}

const Palette& palette() {
  static const Palette p = parse_palette();
  return p;
}

Rgb role_rgb(PathRole role) {
  const auto& roles = palette().roles;
  return roles[std::min(static_cast<std::size_t>(role), roles.size() - 1)].second;
}

Rgb tool_rgb(int tool) {
  const auto& tools = palette().tools;
  return tools[static_cast<std::size_t>(std::max(0, tool)) % tools.size()];
}

Rgb continuous_rgb(double t) {
  const auto& s = palette().continuous;
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0);
  for (std::size_t i = 1; i < s.size(); ++i)
    if (t <= s[i].first)
      return lerp(s[i - 1].second, s[i].second,
                  (t - s[i - 1].first) / (s[i].first - s[i - 1].first));
  return s.back().second;
}

Rgb mixture_rgb(double fraction) {
  const auto& m = palette().mixture2;
  return lerp(m[0], m[1], std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0));
}

Rgb mixture3_rgb(double a, double b, double c) {
  double w[3] = {std::max(0.0, a), std::max(0.0, b), std::max(0.0, c)};
  const double sum = w[0] + w[1] + w[2];
  if (!(sum > 0)) return palette().no_value;
  const auto& m = palette().mixture3;
  Rgb out;
  for (int i = 0; i < 3; ++i)
    out[i] = static_cast<int>(
        std::floor(w[0] / sum * m[0][i] + w[1] / sum * m[1][i] + w[2] / sum * m[2][i] + 0.5));
  return out;
}

}  // namespace trellis
