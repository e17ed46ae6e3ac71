#include "trellis/lattice/atlas.hpp"

#include <cmath>
#include <map>
#include <numbers>
#include <unordered_map>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

constexpr double kPi = std::numbers::pi;
const double kSqrt3 = std::sqrt(3.0);

const std::vector<std::string> kPatternNames = {"honeycomb",   "voronoi",   "penrose",
                                                "snub-square", "arrowhead", "reentrant-honeycomb",
                                                "square",      "triangle",  "lines"};

// Connects every pair of points exactly `len` apart (within 1e-6 relative); points are first
// deduplicated at 1e-9 mm. Used for tilings whose edges are exactly their nearest neighbours.
std::vector<Segment2> connect_at_distance(const std::vector<Vec2>& raw, double len) {
  std::map<std::pair<long long, long long>, Vec2> unique;
  for (auto p : raw)
    unique.emplace(std::make_pair(std::llround(p.x * 1e9), std::llround(p.y * 1e9)), p);
  std::vector<Vec2> pts;
  for (auto& [k, p] : unique) pts.push_back(p);
  // Cells slightly larger than `len`, so two points `len` apart are always in adjacent cells.
  const double cell_size = len * 1.01;
  std::unordered_map<long long, std::vector<std::size_t>> grid;
  auto key = [&](long long i, long long j) { return i * 1000003LL + j; };
  auto cell = [&](Vec2 p) {
    return std::make_pair(static_cast<long long>(std::floor(p.x / cell_size)),
                          static_cast<long long>(std::floor(p.y / cell_size)));
  };
  for (std::size_t i = 0; i < pts.size(); ++i) {
    auto [cx, cy] = cell(pts[i]);
    grid[key(cx, cy)].push_back(i);
  }
  std::vector<Segment2> out;
  const double tol = len * 1e-6;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    auto [cx, cy] = cell(pts[i]);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy) {
        auto it = grid.find(key(cx + dx, cy + dy));
        if (it == grid.end()) continue;
        for (std::size_t j : it->second)
          if (j > i && std::abs(std::hypot(pts[i].x - pts[j].x, pts[i].y - pts[j].y) - len) <= tol)
            out.push_back({pts[i], pts[j]});
      }
  }
  return out;
}

// Points i*a + j*b + basis covering [-half, half]² (with one cell of margin).
std::vector<Vec2> lattice_points(Vec2 a, Vec2 b, const std::vector<Vec2>& basis, double half) {
  std::vector<Vec2> out;
  const int nj = static_cast<int>(std::ceil(half / std::abs(b.y))) + 2;
  for (int j = -nj; j <= nj; ++j) {
    const double x0 = j * b.x;
    const int i0 = static_cast<int>(std::floor((-half - x0) / a.x)) - 2;
    const int i1 = static_cast<int>(std::ceil((half - x0) / a.x)) + 2;
    for (int i = i0; i <= i1; ++i)
      for (auto o : basis) out.push_back(Vec2{i * a.x + j * b.x, i * a.y + j * b.y} + o);
  }
  return out;
}

std::vector<Segment2> honeycomb(double r, double half) {
  return connect_at_distance(
      lattice_points({kSqrt3 * r, 0}, {kSqrt3 * r / 2, 1.5 * r}, {{0, r}, {0, -r}}, half), r);
}

std::vector<Segment2> triangle(double strand, double half) {
  const double len = 2 * strand / kSqrt3;
  return connect_at_distance(lattice_points({len, 0}, {len / 2, strand}, {{0, 0}}, half), len);
}

std::vector<Segment2> square(double s, double half) {
  return connect_at_distance(lattice_points({s, 0}, {0, s}, {{0, 0}}, half), s);
}

std::vector<Segment2> lines(double s, double half) {
  std::vector<Segment2> out;
  const int n = static_cast<int>(std::ceil(half / s));
  for (int j = -n; j <= n; ++j) out.push_back({{-half, j * s}, {half, j * s}});
  return out;
}

std::vector<Segment2> snub_square(double s, double half) {
  // Squares of side s centred on a square lattice of period L, alternately rotated by ±15°;
  // each vertex is shared by two squares, triangles fill the rest.
  const double L = s * (1 + kSqrt3) / std::sqrt(2.0);
  const double r = s / std::sqrt(2.0);
  std::vector<Vec2> verts;
  const int n = static_cast<int>(std::ceil(half / L)) + 2;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = 0; k < 2; ++k) {
        const Vec2 c{(i + 0.5 * k) * L, (j + 0.5 * k) * L};
        const double rot = (k == 0 ? 15.0 : -15.0) * kPi / 180;
        for (int q = 0; q < 4; ++q) {
          const double t = rot + kPi / 4 + q * kPi / 2;
          verts.push_back({c.x + r * std::cos(t), c.y + r * std::sin(t)});
        }
      }
  return connect_at_distance(verts, s);
}

std::vector<Segment2> penrose(double side, double half) {
  // Robinson-triangle deflation (P3 rhombi): a wheel of 10 triangles of radius R, subdivided
  // until the rhombus side is `side`. Each triangle (kind, A, B, C) contributes edges C-A, A-B.
  struct Tri {
    int kind;
    Vec2 a, b, c;
  };
  const double phi = (1 + std::sqrt(5.0)) / 2;
  const int n =
      std::max(0, static_cast<int>(std::ceil(std::log(half * 1.5 / side) / std::log(phi))));
  const double R = side * std::pow(phi, n);
  std::vector<Tri> tris;
  for (int i = 0; i < 10; ++i) {
    Vec2 b{R * std::cos((2 * i - 1) * kPi / 10), R * std::sin((2 * i - 1) * kPi / 10)};
    Vec2 c{R * std::cos((2 * i + 1) * kPi / 10), R * std::sin((2 * i + 1) * kPi / 10)};
    if (i % 2 == 0) std::swap(b, c);
    tris.push_back({0, {0, 0}, b, c});
  }
  for (int it = 0; it < n; ++it) {
    std::vector<Tri> next;
    next.reserve(tris.size() * 3);
    for (const auto& t : tris) {
      if (t.kind == 0) {
        const Vec2 p = t.a + (t.b - t.a) * (1 / phi);
        next.push_back({0, t.c, p, t.b});
        next.push_back({1, p, t.c, t.a});
      } else {
        const Vec2 q = t.b + (t.a - t.b) * (1 / phi);
        const Vec2 r = t.b + (t.c - t.b) * (1 / phi);
        next.push_back({1, r, t.c, t.a});
        next.push_back({1, q, r, t.b});
        next.push_back({0, r, q, t.a});
      }
    }
    tris = std::move(next);
  }
  std::vector<Segment2> out;
  auto inside = [&](Vec2 p) { return std::abs(p.x) <= half * 1.2 && std::abs(p.y) <= half * 1.2; };
  for (const auto& t : tris) {
    if (!inside(t.a) && !inside(t.b) && !inside(t.c)) continue;
    out.push_back({t.c, t.a});
    out.push_back({t.a, t.b});
  }
  return out;
}

std::vector<Segment2> arrowhead(double w, double outer_deg, double inner_deg, double half) {
  // Darts between an outer chevron (apex a1) and an inner chevron (apex a2) on the same tips;
  // the next dart up starts where the outer apex is, so P = a1 - a2.
  const double a1 = w / 2 * std::tan(outer_deg * kPi / 180);
  const double a2 = w / 2 * std::tan(inner_deg * kPi / 180);
  const double p = a1 - a2;
  std::vector<Segment2> out;
  const int nk = static_cast<int>(std::ceil(half / w)) + 1;
  const int nm = static_cast<int>(std::ceil((half + a1) / p)) + 1;
  for (int k = -nk; k <= nk; ++k)
    for (int m = -nm; m <= nm; ++m) {
      const Vec2 l{k * w, m * p}, r{(k + 1) * w, m * p};
      const Vec2 o{k * w + w / 2, m * p + a1}, i{k * w + w / 2, m * p + a2};
      out.push_back({l, o});
      out.push_back({o, r});
      out.push_back({l, i});
      out.push_back({i, r});
    }
  return out;
}

std::vector<Segment2> reentrant(double w, double angle_deg, double rib, double half) {
  // Zigzag lines k with points j at x = jW/2; low points ((j+k) even) at y = k(h-a), high points
  // at y = k(h-a)+a; vertical struts of length h (the rib) from each low point to the line above.
  // The unit cell (two zigzag lines) is W wide and 2(h - a) high.
  const double h = rib;
  const double a = w / 2 * std::tan(angle_deg * kPi / 180);
  const double pitch = h - a;
  auto point = [&](int j, int k) {
    const bool low = ((j + k) % 2 + 2) % 2 == 0;
    return Vec2{j * w / 2, k * pitch + (low ? 0 : a)};
  };
  std::vector<Segment2> out;
  const int nj = static_cast<int>(std::ceil(2 * half / w)) + 2;
  const int nk = static_cast<int>(std::ceil(half / pitch)) + 2;
  for (int k = -nk; k <= nk; ++k)
    for (int j = -nj; j <= nj; ++j) {
      out.push_back({point(j, k), point(j + 1, k)});
      if (((j + k) % 2 + 2) % 2 == 0) out.push_back({point(j, k), point(j, k + 1)});
    }
  return out;
}

// The arrowhead's unit cell is W wide and a1 - a2 high (outer minus inner apex height).
double arrowhead_inner(const AtlasParams& p) {
  if (p.cell_height <= 0) return p.arrowhead_inner_deg;
  const double a1 = p.cell_size / 2 * std::tan(p.arrowhead_outer_deg * kPi / 180);
  return std::atan((a1 - p.cell_height) / (p.cell_size / 2)) * 180 / kPi;
}

double reentrant_rib(const AtlasParams& p) {
  const double a = p.cell_size / 2 * std::tan(p.reentrant_angle_deg * kPi / 180);
  return p.cell_height > 0 ? p.cell_height / 2 + a : p.cell_size;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw SettingError(what);
}

double circumradius(const Region& r) {
  return r.shape == RegionShape::Circle ? r.diameter / 2 : std::hypot(r.width, r.height) / 2;
}

// Handle rectangles at the -x and +x ends of a rectangular region.
std::vector<Polygon2> handle_rects(const AtlasParams& p) {
  const Region& r = p.region;
  const double y0 = r.center.y;
  const double xl = r.center.x - r.width / 2, xr = r.center.x + r.width / 2;
  return {make_rectangle({xl - p.handle_length / 2, y0}, p.handle_length, p.handle_width),
          make_rectangle({xr + p.handle_length / 2, y0}, p.handle_length, p.handle_width)};
}

double boundary_distance(const Polygon2& poly, Vec2 p) {
  double best = 1e300;
  auto ring_d = [&](const std::vector<Vec2>& ring) {
    for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
      best = std::min(best, distance_to_segment({p.x, p.y, 0}, {ring[j].x, ring[j].y, 0},
                                                {ring[i].x, ring[i].y, 0}));
  };
  ring_d(poly.outer);
  for (const auto& h : poly.holes) ring_d(h);
  return best;
}

void add_ring_segments(const std::vector<Vec2>& ring, std::vector<Segment2>& out) {
  for (std::size_t i = 0; i < ring.size(); ++i)
    out.push_back({ring[i], ring[(i + 1) % ring.size()]});
}

// Adds the outline of `poly` as struts, with a node at every strut end lying on it.
void add_outline(const Polygon2& poly, std::vector<Segment2>& segs) {
  std::vector<Vec2> on;
  for (const auto& s : segs)
    for (Vec2 q : {s.a, s.b})
      if (boundary_distance(poly, q) <= 1e-6) on.push_back(q);
  for (const auto& ring : rings_with_points(poly, on, 1e-6)) add_ring_segments(ring, segs);
}

}  // namespace

const std::vector<std::string>& pattern_names() {
  return kPatternNames;
}

std::string to_string(Pattern p) {
  return kPatternNames[static_cast<int>(p)];
}

Pattern pattern_from_string(const std::string& name) {
  for (std::size_t i = 0; i < kPatternNames.size(); ++i)
    if (kPatternNames[i] == name) return static_cast<Pattern>(i);
  std::string all;
  for (const auto& n : kPatternNames) all += (all.empty() ? "" : ", ") + n;
  throw SettingError("unknown pattern '" + name + "' (expected one of: " + all + ")");
}

Vec2 corner_at_origin(const AtlasParams& p) {
  const Region& r = p.region;
  if (r.shape == RegionShape::Circle) return {r.diameter / 2, r.diameter / 2};
  const double hx = r.width / 2 + (p.handles ? p.handle_length : 0);
  const double hy = std::max(r.height, p.handles ? p.handle_width : 0.0) / 2;
  return {hx, hy};
}

namespace {

// The region shrunk by d on every side (same centre).
Region inset_region(Region r, double d) {
  r.diameter -= 2 * d;
  r.width -= 2 * d;
  r.height -= 2 * d;
  return r;
}

}  // namespace

Polygon2 Region::polygon() const {
  return shape == RegionShape::Circle ? make_circle(center, diameter)
                                      : make_rectangle(center, width, height);
}

std::vector<Segment2> pattern_segments(const AtlasParams& p, double half) {
  const double strand = p.strand_distance > 0 ? p.strand_distance : p.cell_size;
  switch (p.pattern) {
    case Pattern::Honeycomb:
      return honeycomb(p.cell_size, half);
    case Pattern::Voronoi:
      return voronoi_segments(half, p.voronoi_density, p.seed);
    case Pattern::Penrose:
      return penrose(p.cell_size, half);
    case Pattern::SnubSquare:
      return snub_square(p.cell_size, half);
    case Pattern::Arrowhead:
      return arrowhead(p.cell_size, p.arrowhead_outer_deg, arrowhead_inner(p), half);
    case Pattern::ReentrantHoneycomb:
      return reentrant(p.cell_size, p.reentrant_angle_deg, reentrant_rib(p), half);
    case Pattern::Square:
      return square(strand, half);
    case Pattern::Triangle:
      return triangle(strand, half);
    case Pattern::Lines:
      return lines(strand, half);
  }
  return {};
}

Graph make_lattice2d(const AtlasParams& p) {
  const Region& r = p.region;
  require(std::isfinite(p.cell_size) && p.cell_size > 0, "cell size must be > 0 mm");
  require(p.strand_distance >= 0, "strand distance must be >= 0 mm");
  require(std::isfinite(p.rotation_deg), "rotation must be a finite angle");
  require(r.shape == RegionShape::Circle ? r.diameter > 0 : (r.width > 0 && r.height > 0),
          "region size must be > 0 mm");
  const double radius = circumradius(r);
  const double strand = p.strand_distance > 0 ? p.strand_distance : p.cell_size;
  const double scale = p.pattern == Pattern::Voronoi ? 1 / std::sqrt(p.voronoi_density)
                                                     : std::min(p.cell_size, strand);
  require(p.voronoi_density > 0, "Voronoi density must be > 0 seeds per mm²");
  require(p.min_feature > 0 && p.min_feature < scale / 4,
          "min feature must be > 0 and well below the cell size");
  require(radius / scale <= 2000,
          "region is more than 2000 cells across: increase the cell size or shrink the region");
  require(p.reentrant_angle_deg > 0 && p.reentrant_angle_deg < 45,
          "re-entrant angle must be in (0, 45) degrees (struts would cross)");
  require(p.arrowhead_inner_deg > 0 && p.arrowhead_outer_deg > p.arrowhead_inner_deg &&
              p.arrowhead_outer_deg < 85,
          "arrowhead angles need 0 < inner < outer < 85 degrees");
  require(std::isfinite(p.cell_height) && p.cell_height >= 0, "cell height must be >= 0 mm");
  if (p.pattern == Pattern::Arrowhead && p.cell_height > 0) {
    const double a1 = p.cell_size / 2 * std::tan(p.arrowhead_outer_deg * kPi / 180);
    require(p.cell_height < a1,
            "arrowhead: the cell height must be below the outer chevron's height, " +
                std::to_string(a1) +
                " mm for this cell and outer angle (the inner angle would "
                "be <= 0)");
  }
  require(!p.handles || r.shape == RegionShape::Rectangle, "handles need a rectangular region");
  require(p.rings >= 0 && (p.rings == 0 || p.ring_spacing > 0), "rings need a spacing > 0 mm");
  require(p.rings == 0 || p.crop.empty(),
          "rings follow the region's outline: they do not apply to layers cropped to a solid");
  require(p.rings == 0 ||
              2 * (p.rings - 1) * p.ring_spacing <
                  (r.shape == RegionShape::Circle ? r.diameter : std::min(r.width, r.height)),
          "the rings fill the whole region: fewer rings or a smaller spacing");
  require(!p.handles || (p.handle_length > 0 && p.handle_width > 0 && p.handle_spacing > 0),
          "handle length, width and spacing must be > 0 mm");

  // Generate over a square of half-side 1.5 x the region's circumradius: > twice its area.
  const double half = radius * 1.5;
  auto segs = pattern_segments(p, half);
  const double t = p.rotation_deg * kPi / 180, c = std::cos(t), s = std::sin(t);
  for (auto& seg : segs)
    for (Vec2* q : {&seg.a, &seg.b})
      *q = {r.center.x + c * q->x - s * q->y, r.center.y + s * q->x + c * q->y};
  if (p.crop.empty() && p.rings > 0) {
    segs = clip_segments(segs, inset_region(r, (p.rings - 1) * p.ring_spacing).polygon());
    for (int k = p.rings - 1; k >= 0; --k)
      add_outline(inset_region(r, k * p.ring_spacing).polygon(), segs);
  } else if (p.crop.empty()) {
    const Polygon2 region = r.polygon();
    segs = clip_segments(segs, region);
    if (p.contour) add_outline(region, segs);
  } else {
    std::vector<Segment2> kept;
    for (const auto& poly : p.crop) {
      auto part = clip_segments(segs, poly);
      kept.insert(kept.end(), part.begin(), part.end());
      if (p.contour) add_outline(poly, kept);
    }
    segs = std::move(kept);
  }
  if (p.handles)
    for (const auto& h : handle_rects(p)) {
      const double x0 = h.outer[0].x, x1 = h.outer[1].x, y0 = h.outer[0].y, y1 = h.outer[2].y;
      for (double y = y0 + p.handle_spacing; y < y1 - 1e-9; y += p.handle_spacing)
        segs.push_back({{x0, y}, {x1, y}});
      add_outline(h, segs);
    }
  Graph raw;
  for (const auto& seg : segs) {
    const auto n = static_cast<NodeId>(raw.nodes.size());
    raw.nodes.push_back({seg.a.x, seg.a.y, p.z});
    raw.nodes.push_back({seg.b.x, seg.b.y, p.z});
    raw.edges.push_back({n, n + 1});
  }
  Diagnostics internal;  // duplicates from generation are expected, not the user's concern
  Graph g = clean_graph(raw, {p.min_feature, true}, internal);
  // Drop nodes without edges so node ids are compact.
  std::vector<NodeId> map(g.nodes.size(), UINT32_MAX);
  Graph out;
  for (auto& e : g.edges)
    for (NodeId* n : {&e.a, &e.b}) {
      if (map[*n] == UINT32_MAX) {
        map[*n] = static_cast<NodeId>(out.nodes.size());
        out.nodes.push_back(g.nodes[*n]);
      }
      *n = map[*n];
    }
  out.edges = std::move(g.edges);
  if (out.edges.empty()) throw GeometryError("the pattern has no strut inside the region");
  return out;
}

}  // namespace trellis
