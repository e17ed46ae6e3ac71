#include "trellis/slice/infill.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "trellis/core/error.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/plan/euler.hpp"

namespace trellis {

namespace {

constexpr double kPi = std::numbers::pi;

const std::vector<std::string> kNames = {"rectilinear", "grid",       "triangles", "honeycomb",
                                         "gyroid",      "concentric", "lattice"};

// Mean length per area of the gyroid's plane sections, sin x cos y + sin y cos z + sin z cos x
// = 0 with period 2π, over z (rad⁻¹; the sections repeat every π/2 in z): measured with this
// file's march at 128 heights on a square of 48 periods. A single section has from 0.3675 (z = 0:
// exactly L/(2π²), L the length of y = −atan(sin x) over a period) to about 0.465 at z = π/4,
// where the curves touch: a layer's density is within −6%/+19% of the asked one, the part's on it.
constexpr double kGyroidLengthPerArea = 0.3913;

double polyline_length(const std::vector<Vec2>& l) {
  double s = 0;
  for (std::size_t i = 1; i < l.size(); ++i) s += std::sqrt(dist2(l[i - 1], l[i]));
  return s;
}

double ring_length(const std::vector<Vec2>& r) {
  return r.size() < 2 ? 0 : polyline_length(r) + std::sqrt(dist2(r.back(), r.front()));
}

BBox2 box_of(const Regions& regions) {
  BBox2 b{{1e300, 1e300}, {-1e300, -1e300}};
  for (const auto& p : regions)
    for (const Vec2 q : p.outer) {
      b.min = {std::min(b.min.x, q.x), std::min(b.min.y, q.y)};
      b.max = {std::max(b.max.x, q.x), std::max(b.max.y, q.y)};
    }
  return b;
}

Vec2 turn(Vec2 p, double deg) {
  const double t = deg * kPi / 180, c = std::cos(t), s = std::sin(t);
  return {c * p.x - s * p.y, s * p.x + c * p.y};
}

// The box, in a frame turned by `deg` about the origin, that holds `box` (world coordinates).
BBox2 turned_box(const BBox2& box, double deg) {
  BBox2 b{{1e300, 1e300}, {-1e300, -1e300}};
  for (const Vec2 c : {box.min, box.max, Vec2{box.min.x, box.max.y}, Vec2{box.max.x, box.min.y}}) {
    const Vec2 q = turn(c, -deg);
    b.min = {std::min(b.min.x, q.x), std::min(b.min.y, q.y)};
    b.max = {std::max(b.max.x, q.x), std::max(b.max.y, q.y)};
  }
  return b;
}

// Moves points within `reach` of the region's outline onto it: Clipper's cut points lie on its
// 1 nm grid, about a nanometre off the outline. Outline edges are bucketed in a uniform grid.
class OutlineSnap {
 public:
  OutlineSnap(const Regions& region, double reach) : reach_(reach) {
    for (const auto& ring : rings_of(region))
      for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
        edges_.push_back({ring[j], ring[i]});
    if (edges_.empty()) return;
    box_ = box_of(region);
    box_.min = box_.min - Vec2{2 * reach, 2 * reach};
    box_.max = box_.max + Vec2{2 * reach, 2 * reach};
    const double side = std::max(box_.width(), box_.height());
    cell_ = std::max(side / std::sqrt(static_cast<double>(edges_.size())), 1e-3);
    nx_ = static_cast<long>(box_.width() / cell_) + 1;
    ny_ = static_cast<long>(box_.height() / cell_) + 1;
    std::vector<std::uint32_t> count(static_cast<std::size_t>(nx_ * ny_) + 1, 0);
    for (int pass = 0; pass < 2; ++pass) {
      for (std::uint32_t e = 0; e < edges_.size(); ++e) {
        const auto [a, b] = edges_[e];
        const long i0 = index_x(std::min(a.x, b.x) - reach),
                   i1 = index_x(std::max(a.x, b.x) + reach);
        const long j0 = index_y(std::min(a.y, b.y) - reach),
                   j1 = index_y(std::max(a.y, b.y) + reach);
        for (long j = j0; j <= j1; ++j)
          for (long i = i0; i <= i1; ++i) {
            const auto c = static_cast<std::size_t>(j * nx_ + i);
            if (pass == 0)
              ++count[c + 1];
            else
              items_[start_[c] + fill_[c]++] = e;
          }
      }
      if (pass == 0) {
        for (std::size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
        start_ = std::move(count);
        items_.resize(start_.back());
        fill_.assign(start_.size(), 0);
      }
    }
  }

  Vec2 snap(Vec2 p) const {
    if (edges_.empty() || !box_.contains(p)) return p;
    const auto c = static_cast<std::size_t>(index_y(p.y) * nx_ + index_x(p.x));
    double best = reach_;
    Vec2 out = p;
    for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
      const auto [a, b] = edges_[items_[k]];
      double t;
      const double d = distance_to_segment({p.x, p.y, 0}, {a.x, a.y, 0}, {b.x, b.y, 0}, &t);
      if (d <= best) {
        best = d;
        out = a + (b - a) * t;
      }
    }
    return out;
  }

 private:
  long index_x(double x) const {
    return std::clamp(static_cast<long>((x - box_.min.x) / cell_), 0L, nx_ - 1);
  }
  long index_y(double y) const {
    return std::clamp(static_cast<long>((y - box_.min.y) / cell_), 0L, ny_ - 1);
  }

  double reach_;
  std::vector<Segment2> edges_;
  BBox2 box_;
  double cell_ = 1;
  long nx_ = 0, ny_ = 0;
  std::vector<std::uint32_t> start_, fill_, items_;
};

// Clips polylines that reach beyond the region to it, cut ends moved onto the outline, and keeps
// the pieces at least `min_length` long.
void add_clipped(const std::vector<std::vector<Vec2>>& lines, const Regions& region,
                 double min_length, std::vector<std::vector<Vec2>>& out) {
  const OutlineSnap snap(region, 1e-5);
  for (auto& piece : clip_polylines(lines, region)) {
    piece.front() = snap.snap(piece.front());
    piece.back() = snap.snap(piece.back());
    if (polyline_length(piece) >= min_length) out.push_back(std::move(piece));
  }
}

void add_hatch(const Regions& region, double angle, double spacing, double min_length,
               InfillPaths& out) {
  for (const auto& s : hatch(region, angle, spacing))
    if (dist2(s.a, s.b) >= min_length * min_length) out.open.push_back({s.a, s.b});
}

// Length per area of the honeycomb's zig-zags for hexagons of side s and beads of width w:
// per two rows (3s high) and two zig-zags (a column c = √3 s wide), each zig-zag has two vertical
// sides (s) and two slanted ones spanning c/2 − w across (each bead of a shared side sits w/2
// off its centre line) and s/2 up.
double honeycomb_length_per_area(double s, double w) {
  const double c = std::sqrt(3.0) * s;
  return 2 * (2 * s + 2 * std::hypot(c / 2 - w, s / 2)) / (3 * s * c);
}

// The hexagon side whose zig-zags deposit `target` length per area (bisection: the length per
// area falls with s, from 1/w at s = 2w/√3, where the zig-zags become straight lines w apart).
double honeycomb_side(double target, double w) {
  double lo = 2 * w / std::sqrt(3.0), hi = lo;
  while (honeycomb_length_per_area(hi, w) > target) hi *= 2;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (honeycomb_length_per_area(mid, w) > target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Zig-zag j runs up between x = j·c/2 and (j + 1)·c/2 in the honeycomb's frame (pointy-top
// hexagons of side s, one centred on the origin, rows 1.5 s apart): in row r a vertical side of
// length s at whichever of the two is a side there (odd multiples of c/2 in even rows, even ones
// in odd rows), then a slanted side to the next row. Its neighbour on that side shares the
// vertical side; each draws its bead w/2 off the side's centre line, on its own side.
std::vector<std::vector<Vec2>> honeycomb_lines(const BBox2& box, double s, double w, double deg) {
  const double c = std::sqrt(3.0) * s, pitch = 1.5 * s;
  const BBox2 b = turned_box(box, deg);
  const auto j0 = static_cast<long>(std::floor(b.min.x / (c / 2))) - 2;
  const auto j1 = static_cast<long>(std::ceil(b.max.x / (c / 2))) + 1;
  const auto r0 = static_cast<long>(std::floor(b.min.y / pitch)) - 1;
  const auto r1 = static_cast<long>(std::ceil(b.max.y / pitch)) + 1;
  std::vector<std::vector<Vec2>> out;
  for (long j = j0; j <= j1; ++j) {
    std::vector<Vec2> line;
    for (long r = r0; r <= r1; ++r) {
      const long k = ((j + r) % 2 + 2) % 2 == 1 ? j : j + 1;  // k ≡ r + 1 (mod 2)
      const double x = static_cast<double>(k) * c / 2 + (k == j ? w / 2 : -w / 2);
      const double y = static_cast<double>(r) * pitch;
      line.push_back(turn({x, y - s / 2}, deg));
      line.push_back(turn({x, y + s / 2}, deg));
    }
    out.push_back(std::move(line));
  }
  return out;
}

// The gyroid sin X cos Y + sin Y cos Z + sin Z cos X at the plane's height, X, Y, Z = 2π/period
// times the point turned by −deg about the z axis.
class GyroidSection : public PlaneFunction {
 public:
  GyroidSection(double period, double z, double deg)
      : k_(2 * kPi / period),
        sz_(std::sin(k_ * z)),
        cz_(std::cos(k_ * z)),
        c_(std::cos(deg * kPi / 180)),
        s_(std::sin(deg * kPi / 180)) {}

  void sample(const Vec2* points, double* out, std::size_t n) override {
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2 p = points[i];
      const double x = k_ * (c_ * p.x + s_ * p.y), y = k_ * (-s_ * p.x + c_ * p.y);
      out[i] = std::sin(x) * std::cos(y) + std::sin(y) * cz_ + sz_ * std::cos(x);
    }
  }

 private:
  double k_, sz_, cz_, c_, s_;
};

bool inside(const Regions& region, Vec2 p) {
  return std::any_of(region.begin(), region.end(),
                     [&](const Polygon2& poly) { return contains(poly, p, 0); });
}

// A point of the closed curve outside the region (more than a nanometre), inserted into it as
// its first point; false if it has none (it is inside).
bool start_outside(std::vector<Vec2>& loop, const Regions& region) {
  const auto first =
      std::find_if(loop.begin(), loop.end(), [&](Vec2 p) { return !inside(region, p); });
  if (first != loop.end()) {
    std::rotate(loop.begin(), first, loop.end());
    return true;
  }
  // Every vertex inside: a chord may still cut across a corner of the outline.
  auto closed = loop;
  closed.push_back(loop.front());
  for (const auto& piece : clip_polylines({closed}, region, false)) {
    if (polyline_length(piece) <= 1e-6) continue;
    const Vec2 m = (piece.front() + piece.back()) * 0.5;
    std::size_t edge = 0;
    double best = 1e300;
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Vec2 a = loop[i], b = loop[(i + 1) % loop.size()];
      const double d = distance_to_segment({m.x, m.y, 0}, {a.x, a.y, 0}, {b.x, b.y, 0});
      if (d < best) best = d, edge = i;
    }
    loop.insert(loop.begin() + static_cast<std::ptrdiff_t>(edge) + 1, m);
    std::rotate(loop.begin(), loop.begin() + static_cast<std::ptrdiff_t>(edge) + 1, loop.end());
    return true;
  }
  return false;
}

// The gyroid's curves in the region: lines crossing the march's box are clipped; closed curves
// inside are loops, others are opened at a point outside the region before clipping so that
// every cut end lies on the outline.
void gyroid(const Regions& region, const InfillSpec& spec, double z, InfillPaths& out) {
  const double period = 2 * kPi * kGyroidLengthPerArea * spec.bead_width / spec.density;
  out.scale = period;
  GyroidSection f(period, z, spec.angle);
  // 16 cells a period: chords within about 0.4% of the period of the curve (6 µm at 50%), the
  // length 0.1% short of a fine march's; crossings refined to 0.1% of a cell.
  MarchOptions options;
  options.resolution = period / 16;
  options.refine_fraction = 1e-3;
  options.cubic_guess = true;
  BBox2 box = box_of(region);
  const Vec2 margin{options.resolution, options.resolution};
  const auto set = march_squares(f, box.min - margin, box.max + margin, 0, options);
  std::vector<std::vector<Vec2>> lines = set.lines.open;
  for (auto loop : set.lines.loops) {
    if (loop.size() < 3) continue;
    if (!start_outside(loop, region)) {
      if (ring_length(loop) >= spec.min_length) {
        out.loops.push_back(std::move(loop));
        out.loop_level.push_back(0);
      }
      continue;
    }
    loop.push_back(loop.front());
    lines.push_back(std::move(loop));
  }
  add_clipped(lines, region, spec.min_length, out.open);
}

// Each ring region is the previous one's inward offset (the first: the region's, by half a
// spacing), so that the mitred corners of one are a spacing from the next, as round ones would be.
void concentric(const Regions& region, const InfillSpec& spec, InfillPaths& out) {
  const double spacing = spec.bead_width / spec.density;
  out.scale = spacing;
  Regions ring_region = offset(region, -0.5 * spacing);
  for (std::uint32_t level = 0; !ring_region.empty(); ++level) {
    for (auto& ring : rings_of(ring_region))
      if (ring.size() >= 3 && ring_length(ring) >= spec.min_length) {
        out.loops.push_back(std::move(ring));
        out.loop_level.push_back(level);
      }
    ring_region = offset(ring_region, -spacing);
  }
}

// Strut length per area of an atlas pattern at cell size 1 (its length scale; Voronoi aside),
// as make_lattice2d makes it, weighted by the window cos²(πx/2R)·cos²(πy/2R) over |x|, |y| < R:
// a smooth window's estimate converges far faster with R than a crop's, whose partial rows and
// strands on its edges are worth several percent. At R = 6 cells it is within 0.07% of the
// exact values (2/√3 honeycomb, 2(φ+1)/(φ sin 72° + sin 36°) Penrose, 10/(2+√3) snub square,
// 2 square, 3 triangle, ...) for 2-9 ms a call.
double atlas_length_per_unit_cell(AtlasParams p) {
  constexpr double kR = 6;
  p.cell_size = 1;
  p.strand_distance = 0;
  p.cell_height = 0;
  p.rotation_deg = 0;
  p.region = Region{};
  p.region.width = p.region.height = 2 * kR;
  p.crop.clear();
  const Graph g = make_lattice2d(p);
  auto taper = [](double t) {
    const double c = std::cos(kPi * t / (2 * kR));
    return std::abs(t) < kR ? c * c : 0.0;
  };
  auto window = [&](Vec3 q) { return taper(q.x) * taper(q.y); };
  double sum = 0;
  for (const auto& e : g.edges) {
    const Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
    const double len = distance(a, b);
    const int n = std::max(1, static_cast<int>(std::ceil(len / 0.25)));
    for (int i = 0; i < n; ++i) {  // Simpson's rule on n pieces
      const Vec3 p0 = a + (b - a) * (static_cast<double>(i) / n);
      const Vec3 p1 = a + (b - a) * ((i + 0.5) / n), p2 = a + (b - a) * ((i + 1.0) / n);
      sum += len / n / 6 * (window(p0) + 4 * window(p1) + window(p2));
    }
  }
  return sum / (kR * kR);  // the window's integral over the plane is R²
}

void lattice(const Regions& region, const InfillSpec& spec, std::size_t layer, double z,
             InfillPaths& out) {
  AtlasParams p;
  p.pattern = pattern_from_string(spec.lattice);
  const BBox2 box = box_of(region);
  const bool framed = spec.frame.width() > 0 && spec.frame.height() > 0;
  const BBox2 frame = framed ? spec.frame : box;
  if (framed && !(frame.contains(box.min) && frame.contains(box.max)))
    throw SettingError("infill frame must hold the infill region");
  const double target = spec.density / spec.bead_width;  // length per area
  if (p.pattern == Pattern::Voronoi) {
    // Poisson–Voronoi edges have 2√ρ length per area for ρ seeds per area.
    p.voronoi_density = target * target / 4;
    p.cell_size = 1 / std::sqrt(p.voronoi_density);
  } else {
    p.cell_size = atlas_length_per_unit_cell(p) / target;
  }
  out.scale = p.cell_size;
  const double step = spec.lattice_layer_rotation == 0 && p.pattern == Pattern::Lines
                          ? 90
                          : spec.lattice_layer_rotation;
  p.rotation_deg = std::fmod(spec.angle + step * static_cast<double>(layer), 360.0);
  p.seed = spec.seed;
  p.z = z;
  p.region.center = (frame.min + frame.max) * 0.5;
  p.region.width = frame.width();
  p.region.height = frame.height();
  p.crop = region;
  for (const Vec2 q : {box.min, box.max})
    if (!(std::abs(q.x) <= kMaxCoordinate && std::abs(q.y) <= kMaxCoordinate))
      throw GeometryError("infill region beyond ±1 km");
  Graph g;
  try {
    g = make_lattice2d(p);
  } catch (const GeometryError&) {
    return;  // no strut inside the region (coordinates were checked above): nothing to fill
  }
  // The atlas merges nodes closer than min_feature: a cut end that met a node inside is there,
  // up to min_feature from the outline. Strut ends (degree 1) that near go back onto it.
  std::vector<std::uint32_t> degree(g.nodes.size(), 0);
  for (const auto& e : g.edges) ++degree[e.a], ++degree[e.b];
  const OutlineSnap snap(region, p.min_feature);
  for (NodeId n = 0; n < g.nodes.size(); ++n)
    if (degree[n] == 1) {
      const Vec2 q = snap.snap(g.nodes[n].xy());
      g.nodes[n].x = q.x, g.nodes[n].y = q.y;
    }
  const PathSet set = plan_euler(g);
  out.trails = set.trails.size();
  out.trail_lower_bound = lower_bound_paths(g);
  for (const auto& trail : set.trails) {
    std::vector<Vec2> line;
    line.reserve(trail.nodes.size());
    for (const NodeId n : trail.nodes) line.push_back(g.nodes[n].xy());
    out.open.push_back(std::move(line));
  }
}

}  // namespace

const std::vector<std::string>& infill_pattern_names() {
  return kNames;
}

const char* to_string(InfillPattern pattern) {
  return kNames[static_cast<std::size_t>(pattern)].c_str();
}

InfillPattern infill_pattern_from_string(const std::string& name) {
  for (std::size_t i = 0; i < kNames.size(); ++i)
    if (kNames[i] == name) return static_cast<InfillPattern>(i);
  std::string all;
  for (const auto& n : kNames) all += (all.empty() ? "" : ", ") + n;
  throw SettingError("unknown infill pattern '" + name + "' (expected one of: " + all + ")");
}

InfillPaths make_infill(const Regions& region, const InfillSpec& spec, std::size_t layer_index,
                        double z) {
  if (!(spec.density > 0 && spec.density <= 1))
    throw SettingError("infill density must be within (0, 1]");
  if (!(spec.bead_width > 0 && std::isfinite(spec.bead_width)))
    throw SettingError("bead width must be > 0 mm");
  if (!std::isfinite(spec.angle) || !std::isfinite(spec.lattice_layer_rotation))
    throw SettingError("infill angles must be finite");
  if (!(spec.min_length >= 0)) throw SettingError("infill minimum length must be >= 0 mm");
  InfillPaths out;
  if (spec.pattern == InfillPattern::Lattice) pattern_from_string(spec.lattice);  // name check
  if (region.empty() || area(region) <= 0) return out;
  const double w = spec.bead_width, d = spec.density;
  const double odd = layer_index % 2 == 1 ? 90 : 0;
  switch (spec.pattern) {
    case InfillPattern::Rectilinear:
      out.scale = w / d;
      add_hatch(region, spec.angle + odd, out.scale, spec.min_length, out);
      break;
    case InfillPattern::Grid:
      out.scale = 2 * w / d;
      for (const double a : {0.0, 90.0})
        add_hatch(region, spec.angle + a, out.scale, spec.min_length, out);
      break;
    case InfillPattern::Triangles:
      out.scale = 3 * w / d;
      for (const double a : {0.0, 60.0, 120.0})
        add_hatch(region, spec.angle + a, out.scale, spec.min_length, out);
      break;
    case InfillPattern::Honeycomb: {
      out.scale = honeycomb_side(d / w, w);
      const double deg = spec.angle + 60.0 * static_cast<double>(layer_index % 3);
      add_clipped(honeycomb_lines(box_of(region), out.scale, w, deg), region, spec.min_length,
                  out.open);
      break;
    }
    case InfillPattern::Gyroid:
      gyroid(region, spec, z, out);
      break;
    case InfillPattern::Concentric:
      concentric(region, spec, out);
      break;
    case InfillPattern::Lattice:
      lattice(region, spec, layer_index, z, out);
      break;
  }
  return out;
}

}  // namespace trellis
