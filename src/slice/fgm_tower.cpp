#include "fgm_tower.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
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

int Block::lines(bool across) const {
  const double span = across ? sx_ : sy_;
  return std::max(0, static_cast<int>(std::floor((span - 2 * w_) / w_ + 1e-9)));
}

double Block::line_length(bool across) const {
  return std::max(0.0, (across ? sy_ : sx_) - 3 * w_);
}

int Block::lines_for(double length, bool across) const {
  const double l = line_length(across);
  if (l <= 0) return lines(across) + 1;
  return std::max(1, static_cast<int>(std::ceil((length + w_) / (l + w_) - 1e-12)));
}

bool Block::holds(std::size_t most, double length) const {
  for (bool across : {false, true})
    if (static_cast<double>(most) * lines_for(length, across) > lines(across)) return false;
  return true;
}

std::vector<Vec2> Block::wall() const {
  const double rx = sx_ / 2 - w_ / 2, ry = sy_ / 2 - w_ / 2;
  return {{c_.x - rx, c_.y - ry},
          {c_.x + rx, c_.y - ry},
          {c_.x + rx, c_.y + ry},
          {c_.x - rx, c_.y + ry},
          {c_.x - rx, c_.y - ry}};
}

std::vector<Vec2> Block::zigzag(int first, int count, bool across) const {
  std::vector<Vec2> pts;
  const double along = across ? sy_ : sx_, span = across ? sx_ : sy_;
  const double lo = -along / 2 + 1.5 * w_, hi = along / 2 - 1.5 * w_;
  for (int j = first; j < first + count && j < lines(across); ++j) {
    const double v = -span / 2 + 1.5 * w_ + j * w_;
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

std::vector<Vec2> Block::sparse(int first, bool across) const {
  std::vector<Vec2> pts;
  int k = 0;
  for (int j = first + (kSparse - first % kSparse) % kSparse; j < lines(across);
       j += kSparse, ++k) {
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
    if (Block({0, 0}, s, s, bead).holds(most, length)) return s;
    if (s > 500)
      throw GeometryError("the purge tower would need more than 500 mm a side to hold " +
                              std::to_string(most) + " purges of " + mm(length) +
                              " mm on one layer (lower purge.melt_volume, raise purge.threshold "
                              "or use fewer colours)",
                          {"", 0, "purge.melt_volume"});
  }
}

Vec2 place(const BBox2& part, double sx, double sy, const PurgeOptions& o) {
  const double hx = sx / 2, hy = sy / 2, clr = o.clearance;
  auto tower_box = [&](Vec2 c) { return BBox2{{c.x - hx, c.y - hy}, {c.x + hx, c.y + hy}}; };
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
  const std::string sizes = "a " + (sx == sy ? mm(sx) : mm(sx) + " x " + mm(sy)) + " mm tower " +
                            mm(clr) + " mm from the part's " + mm(part.width()) + " x " +
                            mm(part.height()) + " mm footprint on the " +
                            (o.circular ? "round bed of " + mm(o.bed_x) + " mm"
                                        : mm(o.bed_x) + " x " + mm(o.bed_y) + " mm bed");
  if (!o.automatic) {
    const Vec2 c{o.x, o.y};
    const BBox2 t = tower_box(c);
    if (t.max.x > part.min.x - clr && t.min.x < part.max.x + clr && t.max.y > part.min.y - clr &&
        t.min.y < part.max.y + clr)
      throw GeometryError("the purge tower at (" + mm(o.x) + ", " + mm(o.y) +
                              ") overlaps the part: " + sizes +
                              " (use purge.position = auto, or move purge.x/purge.y)",
                          {"", 0, "purge.x"});
    if (!fits(c))
      throw GeometryError(
          "the purge tower at (" + mm(o.x) + ", " + mm(o.y) + ") is off the bed: " + sizes,
          {"", 0, "purge.x"});
    return c;
  }
  const Vec2 mid{(part.min.x + part.max.x) / 2, (part.min.y + part.max.y) / 2};
  const Vec2 candidates[] = {{part.max.x + clr + hx, mid.y},
                             {part.min.x - clr - hx, mid.y},
                             {mid.x, part.max.y + clr + hy},
                             {mid.x, part.min.y - clr - hy}};
  for (const Vec2 c : candidates)
    if (fits(c)) return c;
  throw GeometryError("no free bed space for the purge tower: " + sizes +
                          " fits on no side (lower purge.melt_volume or purge.clearance, raise "
                          "purge.threshold, or use fewer colours)",
                      {"", 0, "purge.melt_volume"});
}

Block plan_tower(const BBox2& part, std::size_t most, double length, double bead,
                 const PurgeOptions& o) {
  const double side = side_for(most, length, bead, o.side);
  std::string square_error;
  try {
    return Block(place(part, side, side, o), side, side, bead);
  } catch (const GeometryError& e) {
    if (!o.automatic || !(o.bed_x > 0)) throw;
    square_error = e.message();
  }
  // A strip along one side of the part: for each length along it (the bed's extent down to the
  // square's side, in 1 mm steps), the narrowest depth that holds the purges; the smallest area
  // that fits the bed beside the part wins (place() tries the sides in its order).
  const double bed_x = o.bed_x, bed_y = o.circular ? o.bed_x : o.bed_y;
  double best_area = std::numeric_limits<double>::infinity();
  std::optional<Block> best;
  for (int along_x = 0; along_x < 2; ++along_x) {
    const double extent = along_x ? bed_x : bed_y;
    for (double a = std::floor(extent - 1e-6); a >= side; a -= 1) {
      double d = std::max(o.side, 6 * bead);
      while (d < a && !Block({0, 0}, along_x ? a : d, along_x ? d : a, bead).holds(most, length))
        d += bead;
      if (d >= a) break;  // no narrower than a square any more
      const double sx = along_x ? a : d, sy = along_x ? d : a;
      if (sx * sy >= best_area) continue;
      try {
        best = Block(place(part, sx, sy, o), sx, sy, bead);
        best_area = sx * sy;
      } catch (const GeometryError&) {
      }
    }
  }
  if (best) return *best;
  const double need = static_cast<double>(most) * length * bead;
  throw GeometryError(square_error +
                          "; nor does any strip along a side of the part: the busiest "
                          "layer has " +
                          std::to_string(most) + " purges of " + mm(length) + " mm, about " +
                          mm(need) + " mm2 of tower",
                      {"", 0, "purge.melt_volume"});
}

}  // namespace trellis::tower
