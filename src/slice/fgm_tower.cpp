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

namespace trellis {

double purge_length(double volume, double h, double w) {
  const double area = h * (w - h) + 3.14159265358979323846 * h * h / 4;
  return area > 0 ? volume / area : 0;
}

namespace tower {

PrimeTower::PrimeTower(const FgmOptions& o, const PurgeOptions& purge)
    : o_(o),
      purge_(purge),
      length_(purge.melt_volume > 0 ? purge_length(purge.melt_volume, o.layer_height, o.bead_width)
                                    : 0),
      part_{{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()},
            {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}} {}

bool PrimeTower::purges(int before, int after) const {
  if (before < 0 || after == before) return false;
  // The mixture change: the largest change of any material's share.
  const auto from = o_.palette.mixture(before), to = o_.palette.mixture(after);
  double change = 0;
  for (std::size_t m = 0; m < to.size(); ++m) change = std::max(change, std::abs(to[m] - from[m]));
  return change > purge_.threshold;
}

void PrimeTower::observe(const Layer& layer) {
  const std::size_t li = observed_++;
  if (!(purge_.melt_volume > 0)) return;
  std::size_t count = 0;
  for (const Path& p : layer.paths) {
    for (const auto& q : p.points) {
      part_.min = {std::min(part_.min.x, q.x), std::min(part_.min.y, q.y)};
      part_.max = {std::max(part_.max.x, q.x), std::max(part_.max.y, q.y)};
    }
    const int colour = colour_of(p);
    if (colour < 0) continue;
    if (first_colour_ < 0) first_colour_ = colour;
    count += purges(seen_, colour);
    seen_ = colour;
  }
  most_ = std::max(most_, count);
  if (count > 0) last_purge_layer_ = static_cast<long>(li);
}

bool PrimeTower::plan(FgmStats& st) {
  st.purges = 0;
  st.purge_length = st.purge_volume = 0;
  st.tower = {};
  if (!(purge_.melt_volume > 0) || last_purge_layer_ < 0) return false;
  // The footprint of the beads, not of their centre lines.
  const BBox2 beads{{part_.min.x - o_.bead_width / 2, part_.min.y - o_.bead_width / 2},
                    {part_.max.x + o_.bead_width / 2, part_.max.y + o_.bead_width / 2}};
  block_ = plan_tower(beads, most_, length_, o_.bead_width, purge_);
  st.tower.built = true;
  st.tower.x = block_->centre().x;
  st.tower.y = block_->centre().y;
  st.tower.side = std::max(block_->size_x(), block_->size_y());
  st.tower.size_x = block_->size_x();
  st.tower.size_y = block_->size_y();
  st.tower.purge_path = length_;
  st.tower.layers = static_cast<std::size_t>(last_purge_layer_) + 1;
  return true;
}

Path PrimeTower::tower_path(std::vector<Vec2> pts, int colour, double z) {
  Path p;
  p.role = PathRole::Purge;
  p.mixture = o_.palette.mixture(colour);
  p.width = o_.bead_width;
  p.height = o_.layer_height;
  for (const Vec2 q : pts) p.points.push_back({q.x, q.y, z});
  TowerColour& c = colours_[colour];
  c.color = colour;
  c.mixture = p.mixture;
  c.length += p.length();
  return p;
}

void PrimeTower::add(std::size_t li, Layer& layer) {
  if (!block_) return;
  const Block& sq = *block_;
  // Which paths purge (the colour before a layer's first path is the last of the layer below).
  std::vector<char> purge_before(layer.paths.size(), 0);
  long count = 0;
  for (int last = last_, i = 0; i < static_cast<int>(layer.paths.size()); ++i) {
    const int colour = colour_of(layer.paths[static_cast<std::size_t>(i)]);
    if (colour < 0) continue;
    if (purges(last, colour)) purge_before[static_cast<std::size_t>(i)] = 1, ++count;
    last = colour;
  }
  std::vector<Path> out;
  const bool across = li % 2 == 1;  // lines cross the layer below's
  const int k = sq.lines_for(length_, across);
  int used = 0;
  if (static_cast<long>(li) <= last_purge_layer_) {
    // Wall and sparse lines in the colour already loaded, around the lines the purges use.
    const int base = last_ >= 0 ? last_ : first_colour_;
    out.push_back(tower_path(sq.wall(), base, layer.z));
    auto sparse = sq.sparse(static_cast<int>(count) * k, across);
    if (sparse.size() >= 2) out.push_back(tower_path(std::move(sparse), base, layer.z));
  }
  for (std::size_t i = 0; i < layer.paths.size(); ++i) {
    const int colour = colour_of(layer.paths[i]);
    if (purge_before[i]) {
      Path p = tower_path(sq.zigzag(used, k, across), colour, layer.z);
      used += k;
      purge_length_ += p.length();
      ++purges_;
      ++colours_[colour].purges;
      out.push_back(std::move(p));
    }
    if (colour >= 0) last_ = colour;
    out.push_back(std::move(layer.paths[i]));
  }
  layer.paths = std::move(out);
}

void PrimeTower::finish(FgmStats& st) const {
  if (!block_) return;
  st.purges = purges_;
  st.purge_length = purge_length_;
  const double bead_area = o_.layer_height * (o_.bead_width - o_.layer_height) +
                           3.14159265358979323846 * o_.layer_height * o_.layer_height / 4;
  st.purge_volume = st.purge_length * bead_area;
  for (auto [colour, c] : colours_) {
    c.volume = c.length * bead_area;
    double density = 0;
    for (std::size_t m = 0; m < c.mixture.size(); ++m)
      density += c.mixture[m] * (m < purge_.density.size() ? purge_.density[m] : 1.0);
    c.mass = c.volume * 1e-3 * density;
    c.time = purge_.speed > 0 ? c.length / purge_.speed : 0;
    st.tower.length += c.length;
    st.tower.volume += c.volume;
    st.tower.mass += c.mass;
    st.tower.time += c.time;
    st.tower.colours.push_back(c);
  }
}

}  // namespace tower

void add_prime_tower(Toolpath& tp, const FgmOptions& o, const PurgeOptions& purge, FgmStats& st) {
  tower::PrimeTower t(o, purge);
  for (const Layer& l : tp.layers) t.observe(l);
  if (!t.plan(st)) return;
  for (std::size_t li = 0; li < tp.layers.size(); ++li) t.add(li, tp.layers[li]);
  t.finish(st);
}

}  // namespace trellis
