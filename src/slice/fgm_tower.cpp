#include "fgm_tower.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "trellis/core/error.hpp"

namespace trellis::tower {

namespace {

std::string mm(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

}  // namespace

int Square::lines() const { return std::max(0, static_cast<int>(std::floor((s_ - 2 * w_) / w_ + 1e-9))); }

double Square::line_length() const { return std::max(0.0, s_ - 3 * w_); }

int Square::lines_for(double length) const {
  const double l = line_length();
  if (l <= 0) return lines() + 1;
  return std::max(1, static_cast<int>(std::ceil((length + w_) / (l + w_) - 1e-12)));
}

std::vector<Vec2> Square::wall() const {
  const double r = s_ / 2 - w_ / 2;
  return {{c_.x - r, c_.y - r}, {c_.x + r, c_.y - r}, {c_.x + r, c_.y + r}, {c_.x - r, c_.y + r},
          {c_.x - r, c_.y - r}};
}

std::vector<Vec2> Square::zigzag(int first, int count, bool across) const {
  std::vector<Vec2> pts;
  const double lo = -s_ / 2 + 1.5 * w_, hi = s_ / 2 - 1.5 * w_;
  for (int j = first; j < first + count && j < lines(); ++j) {
    const double v = -s_ / 2 + 1.5 * w_ + j * w_;
    const double a = (j - first) % 2 ? hi : lo, b = (j - first) % 2 ? lo : hi;
    if (across) {
      pts.push_back({c_.x + v, c_.y + a});
      pts.push_back({c_.x + v, c_.y + b});
    } else {
      pts.push_back({c_.x + a, c_.y + v});
      pts.push_back({c_.x + b, c_.y + v});
    }
  }
  return pts;
}

std::vector<Vec2> Square::sparse(int first, bool across) const {
  std::vector<Vec2> pts;
  int k = 0;
  for (int j = first + (kSparse - first % kSparse) % kSparse; j < lines(); j += kSparse, ++k) {
    const auto line = zigzag(j, 1, across);
    if (k % 2) {
      pts.push_back(line[1]);
      pts.push_back(line[0]);
    } else {
      pts.insert(pts.end(), line.begin(), line.end());
    }
  }
  return pts;
}

double side_for(std::size_t most, double length, double bead, double min_side) {
  double s = std::max(min_side, 6 * bead);
  for (;; s += bead) {
    const Square sq({0, 0}, s, bead);
    if (static_cast<double>(most) * sq.lines_for(length) <= sq.lines()) return s;
    if (s > 500)
      throw GeometryError("the purge tower would need more than 500 mm a side to hold " +
                              std::to_string(most) + " purges of " + mm(length) +
                              " mm on one layer (lower purge.melt_volume, raise purge.threshold "
                              "or use fewer colours)",
                          {"", 0, "purge.melt_volume"});
  }
}

Vec2 place(const BBox2& part, double s, const PurgeOptions& o) {
  const double h = s / 2, clr = o.clearance;
  auto tower_box = [&](Vec2 c) { return BBox2{{c.x - h, c.y - h}, {c.x + h, c.y + h}}; };
  auto fits = [&](Vec2 c) {
    if (!(o.bed_x > 0)) return true;
    const BBox2 t = tower_box(c);
    const BBox2 all{{std::min(t.min.x, part.min.x), std::min(t.min.y, part.min.y)},
                    {std::max(t.max.x, part.max.x), std::max(t.max.y, part.max.y)}};
    // Where the bed's centre lies in design coordinates.
    const Vec2 mid = o.centred ? Vec2{(all.min.x + all.max.x) / 2, (all.min.y + all.max.y) / 2}
                     : o.origin_centre ? Vec2{-o.offset_x, -o.offset_y}
                                       : Vec2{o.bed_x / 2 - o.offset_x, o.bed_y / 2 - o.offset_y};
    if (o.circular) {
      const double r = o.bed_x / 2 + 1e-9;
      for (const BBox2& b : {t, part})
        for (const Vec2 q : {b.min, b.max, Vec2{b.min.x, b.max.y}, Vec2{b.max.x, b.min.y}})
          if (std::hypot(q.x - mid.x, q.y - mid.y) > r) return false;
      return true;
    }
    const double ex = 1e-9;
    return t.min.x >= mid.x - o.bed_x / 2 - ex && t.max.x <= mid.x + o.bed_x / 2 + ex &&
           t.min.y >= mid.y - o.bed_y / 2 - ex && t.max.y <= mid.y + o.bed_y / 2 + ex &&
           (!o.centred || (all.width() <= o.bed_x + ex && all.height() <= o.bed_y + ex));
  };
  const std::string sizes = "a " + mm(s) + " mm tower " + mm(clr) + " mm from the part's " +
                            mm(part.width()) + " x " + mm(part.height()) + " mm footprint on the " +
                            (o.circular ? "round bed of " + mm(o.bed_x) + " mm"
                                        : mm(o.bed_x) + " x " + mm(o.bed_y) + " mm bed");
  if (!o.automatic) {
    const Vec2 c{o.x, o.y};
    const BBox2 t = tower_box(c);
    if (t.max.x > part.min.x - clr && t.min.x < part.max.x + clr && t.max.y > part.min.y - clr &&
        t.min.y < part.max.y + clr)
      throw GeometryError("the purge tower at (" + mm(o.x) + ", " + mm(o.y) + ") overlaps the part: " +
                              sizes + " (use purge.position = auto, or move purge.x/purge.y)",
                          {"", 0, "purge.x"});
    if (!fits(c))
      throw GeometryError("the purge tower at (" + mm(o.x) + ", " + mm(o.y) +
                              ") is off the bed: " + sizes,
                          {"", 0, "purge.x"});
    return c;
  }
  const Vec2 mid{(part.min.x + part.max.x) / 2, (part.min.y + part.max.y) / 2};
  const Vec2 candidates[] = {{part.max.x + clr + h, mid.y},
                             {part.min.x - clr - h, mid.y},
                             {mid.x, part.max.y + clr + h},
                             {mid.x, part.min.y - clr - h}};
  for (const Vec2 c : candidates)
    if (fits(c)) return c;
  throw GeometryError("no free bed space for the purge tower: " + sizes +
                          " fits on no side (lower purge.melt_volume or purge.clearance, raise "
                          "purge.threshold, or use fewer colours)",
                      {"", 0, "purge.melt_volume"});
}

}  // namespace trellis::tower
