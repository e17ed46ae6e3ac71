// The colours of every Trellis picture: one table (src/render/palette.json, compiled in) read by
// the PNG renderer and bundled into the viewer (viewer/src/colors.js), so a mixture, a role or a
// value has the same colour in a PNG and on screen. Colours are RGB bytes; blends round half up,
// as the viewer's JavaScript does, so both give the same bytes.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

using Rgb = std::array<int, 3>;

struct Palette {
  std::vector<std::pair<std::string, Rgb>> roles;  // by PathRole, in enum order
  std::vector<Rgb> tools;                          // tool k: tools[k % size]
  Rgb no_value{};                                  // a path without the value shown
  std::vector<std::pair<double, Rgb>> continuous;  // stops of the map of ranged values
  std::array<Rgb, 2> mixture2{};                   // fraction of material 1: 0, 1
  std::array<Rgb, 3> mixture3{};                   // materials 1, 2, 3
};

// The compiled-in table (parsed once; immutable).
const Palette& palette();
// The JSON text it was parsed from (the viewer bundles the same file).
const std::string& palette_json();

Rgb role_rgb(PathRole role);
Rgb tool_rgb(int tool);
// Ranged values (print order, height, temperature, ...): t in [0, 1], clamped.
Rgb continuous_rgb(double t);
// A two-material mixture: `fraction` of material 1, clamped to [0, 1].
Rgb mixture_rgb(double fraction);
// Three materials: fractions of materials 1, 2, 3 (normalised to sum 1; negatives count as 0).
Rgb mixture3_rgb(double a, double b, double c);

}  // namespace trellis
