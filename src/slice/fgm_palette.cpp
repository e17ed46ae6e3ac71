// The palette of a graded print: N divisions of the gradient into colours (two materials: bands
// of the first fraction; three: triangles of the simplex), their mixtures, and the colour of a
// point's fractions.
#include <algorithm>
#include <cmath>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/slice/fgm.hpp"

namespace trellis {

void Palette::check() const {
  if (materials != 2 && materials != 3)
    throw SettingError("gradient palettes mix two or three materials (the design has " +
                       std::to_string(materials) + ")");
  if (colors < 1 || colors > 1000) throw SettingError("the palette needs 1 to 1000 colours");
  if (ends && (materials != 2 || colors < 2))
    throw SettingError("a tool palette has two materials and at least two colours");
  if (materials == 3) {
    const int d = divisions();
    if (d * d != colors || d < 1)
      throw SettingError("a three-material palette has d² colours (1, 4, 9, 16, 25, …), not " +
                         std::to_string(colors));
  }
}

int Palette::divisions() const {
  if (materials != 3) return colors;
  return static_cast<int>(std::lround(std::sqrt(static_cast<double>(std::max(colors, 1)))));
}

double Palette::band() const {
  if (ends && materials != 3) return colors > 1 ? 1.0 / (colors - 1) : 1.0;
  return 1.0 / divisions();
}

double Palette::level(int k) const {
  if (ends && materials != 3) return (k - 0.5) * band();
  return static_cast<double>(k) / divisions();
}

double Palette::error_bound() const {
  return (materials == 3 ? 2.0 / 3.0 : 0.5) * band();
}

Palette::Cell Palette::cell(int color) const {
  // Row r holds the triangles with i = r: up (r, 0), down (r, 0), up (r, 1), …, up (r, d-1-r),
  // 2(d - r) - 1 of them, walked left to right on even rows and back on odd ones.
  const int d = divisions();
  int r = 0, first = 0;
  while (r < d - 1 && color >= first + 2 * (d - r) - 1) first += 2 * (d - r) - 1, ++r;
  const int count = 2 * (d - r) - 1;
  int t = std::clamp(color - first, 0, count - 1);
  if (r % 2 == 1) t = count - 1 - t;
  Cell c;
  c.i = r;
  c.j = t / 2;
  c.up = t % 2 == 0;
  c.k = (c.up ? d - 1 : d - 2) - c.i - c.j;
  return c;
}

std::vector<double> Palette::mixture(int color) const {
  if (materials != 3) {
    const double m =
        ends ? (colors > 1 ? 1.0 * color / (colors - 1) : 0.5) : (color + 0.5) / colors;
    return {m, 1 - m};
  }
  const Cell c = cell(color);
  const double off = c.up ? 1.0 / 3.0 : 2.0 / 3.0, d = divisions();
  return {(c.i + off) / d, (c.j + off) / d, (c.k + off) / d};
}

int Palette::color_of(double f) const {
  if (ends) return std::clamp(static_cast<int>(std::floor(f * (colors - 1) + 0.5)), 0, colors - 1);
  return std::clamp(static_cast<int>(std::floor(f * colors)), 0, colors - 1);
}

int Palette::color_of(const std::vector<double>& f) const {
  if (materials != 3 || f.size() < 3) return color_of(f.empty() ? 0.0 : f[0]);
  const int d = divisions();
  const double a = std::clamp(f[0], 0.0, 1.0) * d, b = std::clamp(f[1], 0.0, 1.0) * d;
  const int i = std::clamp(static_cast<int>(std::floor(a)), 0, d - 1);
  int j = std::clamp(static_cast<int>(std::floor(b)), 0, d - 1 - i);
  const bool up = i + j == d - 1 || (a - i) + (b - j) < 1;
  return color_of_cell(i, j, up);
}

int Palette::color_of_cell(int i, int j, bool up) const {
  // Index of (i, j, up) along the snake.
  const int d = divisions();
  int first = 0;
  for (int r = 0; r < i; ++r) first += 2 * (d - r) - 1;
  const int count = 2 * (d - i) - 1;
  int t = 2 * j + (up ? 0 : 1);
  if (i % 2 == 1) t = count - 1 - t;
  return first + t;
}

}  // namespace trellis
