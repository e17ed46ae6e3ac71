// Skin, core, up-skin and down-skin of solid parts, per-contour parameter sets and the hatch
// phase of the solid strategies (issue 44 item 1), checked on what a machine would get: the
// build planned, written to CLI (ASCII and binary) or 3MF and read back, every vector told apart
// by the power it was written with, and checked against the part's own geometry — a T-shaped
// beam (a stem under a wider deck, extruded along Y) whose section at any height is one known
// rectangle, so no slicer is involved in the check:
//   - every up-skin point has no material somewhere within the up-skin thickness above it, every
//     down-skin point somewhere within the down-skin thickness below it, and every other point has
//     material all through both;
//   - every core point is at least the skin thickness inside the section of every layer within
//     the skin thickness above and below it; every skin point is not;
//   - the four kinds' areas add up to the layer's region and do not overlap;
//   - each contour offset reads back with its own power and speed (CLI ids, 3MF profiles);
//   - every vector reads back in its parameter set by name (CLI labels, JSON, 3MF profile names);
//   - each kind's hatch lies on its own lines: its hatch distance apart, at its rotation;
//   - with the origin hatch phase every hatch vector lies on a line of the machine's grid.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/slice/pbf_mesh.hpp"
#include "trellis/slice/pbf_skin.hpp"
#include "trellis/slice/slice.hpp"
#include "trellis/toolpath/json.hpp"

using namespace trellis;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTol = 2e-3;  // mm: points this near a section's outline are not judged

struct Rect {
  double x0, y0, x1, y1;
  bool inside(Vec2 p) const { return p.x > x0 && p.x < x1 && p.y > y0 && p.y < y1; }
  // Distance from an inside point to the outline (negative outside).
  double depth(Vec2 p) const { return std::min({p.x - x0, x1 - p.x, p.y - y0, y1 - p.y}); }
};

// A T-shaped beam W mm long along Y: a stem x in [4, 6] from z = 0 to 3 under a deck x in
// [0, 10] from z = 3 to 4. Its section at height z is one rectangle (none outside [0, 4]).
struct Beam {
  double w = 3;
  bool has(double z) const { return z > 0 && z < 4; }
  Rect at(double z) const { return z < 3 ? Rect{4, 0, 6, w} : Rect{0, 0, 10, w}; }
  bool solid(Vec2 p, double z) const { return has(z) && at(z).inside(p); }
  double depth(Vec2 p, double z) const { return has(z) ? at(z).depth(p) : -1; }
  // The profile in (x, z), star-shaped from (5, 3.5), extruded along Y.
  TriangleMesh mesh() const {
    const std::vector<Vec2> ring{{4, 0}, {6, 0}, {6, 3}, {10, 3}, {10, 4}, {0, 4}, {0, 3}, {4, 3}};
    const Vec2 c{5, 3.5};
    TriangleMesh m;
    const auto n = static_cast<std::uint32_t>(ring.size());
    for (double y : {0.0, w})
      for (Vec2 q : ring) m.vertices.push_back({q.x, y, q.y});
    m.vertices.push_back({c.x, 0, c.y});
    m.vertices.push_back({c.x, w, c.y});
    // Outward: the ring runs counter-clockwise in (x, z), seen from −Y.
    const std::uint32_t c0 = 2 * n, c1 = 2 * n + 1;
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t j = (i + 1) % n;
      m.triangles.push_back({c0, i, j});
      m.triangles.push_back({c1, n + j, n + i});
      m.triangles.push_back({i, n + j, j});
      m.triangles.push_back({i, n + i, n + j});
    }
    return m;
  }
};

constexpr double kLayer = 0.1;
// Layer i's section height (the middle of the layer) from the CLI's z (the layer's top).
double mid_of(double cli_z) {
  return cli_z - kLayer / 2;
}

struct Sets {
  LaserSet contour{60, 800}, hatch{100, 1000}, core{150, 1100}, up{120, 900}, down{50, 1200};
  std::vector<LaserSet> contours{{55, 600}, {65, 700}, {75, 750}};
};

PbfSolidOptions beam_options(const Sets& s) {
  PbfSolidOptions o;
  o.layer = kLayer;
  o.beam_compensation = 0.03;
  o.contours = 3;
  o.contour_distance = 0.05;
  o.pattern.strategy = ScanStrategy::Meander;
  o.pattern.hatch_distance = 0.07;
  o.skin = {0.4, 0.2, 0.3};  // skin, up-skin, down-skin (mm): 4, 2 and 3 layers
  o.kind_hatch[static_cast<std::size_t>(HatchKind::Core)] = {0.11, 90};
  o.kind_hatch[static_cast<std::size_t>(HatchKind::UpSkin)] = {0.05, 30};
  o.kind_hatch[static_cast<std::size_t>(HatchKind::DownSkin)] = {0.09, 45};
  o.exposures.contour = s.contour;
  o.exposures.hatch = s.hatch;
  o.exposures.contours = s.contours;
  o.exposures.core = s.core;
  o.exposures.upskin = s.up;
  o.exposures.downskin = s.down;
  return o;
}

std::vector<CliParameterSet> cli_sets(const Sets& s) {
  return {{"contour 1", false, s.contours[0].power, s.contours[0].speed},
          {"contour 2", false, s.contours[1].power, s.contours[1].speed},
          {"contour 3", false, s.contours[2].power, s.contours[2].speed},
          {"core hatch", true, s.core.power, s.core.speed},
          {"upskin hatch", true, s.up.power, s.up.speed},
          {"downskin hatch", true, s.down.power, s.down.speed}};
}

// The beam planned and written: ASCII CLI, binary CLI or a 3MF toolpath, read back.
Toolpath written(const Beam& beam, const PbfSolidOptions& o, const Sets& s, const std::string& as) {
  const test::TempDir dir("trellis_test_pbf_skin");
  const TriangleMesh mesh = beam.mesh();
  PbfSolid part;
  part.mesh = &mesh;
  LaserProfile prof;
  prof.layer = o.layer;
  const std::string path = dir.file(as == "3mf"    ? "beam.3mf"
                                    : as == "json" ? "beam.json"
                                                   : "beam.cli");
  if (as == "3mf" || as == "json") {
    Toolpath tp;
    tp.parameter_sets = named_parameter_sets(o.exposures, o.skin);
    plan_pbf_solid(part, o, [&](std::size_t i, const PbfLayer& L) {
      tp.layers.push_back(pbf_solid_layer_toolpath(L, i, o.layer, o.exposures));
    });
    if (as == "json") {
      write_toolpath(path, tp);
      return read_toolpath(path);
    }
    Toolpath3mfOptions to;
    to.laser = &prof;
    write_toolpath_3mf_file(path, tp, to);
    return read_toolpath_3mf_file(path);
  }
  CliStreamWriter w(path, prof, {as == "binary", true, cli_sets(s)}, "test", "");
  plan_pbf_solid(part, o, [&](std::size_t i, const PbfLayer& L) {
    w.add(pbf_solid_layer_toolpath(L, i, o.layer, o.exposures));
  });
  w.finish();
  return read_cli_file(path);
}

std::vector<Vec2> samples(const Path& p, double step = 0.05) {
  std::vector<Vec2> out;
  for (std::size_t k = 1; k < p.points.size(); ++k) {
    const Vec2 a{p.points[k - 1].x, p.points[k - 1].y}, b{p.points[k].x, p.points[k].y};
    const int n = std::max(1, static_cast<int>(std::ceil(std::sqrt(dist2(a, b)) / step)));
    for (int j = 0; j <= n; ++j) out.push_back(a + (b - a) * (static_cast<double>(j) / n));
  }
  return out;
}

bool is(const Path& p, LaserSet s) {
  return p.power == s.power && p.speed == s.speed;
}

// No material at p somewhere in layers 1..n above (dir +1) or below (−1) the layer at z.
bool open_within(const Beam& b, Vec2 p, double z, int n, int dir) {
  for (int j = 1; j <= n; ++j)
    if (!b.solid(p, z + dir * j * kLayer)) return true;
  return false;
}
// p at or near an outline of the layers from −n to n around z: not judged.
bool near_outline(const Beam& b, Vec2 p, double z, int n) {
  for (int j = -n; j <= n; ++j)
    if (b.has(z + j * kLayer) && std::abs(b.depth(p, z + j * kLayer)) < kTol) return true;
  return false;
}

}  // namespace

TEST(PbfSkin, KindsHoldTheirDefinitionsReadBackFromTheCli) {
  const Beam beam;
  const Sets s;
  const PbfSolidOptions o = beam_options(s);
  const Toolpath tp = written(beam, o, s, "ascii");
  ASSERT_EQ(tp.layers.size(), 40u);
  const int n_up = 2, n_down = 3, n_core = 4;
  std::map<std::string, std::size_t> counted;
  for (const Layer& l : tp.layers) {
    const double z = mid_of(l.z);
    for (const Path& p : l.paths) {
      if (p.role == PathRole::Contour) continue;
      const bool up = is(p, s.up), down = is(p, s.down), core = is(p, s.core);
      ASSERT_TRUE(up || down || core || is(p, s.hatch)) << "a hatch with power " << p.power;
      ++counted[up ? "up" : down ? "down" : core ? "core" : "skin"];
      for (Vec2 q : samples(p)) {
        if (near_outline(beam, q, z, std::max({n_up, n_down, n_core}))) continue;
        ASSERT_TRUE(beam.solid(q, z)) << "z " << z;
        const bool open_above = open_within(beam, q, z, n_up, +1);
        const bool open_below = open_within(beam, q, z, n_down, -1);
        if (down) {
          EXPECT_TRUE(open_below) << "down-skin over material at " << q.x << "," << q.y << " z "
                                  << z;
        } else if (up) {
          EXPECT_TRUE(open_above) << "up-skin under material at " << q.x << "," << q.y << " z "
                                  << z;
          EXPECT_FALSE(open_below) << "up-skin that is down-skin, z " << z;
        } else {
          EXPECT_FALSE(open_above || open_below) << "skin/core point at the surface, z " << z;
        }
        // Core: at least the skin thickness inside every layer within it above and below.
        double deepest = HUGE_VAL;
        for (int j = -n_core; j <= n_core; ++j)
          deepest = std::min(deepest, beam.depth(q, z + j * kLayer));
        if (core)
          EXPECT_GE(deepest, o.skin.skin_thickness - kTol)
              << "core point at " << q.x << "," << q.y << " z " << z;
        else if (!up && !down && deepest > o.skin.skin_thickness + kTol)
          ADD_FAILURE() << "a skin point " << deepest << " mm deep at z " << z;
      }
    }
  }
  // The beam has all four: its stem's foot and the deck's underside are down-skin, the deck's
  // top up-skin, the stem's and deck's middles core.
  for (const char* k : {"up", "down", "core", "skin"}) EXPECT_GT(counted[k], 10u) << k;
}

TEST(PbfSkin, AreasAddUpAndDoNotOverlap) {
  for (const bool data_mesh : {false, true}) {
    const TriangleMesh mesh =
        data_mesh ? read_mesh(std::string(TRELLIS_SOURCE_DIR) + "/tests/data/mesh/occt_bearing.3mf")
                  : Beam{}.mesh();
    const BBox3 e = bounds(mesh);
    const double layer = (e.max.z - e.min.z) / 30;
    const std::vector<double> zs = layer_planes(e.min.z, e.max.z, layer);
    std::vector<Regions> regions;
    for (auto& l : slice_mesh_layers(mesh, zs)) regions.push_back(std::move(l.regions));
    const double size = std::max(e.max.x - e.min.x, e.max.y - e.min.y);
    const double skin = std::min(0.05 * size, 1.5 * layer);  // a core the bearing's ring holds
    SkinWindow window({skin, 2.5 * layer, 3 * layer}, layer, zs.size());
    window.prepare(0, zs.size(), [&](std::size_t j) -> const Regions& { return regions[j]; });
    std::array<bool, kHatchKinds> seen{};
    for (std::size_t i = 0; i < zs.size(); ++i) {
      const LayerKinds k = window.split(i, regions[i]);
      double sum = 0;
      Regions all;
      for (std::size_t j = 0; j < kHatchKinds; ++j) {
        sum += area(k[j]);
        all = unite(all, k[j]);
        seen[j] = seen[j] || !k[j].empty();
      }
      const double a = area(regions[i]);
      EXPECT_NEAR(sum, a, 1e-6 * std::max(1.0, a)) << "layer " << i;
      EXPECT_NEAR(area(all), a, 1e-6 * std::max(1.0, a)) << "layer " << i << ": kinds overlap";
      EXPECT_NEAR(area(difference(regions[i], all)), 0, 1e-6 * std::max(1.0, a)) << "layer " << i;
    }
    for (std::size_t j = 0; j < kHatchKinds; ++j)
      EXPECT_TRUE(seen[j]) << (data_mesh ? "bearing: " : "beam: ") << "no "
                           << hatch_kind_name(static_cast<HatchKind>(j));
    // The planner reports the same areas per layer.
    PbfSolidOptions o;
    o.layer = layer;
    o.skin = {skin, 2.5 * layer, 3 * layer};
    o.pattern.hatch_distance = size / 50;
    PbfSolid part;
    part.mesh = &mesh;
    const PbfResult r = plan_pbf_solid(part, o);
    ASSERT_EQ(r.layers.size(), zs.size());
    for (const PbfLayer& L : r.layers) {
      double sum = 0;
      for (double a : L.kind_area) sum += a;
      EXPECT_NEAR(sum, L.area, 1e-6 * std::max(1.0, L.area));
    }
  }
}

TEST(PbfSkin, ContourOffsetsRoundTripWithTheirParameterSets) {
  const Beam beam;
  const Sets s;
  const PbfSolidOptions o = beam_options(s);
  for (const std::string as : {"ascii", "binary", "3mf"}) {
    const Toolpath tp = written(beam, o, s, as);
    std::map<int, std::size_t> per_offset;
    for (const Layer& l : tp.layers)
      for (const Path& p : l.paths) {
        if (p.role != PathRole::Contour) continue;
        // Which offset the contour is, from its distance to the section's outline.
        const Vec2 q{p.points.front().x, p.points.front().y};
        const double d = beam.depth(q, mid_of(l.z));
        const int k = static_cast<int>(std::lround((d - o.beam_compensation) / o.contour_distance));
        ASSERT_GE(k, 0) << as;
        ASSERT_LT(k, 3) << as;
        EXPECT_NEAR(d, o.beam_compensation + k * o.contour_distance, 1e-4) << as;
        EXPECT_TRUE(is(p, s.contours[static_cast<std::size_t>(k)]))
            << as << ": contour " << k + 1 << " read back with " << p.power << " W, " << p.speed
            << " mm/s";
        ++per_offset[k];
      }
    for (int k = 0; k < 3; ++k) EXPECT_GE(per_offset[k], 40u) << as << " offset " << k;
  }
  // Each set has its own id and label in the CLI header, and reads back as its kind.
  const test::TempDir dir("trellis_test_pbf_skin_ids");
  Toolpath one;
  one.layers.push_back(Layer{});
  for (std::size_t k = 0; k < 3; ++k) {
    Path p;
    p.role = PathRole::Contour;
    p.power = s.contours[k].power, p.speed = s.contours[k].speed;
    p.points = {{0, 0, 0.1}, {1, 0, 0.1}, {1, 1, 0.1}};
    one.layers[0].paths.push_back(p);
  }
  const std::string cli = write_cli(one, LaserProfile{}, {false, true, cli_sets(s)});
  for (int id = 3; id <= 8; ++id)  // after contour 1 and hatch 2
    EXPECT_NE(cli.find("// PROFILE_DEF=" + std::to_string(id) + " NAME="), std::string::npos) << id;
  EXPECT_NE(cli.find("$$LABEL/3,contour 1"), std::string::npos);
  EXPECT_NE(cli.find("$$LABEL/6,core hatch"), std::string::npos);
  EXPECT_NE(cli.find("$$POLYLINE/5,"), std::string::npos);
  const Toolpath back = read_cli(cli, "ids");
  ASSERT_EQ(back.layers.size(), 1u);
  for (const Path& p : back.layers[0].paths) EXPECT_EQ(p.role, PathRole::Contour);
}

TEST(PbfSkin, EveryVectorReadsBackInItsNamedParameterSet) {
  const Beam beam;
  const Sets s;
  const PbfSolidOptions o = beam_options(s);
  // What each set is called, by power and speed (all distinct in Sets).
  const std::vector<std::pair<LaserSet, std::string>> names{
      {s.contours[0], "contour 1"}, {s.contours[1], "contour 2"}, {s.contours[2], "contour 3"},
      {s.hatch, "hatch"},           {s.core, "core hatch"},       {s.up, "upskin hatch"},
      {s.down, "downskin hatch"}};
  for (const char* as : {"ascii", "binary", "json", "3mf"}) {
    const Toolpath tp = written(beam, o, s, as);
    std::map<std::string, std::size_t> seen;
    for (const Layer& l : tp.layers)
      for (const Path& p : l.paths) {
        const int k = parameter_set_of(tp, p);
        ASSERT_GE(k, 0) << as << ": a path of " << p.power << " W in no set";
        const ParameterSet& set = tp.parameter_sets[static_cast<std::size_t>(k)];
        const auto want =
            std::find_if(names.begin(), names.end(), [&](const auto& n) { return is(p, n.first); });
        ASSERT_NE(want, names.end()) << as;
        EXPECT_EQ(set.name, want->second) << as;
        EXPECT_EQ(set.role == PathRole::Hatch, want->second.find("hatch") != std::string::npos);
        ++seen[set.name];
      }
    for (const auto& [set, name] : names) EXPECT_GT(seen[name], 0u) << as << " " << name;
  }
}

TEST(PbfSkin, OriginPhasePutsHatchLinesOnTheMachineGrid) {
  const Beam beam;
  const TriangleMesh mesh = beam.mesh();
  for (const ScanStrategy strategy : {ScanStrategy::Rectilinear, ScanStrategy::Meander,
                                      ScanStrategy::Stripe, ScanStrategy::Island}) {
    PbfSolidOptions o;
    o.layer = kLayer;
    o.pattern.strategy = strategy;
    o.pattern.hatch_distance = 0.07;
    o.pattern.island_size = 1.3;
    o.pattern.stripe_width = 1.7;
    o.hatch_phase = HatchPhase::Origin;
    o.machine_origin = {-51.234567, -48.7654321};  // the part off the plate's centre
    const Sets s;
    o.exposures.contour = s.contour;
    o.exposures.hatch = s.hatch;
    const Toolpath tp = written(beam, o, s, "binary");
    std::size_t judged = 0;
    for (std::size_t i = 0; i < tp.layers.size(); ++i) {
      const double a = scan_angle(o.pattern, i) * kPi / 180;
      for (const Path& p : tp.layers[i].paths) {
        if (p.role == PathRole::Contour) continue;
        const Vec2 u{p.points[1].x - p.points[0].x, p.points[1].y - p.points[0].y};
        const double len = std::sqrt(u.x * u.x + u.y * u.y);
        if (len < 0.05) continue;  // too short to tell its direction at the file's 10 nm
        // Along the layer's angle or (islands) at 90° to it.
        const double c = std::abs(std::cos(a) * u.x + std::sin(a) * u.y) / len;
        const bool turned = c < 1e-3;
        EXPECT_TRUE(c > 1 - 1e-5 || (strategy == ScanStrategy::Island && turned));
        // Across the lines, from the machine's origin: a whole number of hatch distances.
        const Vec2 n = turned ? Vec2{-std::cos(a), -std::sin(a)} : Vec2{-std::sin(a), std::cos(a)};
        const Vec2 q{p.points[0].x - o.machine_origin.x, p.points[0].y - o.machine_origin.y};
        const double t = (q.x * n.x + q.y * n.y) / o.pattern.hatch_distance;
        EXPECT_NEAR(t, std::round(t), 2e-3)
            << "layer " << i << " strategy " << static_cast<int>(strategy);
        ++judged;
      }
    }
    EXPECT_GT(judged, 500u);
  }
}

TEST(PbfSkin, EachKindHatchesOnItsOwnDistanceAndRotation) {
  const Beam beam;
  const Sets s;
  const PbfSolidOptions o = beam_options(s);
  const Toolpath tp = written(beam, o, s, "ascii");
  const std::array<std::pair<HatchKind, LaserSet>, kHatchKinds> kinds{
      {{HatchKind::Skin, s.hatch},
       {HatchKind::Core, s.core},
       {HatchKind::UpSkin, s.up},
       {HatchKind::DownSkin, s.down}}};
  std::map<HatchKind, std::size_t> judged;
  for (std::size_t i = 0; i < tp.layers.size(); ++i) {
    for (const Path& p : tp.layers[i].paths) {
      if (p.role == PathRole::Contour) continue;
      const auto kind =
          std::find_if(kinds.begin(), kinds.end(), [&](const auto& k) { return is(p, k.second); });
      ASSERT_NE(kind, kinds.end()) << "a hatch with power " << p.power;
      const ScanPattern pattern = o.pattern_of(kind->first);
      const Vec2 u{p.points[1].x - p.points[0].x, p.points[1].y - p.points[0].y};
      const double len = std::sqrt(u.x * u.x + u.y * u.y);
      if (len < 0.05) continue;  // too short to tell its direction at the file's 10 nm
      const double a = scan_angle(pattern, i) * kPi / 180;
      EXPECT_GT(std::abs(std::cos(a) * u.x + std::sin(a) * u.y) / len, 1 - 1e-5)
          << hatch_kind_name(kind->first) << " layer " << i;
      // The wall phase: lines through the design's origin, a whole number of distances across.
      const Vec2 n{-std::sin(a), std::cos(a)};
      const double t = (p.points[0].x * n.x + p.points[0].y * n.y) / pattern.hatch_distance;
      EXPECT_NEAR(t, std::round(t), 2e-3) << hatch_kind_name(kind->first) << " layer " << i;
      ++judged[kind->first];
    }
  }
  for (const auto& [kind, set] : kinds) EXPECT_GT(judged[kind], 20u) << hatch_kind_name(kind);
  // The four patterns differ: a kind on another's lines would fail above.
  EXPECT_NE(o.pattern_of(HatchKind::UpSkin).hatch_distance, o.pattern.hatch_distance);
  EXPECT_NE(o.pattern_of(HatchKind::DownSkin).rotation, o.pattern.rotation);
}

TEST(PbfSkin, RandomPhaseMovesEachLayerAndRepeats) {
  const Beam beam;
  const TriangleMesh mesh = beam.mesh();
  PbfSolid part;
  part.mesh = &mesh;
  PbfSolidOptions o;
  o.layer = kLayer;
  o.pattern.strategy = ScanStrategy::Rectilinear;
  o.pattern.rotation = 0;  // the same lines every layer but for the phase
  o.pattern.hatch_distance = 0.07;
  o.hatch_phase = HatchPhase::Random;
  o.hatch_seed = 7;
  const PbfResult a = plan_pbf_solid(part, o), b = plan_pbf_solid(part, o);
  std::vector<double> phases;
  for (std::size_t i = 0; i < a.layers.size(); ++i) {
    ASSERT_EQ(a.layers[i].hatches.size(), b.layers[i].hatches.size());
    ASSERT_FALSE(a.layers[i].hatches.empty());
    EXPECT_EQ(a.layers[i].hatches[0].a.y, b.layers[i].hatches[0].a.y);
    // Lines along X: the phase is y modulo the hatch distance.
    double f = std::fmod(a.layers[i].hatches[0].a.y / 0.07, 1.0);
    if (f < 0) f += 1;
    for (const Segment2& h : a.layers[i].hatches) {
      const double t = h.a.y / 0.07 - f;
      EXPECT_NEAR(t, std::round(t), 1e-6);
    }
    phases.push_back(f);
  }
  std::sort(phases.begin(), phases.end());
  const auto distinct = std::unique(phases.begin(), phases.end(),
                                    [](double x, double y) { return std::abs(x - y) < 1e-3; });
  EXPECT_GT(distinct - phases.begin(), 30);        // 40 layers, hardly any two alike
  EXPECT_GT(phases.back() - phases.front(), 0.8);  // spread over the whole distance
}
