#include "trellis/slice/pbf_lasers.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <exception>
#include <limits>
#include <optional>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-9;          // mm: a point on a field's edge is inside it
constexpr double kBoundaryTol = 1e-3;  // mm: balancing stops when a boundary is this close

struct Extent {
  double x0 = kInf, x1 = -kInf, y0 = kInf, y1 = -kInf;
  double mid() const { return 0.5 * (x0 + x1); }
};

Extent extent_of(const std::vector<Vec3>& pts) {
  Extent e;
  for (const Vec3& q : pts)
    e.x0 = std::min(e.x0, q.x), e.x1 = std::max(e.x1, q.x), e.y0 = std::min(e.y0, q.y),
    e.y1 = std::max(e.y1, q.y);
  return e;
}

bool holds(const BBox2& f, const Extent& e) {
  return e.x0 >= f.min.x - kEps && e.x1 <= f.max.x + kEps && e.y0 >= f.min.y - kEps &&
         e.y1 <= f.max.y + kEps;
}

bool is_hatch(const Path& p) {
  return p.role == PathRole::Hatch || p.role == PathRole::Infill;
}

// The speed `laser` marks `p` at (expose_on's, without copying the path).
double exposed_speed(const Path& p, const LaserParameters& laser, const LaserParameters& profile) {
  const bool hatch = is_hatch(p);
  if (hatch && p.power == profile.hatch_power && p.speed == profile.hatch_speed)
    return laser.hatch_speed;
  if (!hatch && p.power == profile.contour_power && p.speed == profile.contour_speed)
    return laser.contour_speed;
  return p.speed > 0 ? p.speed : (hatch ? laser.timing.hatch_speed : laser.timing.contour_speed);
}

// One laser's scan time over `vectors` as it exposes them: scan_time of the exposed paths.
double exposed_seconds(const std::vector<const Path*>& vectors, const LaserParameters& laser,
                       const LaserParameters& profile) {
  ScanClock clock(laser.timing);
  std::vector<Vec2> xy;
  for (const Path* p : vectors) {
    if (p->points.size() < 2) continue;
    xy.clear();
    for (const Vec3& q : p->points) xy.push_back({q.x, q.y});
    clock.mark(xy.data(), xy.size(), exposed_speed(*p, laser, profile));
  }
  return clock.seconds();
}

// One piece of the split: a whole path of the layer or a piece of one cut at a boundary.
struct Piece {
  std::size_t source;
  int laser;
  const Path* path;  // the layer's path, or one of Split::cuts
};

struct Split {
  std::vector<Piece> pieces;
  std::deque<Path> cuts;  // pieces of cut paths (a deque: Piece::path points into it)
  std::size_t cut_paths = 0;
};

// `path` cut where it crosses the boundaries strictly inside its X extent.
std::vector<std::vector<Vec3>> cut_at(const Path& path, const std::vector<double>& b) {
  std::vector<std::vector<Vec3>> out(1);
  out.back().push_back(path.points.front());
  for (std::size_t k = 1; k < path.points.size(); ++k) {
    const Vec3 p = path.points[k - 1], q = path.points[k];
    std::vector<double> ts;
    for (double x : b)
      if ((p.x < x && x < q.x) || (q.x < x && x < p.x)) ts.push_back((x - p.x) / (q.x - p.x));
    std::sort(ts.begin(), ts.end());
    for (double t : ts) {
      const Vec3 c{p.x + t * (q.x - p.x), p.y + t * (q.y - p.y), p.z + t * (q.z - p.z)};
      out.back().push_back(c);
      out.push_back({c});
    }
    out.back().push_back(q);
  }
  return out;
}

// Splits a layer into stripes across X. Along Y, the caller swaps X and Y of the layer and the
// fields first (`swapped`: coordinates in messages are swapped back).
class Splitter {
 public:
  Splitter(const Layer& layer, const LaserSetup& setup, std::size_t index, bool swapped)
      : layer_(layer),
        setup_(setup),
        index_(index),
        n_(static_cast<int>(setup.fields.size())),
        swapped_(swapped) {
    for (const Path& p : layer.paths) extents_.push_back(extent_of(p.points));
  }

  Split split(const std::vector<double>& b) const {
    Split s;
    for (std::size_t i = 0; i < layer_.paths.size(); ++i) {
      const Path& path = layer_.paths[i];
      if (const int l = whole(extents_[i], b); l >= 0) {
        s.pieces.push_back({i, l, &path});
        continue;
      }
      const auto parts = cut_at(path, b);
      if (parts.size() > 1) ++s.cut_paths;
      for (const auto& pts : parts) {
        const Extent e = extent_of(pts);
        const int l = reaching(e, stripe_of(e.mid(), b));
        if (l < 0) {
          const Vec3 a = unswapped(pts.front()), b = unswapped(pts.back());
          throw GeometryError(
              fmt::format("layer {}: a {} vector from ({:.3f}, {:.3f}) to ({:.3f}, {:.3f}) lies in "
                          "no laser's field: widen the fields or move the part",
                          index_, to_string(path.role), a.x, a.y, b.x, b.y),
              {"", 0, "laser.fields"});
        }
        if (parts.size() == 1) {
          s.pieces.push_back({i, l, &path});
        } else {
          Path piece;
          piece.role = path.role, piece.tool = path.tool, piece.mixture = path.mixture;
          piece.width = path.width, piece.height = path.height, piece.speed = path.speed;
          piece.power = path.power, piece.temperature = path.temperature, piece.flow = path.flow;
          piece.fan = path.fan, piece.part = path.part;
          piece.points = pts;
          s.cuts.push_back(std::move(piece));
          s.pieces.push_back({i, l, &s.cuts.back()});
        }
      }
    }
    return s;
  }

  std::vector<double> seconds(const Split& s) const {
    std::vector<std::vector<const Path*>> by(static_cast<std::size_t>(n_));
    for (const Piece& p : s.pieces) by[static_cast<std::size_t>(p.laser)].push_back(p.path);
    std::vector<double> t;
    for (std::size_t l = 0; l < by.size(); ++l)
      t.push_back(setup_.lasers.empty() ? scan_time(by[l], setup_.timing)
                                        : exposed_seconds(by[l], setup_.lasers[l], setup_.profile));
    return t;
  }

  // The stripe boundaries that balance the lasers' times as far as their fields allow.
  std::vector<double> balance() const {
    const std::size_t nb = static_cast<std::size_t>(n_ - 1);
    double x0 = kInf, x1 = -kInf;
    for (const Extent& e : extents_) x0 = std::min(x0, e.x0), x1 = std::max(x1, e.x1);
    if (!(x0 <= x1)) x0 = x1 = 0;
    std::vector<double> lo(nb), hi(nb), b(nb);
    for (std::size_t j = 0; j < nb; ++j) {
      // Laser j + 1's stripe starts inside its field, laser j's ends inside its.
      lo[j] = std::max(x0, setup_.fields[j + 1].min.x);
      hi[j] = std::min(x1, setup_.fields[j].max.x);
      if (lo[j] > hi[j]) hi[j] = lo[j];
    }
    initial(b, x0, x1);
    for (std::size_t j = 0; j < nb; ++j) {
      b[j] = std::clamp(b[j], lo[j], hi[j]);
      if (j > 0) b[j] = std::max(b[j], b[j - 1]);
    }
    const int sweeps = n_ == 2 ? 1 : 4;
    for (int sweep = 0; sweep < sweeps; ++sweep)
      for (std::size_t j = 0; j < nb; ++j) {
        double a = std::max(lo[j], j > 0 ? b[j - 1] : -kInf);
        double c = std::min(hi[j], j + 1 < nb ? b[j + 1] : kInf);
        if (a > c) c = a;
        // f(x) = T_j - T_{j+1} grows with x: find where it changes sign.
        const auto gap = [&](double x) {
          b[j] = x;
          const auto t = seconds(split(b));
          return std::pair{t[j] - t[j + 1], std::max(t[j], t[j + 1])};
        };
        auto fa = gap(a), fc = gap(c);
        if (fa.first >= 0) {
          b[j] = a;
          continue;
        }
        if (fc.first <= 0) {
          b[j] = c;
          continue;
        }
        for (int it = 0; it < 40 && c - a > kBoundaryTol; ++it) {
          const double m = 0.5 * (a + c);
          const auto fm = gap(m);
          (fm.first < 0 ? a : c) = m;
          (fm.first < 0 ? fa : fc) = fm;
        }
        b[j] = fa.second <= fc.second ? a : c;
      }
    return b;
  }

 private:
  Vec3 unswapped(Vec3 p) const { return swapped_ ? Vec3{p.y, p.x, p.z} : p; }

  // Equal shares of an estimate of each vector's time, placed at its middle.
  void initial(std::vector<double>& b, double x0, double x1) const {
    std::vector<std::pair<double, double>> w;
    double total = 0;
    for (std::size_t i = 0; i < extents_.size(); ++i) {
      const double t =
          scan_time({&layer_.paths[i]}, setup_.timing) + setup_.timing.jump_delay * 1e-6;
      w.emplace_back(extents_[i].mid(), t);
      total += t;
    }
    std::sort(w.begin(), w.end());
    double acc = 0;
    std::size_t k = 0;
    for (std::size_t j = 0; j < b.size(); ++j) {
      const double target = total * static_cast<double>(j + 1) / n_;
      while (k < w.size() && acc + w[k].second < target) acc += w[k++].second;
      b[j] = k < w.size() ? w[k].first : x0 + (x1 - x0) * static_cast<double>(j + 1) / n_;
    }
  }

  static int stripe_of(double x, const std::vector<double>& b) {
    return static_cast<int>(std::upper_bound(b.begin(), b.end(), x) - b.begin());
  }

  // The laser that takes a path whole: its stripe's (the one holding its middle), else a
  // neighbour's, within the overlap and the laser's field; -1 = none (the path is cut).
  int whole(const Extent& e, const std::vector<double>& b) const {
    const int s = stripe_of(e.mid(), b);
    for (int l : {s, s - 1, s + 1}) {
      if (l < 0 || l >= n_) continue;
      const double lo = l == 0 ? -kInf : b[static_cast<std::size_t>(l - 1)] - setup_.overlap / 2;
      const double hi = l == n_ - 1 ? kInf : b[static_cast<std::size_t>(l)] + setup_.overlap / 2;
      if (e.x0 >= lo - kEps && e.x1 <= hi + kEps &&
          holds(setup_.fields[static_cast<std::size_t>(l)], e))
        return l;
    }
    return -1;
  }

  // The laser nearest stripe `s` whose field holds the extent, -1 if none.
  int reaching(const Extent& e, int s) const {
    for (int d = 0; d < n_; ++d)
      for (int l : {s - d, s + d})
        if (l >= 0 && l < n_ && holds(setup_.fields[static_cast<std::size_t>(l)], e)) return l;
    return -1;
  }

  const Layer& layer_;
  const LaserSetup& setup_;
  std::size_t index_;
  int n_;
  bool swapped_;
  std::vector<Extent> extents_;
};

LaserSplit split_across_x(Layer& layer, const LaserSetup& setup, std::size_t layer_index,
                          bool swapped) {
  LaserSplit r;
  const Splitter sp(layer, setup, layer_index, swapped);
  r.boundaries = setup.fields.size() > 1 ? sp.balance() : std::vector<double>{};
  Split s = sp.split(r.boundaries);
  r.seconds = sp.seconds(s);
  r.cut = s.cut_paths;
  if (setup.fields.size() == 1) {
    for (std::size_t i = 0; i < layer.paths.size(); ++i) r.source.push_back(i);
    if (!setup.lasers.empty())
      for (Path& p : layer.paths) expose_on(p, setup.lasers[0], setup.profile);
    return r;  // one laser: every path is its own, as it was
  }
  std::vector<Path> paths;
  paths.reserve(s.pieces.size());
  for (const Piece& p : s.pieces) {
    Path q = p.path == &layer.paths[p.source] ? std::move(layer.paths[p.source]) : *p.path;
    q.tool = p.laser;
    if (!setup.lasers.empty())
      expose_on(q, setup.lasers[static_cast<std::size_t>(p.laser)], setup.profile);
    paths.push_back(std::move(q));
    r.source.push_back(p.source);
  }
  layer.paths = std::move(paths);
  return r;
}

void swap_xy(Layer& layer) {
  for (Path& p : layer.paths)
    for (Vec3& q : p.points) std::swap(q.x, q.y);
}

LaserSetup swap_xy(LaserSetup s) {
  for (BBox2& f : s.fields) std::swap(f.min.x, f.min.y), std::swap(f.max.x, f.max.y);
  return s;
}

// The split across X, or across Y with X and Y swapped around it.
LaserSplit split_along(Layer& layer, const LaserSetup& setup, std::size_t layer_index,
                       LaserAxis axis) {
  const bool y = axis == LaserAxis::Y;
  if (!y) return split_across_x(layer, setup, layer_index, false);
  swap_xy(layer);
  LaserSplit r;
  try {
    r = split_across_x(layer, swap_xy(setup), layer_index, true);
  } catch (...) {
    swap_xy(layer);
    throw;
  }
  swap_xy(layer);
  r.axis = LaserAxis::Y;
  return r;
}

}  // namespace

const char* to_string(LaserAxis axis) {
  switch (axis) {
    case LaserAxis::X:
      return "x";
    case LaserAxis::Y:
      return "y";
    case LaserAxis::Auto:
      break;
  }
  return "auto";
}

BBox2 whole_plate() {
  return {{-kInf, -kInf}, {kInf, kInf}};
}

LaserSetup laser_setup(int lasers, const std::vector<double>& fields, double overlap,
                       const ScanTiming& timing) {
  LaserSetup s;
  s.overlap = overlap;
  s.timing = timing;
  if (lasers < 1) throw SettingError("laser.lasers must be at least 1", {"", 0, "laser.lasers"});
  if (fields.empty()) {
    s.fields.assign(static_cast<std::size_t>(lasers), whole_plate());
    return s;
  }
  if (fields.size() != 4 * static_cast<std::size_t>(lasers))
    throw SettingError(
        fmt::format("{} numbers: {} laser(s) need x0, y0, x1, y1 "
                    "each ({} numbers), or none for lasers that reach the whole plate",
                    fields.size(), lasers, 4 * lasers),
        {"", 0, "laser.fields"});
  for (int l = 0; l < lasers; ++l) {
    const double* f = &fields[4 * static_cast<std::size_t>(l)];
    if (!(f[0] < f[2] && f[1] < f[3]))
      throw SettingError(fmt::format("laser {}'s field {}, {}, {}, {} is empty "
                                     "(x0 < x1 and y0 < y1)",
                                     l + 1, f[0], f[1], f[2], f[3]),
                         {"", 0, "laser.fields"});
    s.fields.push_back({{f[0], f[1]}, {f[2], f[3]}});
  }
  return s;
}

LaserSetup laser_setup(const std::vector<double>& fields, double overlap,
                       const LaserParameters& profile, const std::vector<LaserParameters>& each) {
  LaserSetup s = laser_setup(static_cast<int>(each.size()), fields, overlap, profile.timing);
  s.profile = profile;
  s.lasers = each;
  return s;
}

void expose_on(Path& p, const LaserParameters& laser, const LaserParameters& profile) {
  const bool hatch = is_hatch(p);
  if (hatch && p.power == profile.hatch_power && p.speed == profile.hatch_speed)
    p.power = laser.hatch_power, p.speed = laser.hatch_speed;
  else if (!hatch && p.power == profile.contour_power && p.speed == profile.contour_speed)
    p.power = laser.contour_power, p.speed = laser.contour_speed;
}

double LaserSplit::build_seconds() const {
  return seconds.empty() ? 0.0 : *std::max_element(seconds.begin(), seconds.end());
}

LaserSplit split_among_lasers(Layer& layer, const LaserSetup& setup, std::size_t layer_index) {
  if (setup.fields.size() == 1 || setup.axis != LaserAxis::Auto)
    return split_along(layer, setup, layer_index,
                       setup.fields.size() == 1 ? LaserAxis::X : setup.axis);
  // Auto: both splits, the sooner built kept (X on a tie); one the fields refuse is skipped.
  Layer other = layer;
  std::optional<LaserSplit> x, y;
  std::exception_ptr x_failed;
  try {
    x = split_along(layer, setup, layer_index, LaserAxis::X);
  } catch (const GeometryError&) {
    x_failed = std::current_exception();
  }
  try {
    y = split_along(other, setup, layer_index, LaserAxis::Y);
  } catch (const GeometryError&) {
    if (x_failed) std::rethrow_exception(x_failed);
  }
  if (!x || (y && y->build_seconds() < x->build_seconds() * (1 - 1e-9))) {
    layer = std::move(other);
    return *y;
  }
  return *x;
}

void LaserTimes::add(const LaserSplit& split) {
  per_layer.push_back(split.seconds);
  cut += split.cut;
  along_y += split.axis == LaserAxis::Y;
}

std::vector<double> LaserTimes::totals() const {
  std::vector<double> t;
  for (const auto& l : per_layer) {
    if (t.size() < l.size()) t.resize(l.size(), 0.0);
    for (std::size_t k = 0; k < l.size(); ++k) t[k] += l[k];
  }
  return t;
}

double LaserTimes::build_seconds() const {
  double s = 0;
  for (const auto& l : per_layer)
    if (!l.empty()) s += *std::max_element(l.begin(), l.end());
  return s;
}

LaserTimes laser_times(const Toolpath& tp, const ScanTiming& timing) {
  int lasers = 1;
  for (const Layer& l : tp.layers)
    for (const Path& p : l.paths) lasers = std::max(lasers, p.tool + 1);
  return laser_times(tp, std::vector<ScanTiming>(static_cast<std::size_t>(lasers), timing));
}

LaserTimes laser_times(const Toolpath& tp, const std::vector<ScanTiming>& each) {
  std::size_t lasers = std::max<std::size_t>(each.size(), 1);
  for (const Layer& l : tp.layers)
    for (const Path& p : l.paths)
      lasers = std::max(lasers, static_cast<std::size_t>(std::max(0, p.tool)) + 1);
  if (lasers > each.size())
    throw SettingError(fmt::format("the toolpath has paths of laser {} but the machine has {} "
                                   "laser(s) with their own timing",
                                   lasers, each.size()),
                       {"", 0, "laser.lasers"});
  LaserTimes t;
  for (const Layer& l : tp.layers) {
    std::vector<std::vector<const Path*>> by(lasers);
    for (const Path& p : l.paths) by[static_cast<std::size_t>(std::max(0, p.tool))].push_back(&p);
    std::vector<double> s;
    for (std::size_t k = 0; k < lasers; ++k) s.push_back(scan_time(by[k], each[k]));
    t.per_layer.push_back(std::move(s));
  }
  return t;
}

}  // namespace trellis
