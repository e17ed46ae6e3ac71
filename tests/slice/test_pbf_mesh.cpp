// Solid parts scanned for laser powder-bed fusion (issue 44 items 1, 2, 5): generated brackets
// and star-shaped tapered prisms (whose every section is known exactly, without the slicer) and
// meshes from tests/data, planned with each scan strategy, written to CLI and read back, then
// checked with the test's own geometry: every hatch vector at least the beam compensation (and
// the contours' band) inside the section, islands tiling the section with the set overlap and no
// gap (samples of the eroded section within half a hatch distance of a hatch line of their
// island's direction), and the strategies' own shapes (island vectors within an island, stripes
// within a stripe, meander back and forth, rectilinear one way).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/slice/pbf_mesh.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTol = 1e-3;  // mm: 1 µm
// mm: a vector's ends may move this far off its line, written to CLI to 10 nm.
constexpr double kRound = 3e-5;

// A star-shaped polygon (every vertex seen from `centre`) extruded to `height`, scaled about the
// centre from 1 at the bottom to `taper` at the top: its sides are planar trapezoids, so the
// section at z is the polygon scaled by 1 + (taper − 1)·z/height, exactly.
struct Prism {
  std::vector<Vec2> ring;  // counter-clockwise
  Vec2 centre;
  double height = 1, taper = 1;

  Regions section(double z) const {
    const double s = 1 + (taper - 1) * z / height;
    Polygon2 p;
    for (Vec2 q : ring) p.outer.push_back(centre + (q - centre) * s);
    return {p};
  }
  TriangleMesh mesh() const {
    TriangleMesh m;
    const auto n = static_cast<std::uint32_t>(ring.size());
    for (Vec2 q : ring) m.vertices.push_back({q.x, q.y, 0});
    for (Vec2 q : ring) {
      const Vec2 t = centre + (q - centre) * taper;
      m.vertices.push_back({t.x, t.y, height});
    }
    m.vertices.push_back({centre.x, centre.y, 0});
    m.vertices.push_back({centre.x, centre.y, height});
    const std::uint32_t cb = 2 * n, ct = 2 * n + 1;
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t j = (i + 1) % n;
      m.triangles.push_back({cb, j, i});
      m.triangles.push_back({ct, n + i, n + j});
      m.triangles.push_back({i, j, n + j});
      m.triangles.push_back({i, n + j, n + i});
    }
    return m;
  }
};

Vec2 turn(Vec2 p, double a) {
  return {p.x * std::cos(a) - p.y * std::sin(a), p.x * std::sin(a) + p.y * std::cos(a)};
}

// An L bracket with arms `arm` mm long and `t` thick, turned and moved.
Prism bracket(double arm, double t, double angle, Vec2 at, double height, double taper = 1) {
  Prism p;
  for (Vec2 q : std::vector<Vec2>{{0, 0}, {arm, 0}, {arm, t}, {t, t}, {t, arm}, {0, arm}})
    p.ring.push_back(turn(q, angle) + at);
  p.centre = turn({t / 2, t / 2}, angle) + at;
  p.height = height;
  p.taper = taper;
  return p;
}

Prism random_star(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  Prism p;
  const int n = 5 + static_cast<int>(u(rng) * 8);
  const double r = 3 + 5 * u(rng);
  p.centre = {20 * u(rng) - 10, 20 * u(rng) - 10};
  for (int k = 0; k < n; ++k) {
    const double a = 2 * kPi * (k + 0.4 * u(rng)) / n;
    const double rk = r * (0.45 + 0.55 * u(rng));
    p.ring.push_back(p.centre + Vec2{rk * std::cos(a), rk * std::sin(a)});
  }
  p.height = 0.5 + u(rng);
  p.taper = 0.8 + 0.4 * u(rng);
  return p;
}

// ---- the test's own geometry

double point_segment(Vec2 p, Vec2 a, Vec2 b) {
  const Vec2 ab = b - a, ap = p - a;
  const double l2 = ab.x * ab.x + ab.y * ab.y;
  const double t = l2 > 0 ? std::clamp((ap.x * ab.x + ap.y * ab.y) / l2, 0.0, 1.0) : 0.0;
  return std::sqrt(dist2(p, a + ab * t));
}

bool crosses(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  const auto side = [](Vec2 o, Vec2 p, Vec2 q) {
    return (p.x - o.x) * (q.y - o.y) - (p.y - o.y) * (q.x - o.x);
  };
  return side(a, b, c) * side(a, b, d) < 0 && side(c, d, a) * side(c, d, b) < 0;
}

struct Edges {
  std::vector<std::pair<Vec2, Vec2>> e;
  explicit Edges(const Regions& r) {
    for (const auto& ring : rings_of(r))
      for (std::size_t i = 0; i < ring.size(); ++i)
        e.push_back({ring[i], ring[(i + 1) % ring.size()]});
  }
  bool inside(Vec2 p) const {  // even-odd
    bool in = false;
    for (const auto& [a, b] : e)
      if ((a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y))
        in = !in;
    return in;
  }
  double distance(Vec2 p) const {
    double d = HUGE_VAL;
    for (const auto& [a, b] : e) d = std::min(d, point_segment(p, a, b));
    return d;
  }
  // Distance from a segment to the outline; 0 when it crosses it.
  double distance(Vec2 p, Vec2 q) const {
    double d = HUGE_VAL;
    for (const auto& [a, b] : e) {
      if (crosses(p, q, a, b)) return 0;
      d = std::min({d, point_segment(p, a, b), point_segment(q, a, b), point_segment(a, p, q),
                    point_segment(b, p, q)});
    }
    return d;
  }
};

struct ScanSettings {
  ScanStrategy strategy = ScanStrategy::Island;
  double layer = 0.1, hatch = 0.08, bc = 0.05, contour_distance = 0.06;
  int contours = 1;
  double island = 2, island_overlap = 0.12, island_shift = 0.7;
  double stripe = 3, stripe_overlap = 0.1;
  double rotation = 67;
  double inset() const { return bc + contours * contour_distance; }
};

PbfSolidOptions options_of(const ScanSettings& s) {
  PbfSolidOptions o;
  o.layer = s.layer;
  o.beam_compensation = s.bc;
  o.contours = s.contours;
  o.contour_distance = s.contour_distance;
  o.pattern.strategy = s.strategy;
  o.pattern.hatch_distance = s.hatch;
  o.pattern.rotation = s.rotation;
  o.pattern.island_size = s.island;
  o.pattern.island_overlap = s.island_overlap;
  o.pattern.island_shift = s.island_shift;
  o.pattern.stripe_width = s.stripe;
  o.pattern.stripe_overlap = s.stripe_overlap;
  return o;
}

// The part planned and streamed into a CLI file, read back.
Toolpath cli_of(const TriangleMesh& mesh, const ScanSettings& s, const std::string& name) {
  const test::TempDir dir("trellis_test_pbf_mesh");
  const std::string path = dir.file(name + ".cli");
  LaserProfile prof;
  prof.layer = s.layer;
  PbfSolid part;
  part.mesh = &mesh;
  {
    CliStreamWriter w(path, prof, {}, "test", "");
    plan_pbf_solid(part, options_of(s), [&](std::size_t i, const PbfLayer& L) {
      w.add(pbf_layer_toolpath(L, i, s.layer, 60, 800, 100, 1000));
    });
    w.finish();
  }
  return read_cli_file(path);
}

struct Vector {
  Vec2 a, b;
  double length() const { return std::sqrt(dist2(a, b)); }
};

struct LayerScan {
  std::vector<std::vector<Vec2>> contours;
  std::vector<Vector> hatches;
};

LayerScan scan_of(const Layer& layer) {
  LayerScan out;
  for (const Path& p : layer.paths) {
    std::vector<Vec2> pts;
    for (const Vec3& q : p.points) pts.push_back({q.x, q.y});
    if (p.role == PathRole::Contour)
      out.contours.push_back(pts);
    else
      out.hatches.push_back({pts.front(), pts.back()});
  }
  return out;
}

// Hatch vectors near a point: a bucket grid of `cell` mm.
class VectorIndex {
 public:
  VectorIndex(const std::vector<Vector>& v, double cell) : v_(v), cell_(cell) {
    for (std::size_t k = 0; k < v.size(); ++k) {
      const long x0 = key(std::min(v[k].a.x, v[k].b.x)), x1 = key(std::max(v[k].a.x, v[k].b.x));
      const long y0 = key(std::min(v[k].a.y, v[k].b.y)), y1 = key(std::max(v[k].a.y, v[k].b.y));
      for (long x = x0; x <= x1; ++x)
        for (long y = y0; y <= y1; ++y) cells_[{x, y}].push_back(k);
    }
  }
  // Nearest distance from p to a vector accepted by `keep` (r <= cell).
  template <class Keep>
  double nearest(Vec2 p, Keep keep) const {
    double d = HUGE_VAL;
    for (long x = key(p.x) - 1; x <= key(p.x) + 1; ++x)
      for (long y = key(p.y) - 1; y <= key(p.y) + 1; ++y) {
        const auto it = cells_.find({x, y});
        if (it == cells_.end()) continue;
        for (std::size_t k : it->second)
          if (keep(v_[k])) d = std::min(d, point_segment(p, v_[k].a, v_[k].b));
      }
    return d;
  }

 private:
  long key(double x) const { return static_cast<long>(std::floor(x / cell_)); }
  const std::vector<Vector>& v_;
  double cell_;
  std::map<std::pair<long, long>, std::vector<std::size_t>> cells_;
};

// The layer's hatch frame, from the settings (not from the planner).
struct Frame {
  Vec2 d, n;
  double shift = 0;
  Frame(const ScanSettings& s, std::size_t layer) {
    const double a = std::fmod(s.rotation * static_cast<double>(layer), 360.0) * kPi / 180;
    d = {std::cos(a), std::sin(a)};
    n = {-d.y, d.x};
    shift = std::fmod(s.island_shift * static_cast<double>(layer), s.island);
  }
  bool along_d(const Vector& v) const {
    const Vec2 w = v.b - v.a;
    return std::abs(w.x * n.x + w.y * n.y) < kRound;
  }
  bool along_n(const Vector& v) const {
    const Vec2 w = v.b - v.a;
    return std::abs(w.x * d.x + w.y * d.y) < kRound;
  }
};

struct Counts {
  std::size_t layers = 0, hatches = 0, samples = 0, overlap_samples = 0;
};

// Every check of one layer against its exact section.
void check_layer(const Regions& section, const LayerScan& scan, const ScanSettings& s,
                 std::size_t layer, double sample_step, Counts& counts, const std::string& what) {
  const Edges edges(section);
  const Frame f(s, layer);
  const double inset = s.inset();
  SCOPED_TRACE(what + " layer " + std::to_string(layer));
  if (area(offset(section, -inset - s.hatch)) > 1) {
    EXPECT_FALSE(scan.hatches.empty());
    EXPECT_GE(scan.contours.size(), static_cast<std::size_t>(s.contours));
  }
  ++counts.layers;
  counts.hatches += scan.hatches.size();
  for (const auto& c : scan.contours)
    for (Vec2 p : c) {
      ASSERT_TRUE(edges.inside(p));
      const double dist = edges.distance(p);
      ASSERT_GE(dist, s.bc - kTol);
      // Offsets are mitred up to twice their distance at the section's concave corners.
      ASSERT_LE(dist, 2 * (s.bc + (s.contours - 1) * s.contour_distance) + kTol);
    }
  const double island_bound = (s.island + s.island_overlap) * std::sqrt(2.0);
  for (const Vector& v : scan.hatches) {
    ASSERT_TRUE(edges.inside(v.a) && edges.inside(v.b));
    // At least the beam compensation (and the contours' band) inside, along the whole vector.
    ASSERT_GE(edges.distance(v.a, v.b), inset - kTol) << v.a.x << "," << v.a.y;
    const double side = v.b.x * f.d.x + v.b.y * f.d.y - (v.a.x * f.d.x + v.a.y * f.d.y);
    const long line = std::lround((v.a.x * f.n.x + v.a.y * f.n.y) / s.hatch);
    switch (s.strategy) {
      case ScanStrategy::Island:
        ASSERT_TRUE(f.along_d(v) || f.along_n(v));
        ASSERT_LE(v.length(), island_bound + kTol);
        ASSERT_LE(v.length(), s.island + s.island_overlap + kTol);  // along an island's side
        break;
      case ScanStrategy::Stripe:
        ASSERT_TRUE(f.along_d(v));
        ASSERT_LE(v.length(), s.stripe + s.stripe_overlap + kTol);
        break;
      case ScanStrategy::Rectilinear:
        ASSERT_TRUE(f.along_d(v));
        ASSERT_GT(side, 0);
        break;
      case ScanStrategy::Meander:
        ASSERT_TRUE(f.along_d(v));
        ASSERT_EQ(side > 0, line % 2 == 0) << "meander lines alternate";
        break;
    }
  }
  // Coverage: samples of the section eroded by the inset plus a hatch distance (where lines run
  // whole) lie within half a hatch distance of a line of their island's direction; in the
  // overlap band between islands, of both directions; deeper in, only of their own.
  const VectorIndex index(scan.hatches, std::max(0.5, s.hatch));
  BBox2 box{{HUGE_VAL, HUGE_VAL}, {-HUGE_VAL, -HUGE_VAL}};
  for (const auto& [a, b] : edges.e) {
    box.min = {std::min(box.min.x, a.x), std::min(box.min.y, a.y)};
    box.max = {std::max(box.max.x, a.x), std::max(box.max.y, a.y)};
  }
  const double half = s.hatch / 2 + kTol;
  for (double y = box.min.y; y <= box.max.y; y += sample_step)
    for (double x = box.min.x; x <= box.max.x; x += sample_step) {
      const Vec2 p{x, y};
      if (!edges.inside(p) || edges.distance(p) < inset + s.hatch + kTol) continue;
      ++counts.samples;
      const double dd = index.nearest(p, [&](const Vector& v) { return f.along_d(v); });
      if (s.strategy != ScanStrategy::Island) {
        ASSERT_LE(dd, half) << "gap at " << x << "," << y;
        continue;
      }
      const double dn = index.nearest(p, [&](const Vector& v) { return f.along_n(v); });
      const double u = p.x * f.d.x + p.y * f.d.y - f.shift, w = p.x * f.n.x + p.y * f.n.y - f.shift;
      const double i = std::floor(u / s.island), j = std::floor(w / s.island);
      const bool odd = static_cast<long>(i + j) % 2 != 0;
      ASSERT_LE(odd ? dn : dd, half)
          << "gap in island " << i << "," << j << " at " << x << "," << y;
      // Across a boundary between columns (constant u) the neighbour's lines run across it
      // when the neighbour is even (along d), across one between rows when it is odd: they
      // reach the set overlap past it, exactly. Lines along a boundary stop at the last line
      // within the overlap; deeper than the overlap and half a line no other line reaches.
      const double du = std::min(u - i * s.island, (i + 1) * s.island - u);
      const double dw = std::min(w - j * s.island, (j + 1) * s.island - w);
      const double inner = s.island_overlap / 2 - 0.01;
      const bool across = (du < inner && odd) || (dw < inner && !odd);
      if (across) {
        ++counts.overlap_samples;
        ASSERT_LE(odd ? dd : dn, half) << "overlap missing at " << x << "," << y;
      } else if (std::min(du, dw) > s.island_overlap / 2 + s.hatch / 2 + 0.01) {
        ASSERT_GT(odd ? dd : dn, s.hatch / 2) << "overlap too wide at " << x << "," << y;
      }
    }
}

// The CLI's layer i is cut at (i + 0.5)·layer above the part's bottom (z = 0 here).
void check_part(const Prism& part, const ScanSettings& s, const std::string& name, Counts& counts,
                std::size_t every = 1, double sample_step = 0.05) {
  const Toolpath tp = cli_of(part.mesh(), s, name);
  ASSERT_EQ(tp.layers.size(), static_cast<std::size_t>(std::ceil(part.height / s.layer - 1e-6)));
  for (std::size_t i = 0; i < tp.layers.size(); i += every) {
    EXPECT_NEAR(tp.layers[i].z, (static_cast<double>(i) + 1) * s.layer, 1e-6);
    const double z =
        std::min((static_cast<double>(i) + 0.5) * s.layer, part.height - 1e-3 * s.layer);
    check_layer(part.section(z), scan_of(tp.layers[i]), s, i, sample_step, counts, name);
    if (testing::Test::HasFatalFailure()) return;
  }
}

}  // namespace

TEST(PbfMesh, BracketIslandsKeepCompensationAndTile) {
  ScanSettings s;
  Counts counts;
  check_part(bracket(20, 5, 0.3, {1, -2}, 0.8), s, "bracket", counts);
  EXPECT_EQ(counts.layers, 8u);
  EXPECT_GT(counts.samples, 50000u);
  EXPECT_GT(counts.overlap_samples, 1000u);
}

TEST(PbfMesh, GeneratedPartsAllStrategies) {
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> u(0, 1);
  Counts counts;
  for (int k = 0; k < 12; ++k) {
    const Prism part = k % 3 == 0
                           ? bracket(10 + 10 * u(rng), 2 + 4 * u(rng), 2 * kPi * u(rng),
                                     {10 * u(rng), 10 * u(rng)}, 0.4 + u(rng), 0.9 + 0.2 * u(rng))
                           : random_star(rng);
    ScanSettings s;
    s.strategy = std::array{ScanStrategy::Island, ScanStrategy::Stripe, ScanStrategy::Meander,
                            ScanStrategy::Rectilinear}[k % 4];
    s.contours = k % 3;
    s.island = 1.5 + 2 * u(rng);
    s.island_overlap = 0.05 + 0.2 * u(rng);
    s.island_shift = 2 * u(rng);
    s.stripe = 1 + 3 * u(rng);
    s.rotation = k % 2 ? 67 : 90 * u(rng);
    check_part(part, s, "part" + std::to_string(k), counts, 1, 0.07);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(counts.samples, 100000u);
}

TEST(PbfMesh, StrategiesDiffer) {
  const Prism part = bracket(20, 5, 0, {0, 0}, 0.5);
  std::map<ScanStrategy, double> longest;
  std::map<ScanStrategy, std::size_t> vectors;
  for (ScanStrategy st : {ScanStrategy::Island, ScanStrategy::Stripe, ScanStrategy::Meander}) {
    ScanSettings s;
    s.strategy = st;
    const Toolpath tp = cli_of(part.mesh(), s, "differ");
    for (const Layer& l : tp.layers)
      for (const Vector& v : scan_of(l).hatches) {
        longest[st] = std::max(longest[st], v.length());
        ++vectors[st];
      }
  }
  ScanSettings s;
  EXPECT_LE(longest[ScanStrategy::Island], (s.island + s.island_overlap) * std::sqrt(2.0));
  EXPECT_LE(longest[ScanStrategy::Stripe], s.stripe + s.stripe_overlap + kTol);
  EXPECT_GT(longest[ScanStrategy::Meander], 15);  // whole lines along a 20 mm arm
  EXPECT_GT(vectors[ScanStrategy::Island], vectors[ScanStrategy::Meander]);
  EXPECT_GT(vectors[ScanStrategy::Stripe], vectors[ScanStrategy::Meander]);
}

// Meshes from tests/data and examples/designs (from OCCT's samples and our own): the section is
// the planar slicer's (slice_mesh_layers); the scan is checked against it as above.
TEST(PbfMesh, DataMeshesIslands) {
  const std::string root = TRELLIS_SOURCE_DIR;
  Counts counts;
  // The bearing is 100 × 120 mm: sampled more coarsely.
  for (const auto& [file, step] : {std::pair{"/tests/data/mesh/occt_bearing.3mf", 0.4},
                                   std::pair{"/examples/designs/concave_cylinder.obj", 0.1}}) {
    const TriangleMesh mesh = read_mesh(root + file);
    const BBox3 box = bounds(mesh);
    ScanSettings s;
    s.layer = (box.max.z - box.min.z) / 6;  // six layers through the whole part
    s.hatch = 0.1;
    const Toolpath tp = cli_of(mesh, s, fs::path(file).stem().string());
    ASSERT_EQ(tp.layers.size(), 6u);
    std::vector<double> zs;
    for (std::size_t i = 0; i < 6; ++i) zs.push_back(box.min.z + (i + 0.5) * s.layer);
    const auto outlines = slice_mesh_layers(mesh, zs);
    for (std::size_t i = 0; i < 6; ++i) {
      check_layer(outlines[i].regions, scan_of(tp.layers[i]), s, i, step, counts, file);
      if (HasFatalFailure()) return;
    }
  }
  EXPECT_GT(counts.samples, 10000u);
}

TEST(PbfMesh, RefusesBadSettings) {
  const Prism part = bracket(20, 5, 0, {0, 0}, 0.3);
  const TriangleMesh mesh = part.mesh();
  PbfSolid solid;
  solid.mesh = &mesh;
  ScanSettings s;
  s.island_overlap = s.island;
  EXPECT_THROW(plan_pbf_solid(solid, options_of(s)), SettingError);
  s = ScanSettings{};
  s.contours = -1;
  EXPECT_THROW(plan_pbf_solid(solid, options_of(s)), SettingError);
}
