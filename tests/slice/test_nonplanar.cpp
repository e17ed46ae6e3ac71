// Non-planar slicing: the properties checked on the paths (and on the G-code read back by
// the independent replayer), over the paper's surfaces and random height fields.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <set>

#include "support/gcode_replay.hpp"
#include "support/machines.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/plan/plan.hpp"
#include "trellis/slice/nonplanar.hpp"

using namespace trellis;

namespace {

constexpr double kDeg = std::numbers::pi / 180;

// A smooth random height field: a sum of a few sine waves over a random rectangle.
HeightField random_surface(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  struct Wave {
    double ax, ay, k, phase, amp;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 3; ++i)
    waves.push_back({u(rng) * 2 - 1, u(rng) * 2 - 1, 0.2 + u(rng) * 0.6, u(rng) * 6, 0.3 + u(rng)});
  const double w = 6 + u(rng) * 10, h = 4 + u(rng) * 8;
  auto make = [waves]() -> HeightField::Eval {
    return [waves](double x, double y) {
      double z = 0;
      for (const auto& wv : waves)
        z += wv.amp * std::sin(wv.k * (wv.ax * x + wv.ay * y) + wv.phase);
      return z;
    };
  };
  return HeightField::from_function(make, {{0, 0}, {w, h}}, "random");
}

// Distances between neighbouring lines of a layer: the offsets across the direction of every
// long segment parallel to it, clustered.
std::vector<double> line_spacings(const Layer& layer, double angle_deg) {
  const Vec2 d{std::cos(angle_deg * kDeg), std::sin(angle_deg * kDeg)}, n{-d.y, d.x};
  std::vector<double> v;
  for (const auto& p : layer.paths)
    for (std::size_t i = 1; i < p.points.size(); ++i) {
      const Vec2 s = p.points[i].xy() - p.points[i - 1].xy();
      const double len = std::hypot(s.x, s.y);
      if (len > 1e-3 && std::abs(n.x * s.x + n.y * s.y) < 1e-9 * len + 1e-12)
        v.push_back(n.x * p.points[i].x + n.y * p.points[i].y);
    }
  std::sort(v.begin(), v.end());
  std::vector<double> lines;
  for (double x : v)
    if (lines.empty() || x - lines.back() > 1e-6) lines.push_back(x);
  std::vector<double> gaps;
  for (std::size_t i = 1; i < lines.size(); ++i) gaps.push_back(lines[i] - lines[i - 1]);
  return gaps;
}

void expect_properties(const HeightField& s, const NonplanarParams& prm, bool convex,
                       const std::string& what) {
  SCOPED_TRACE(what);
  const NonplanarResult r = slice_nonplanar(s, prm);
  ASSERT_EQ(r.toolpath.layers.size(), static_cast<std::size_t>(prm.layers));
  const SurfaceDeviation dev = surface_deviation(r.toolpath, s, prm);
  EXPECT_LE(dev.max_point, 0.01);
  EXPECT_LE(dev.max_chord, prm.chord_tolerance + 1e-4);
  for (std::size_t k = 0; k < r.toolpath.layers.size(); ++k) {
    const auto& layer = r.toolpath.layers[k];
    if (convex) EXPECT_EQ(layer.paths.size(), 1u) << "layer " << k << ": travel inside a layer";
    for (double g : line_spacings(layer, prm.angles[k % prm.angles.size()]))
      EXPECT_NEAR(g, prm.width, 0.01 * prm.width) << "layer " << k;
    EXPECT_GE(footprint_coverage(r.toolpath, k, s, prm.width, 0.04), 0.98) << "layer " << k;
  }
}

TEST(Nonplanar, PaperSurfacesMeetTheProperties) {
  NonplanarParams prm;  // 0.4 mm paths, 0.3 mm layers, 6 layers, cross-hatch
  expect_properties(corrugation({}), prm, true, "corrugation");
  CorrugationParams sharp;
  sharp.fillet_diameter = 0;
  sharp.periods = 10;
  expect_properties(corrugation(sharp), prm, true, "sharp 10-period corrugation");
  for (double depth : {0.0, 2.0, 6.0}) {
    MiuraParams m;
    m.depth = depth;
    expect_properties(miura(m), prm, true, "miura " + std::to_string(depth));
  }
  expect_properties(m_curve({}), prm, true, "M curve");
  expect_properties(sphere_cap(10, 16), prm, true, "sphere cap");
  NonplanarParams normal = prm;
  normal.offset = OffsetMode::Normal;
  normal.layers = 3;
  expect_properties(corrugation({}), normal, true, "corrugation, normal offsets");
  expect_properties(sphere_cap(10, 16), normal, true, "sphere cap, normal offsets");
}

// Normal offsets over sharp folds: the 1.5 mm offset's nearest surface point sits on creases
// and on the footprint's edge (a quarter of the paper's 6 mm Miura-Ori, for time).
TEST(Nonplanar, NormalOffsetsOverSharpFolds) {
  MiuraParams m;
  m.depth = 6;
  m.length = 22;
  m.width = 8;
  m.periods_x = 2;
  m.periods_y = 1;
  NonplanarParams prm;
  prm.offset = OffsetMode::Normal;
  const HeightField s = miura(m);
  const NonplanarResult r = slice_nonplanar(s, prm);
  const SurfaceDeviation dev = surface_deviation(r.toolpath, s, prm);
  EXPECT_LE(dev.max_point, 0.01);
  // The envelope search is accurate to a few micrometres at folds, and chords inherit that on
  // top of the tolerance (measured: 5.3 µm for 5 µm).
  EXPECT_LE(dev.max_chord, 2 * prm.chord_tolerance);
  for (std::size_t k = 0; k < r.toolpath.layers.size(); ++k) {
    EXPECT_EQ(r.toolpath.layers[k].paths.size(), 1u) << "layer " << k;
    EXPECT_GE(footprint_coverage(r.toolpath, k, s, prm.width, 0.04), 0.98) << "layer " << k;
  }
}

// Sections are cut on worker threads: the same paths and reports on one thread and on two, for
// vertical and normal offsets (whose envelope search is the slow part).
TEST(Nonplanar, SamePathsOnOneAndTwoThreads) {
  for (const OffsetMode mode : {OffsetMode::Vertical, OffsetMode::Normal}) {
    NonplanarParams prm;
    prm.offset = mode;
    prm.layers = 3;
    prm.layer_height = 0.6;
    auto slice = [&](std::size_t threads) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      return slice_nonplanar(corrugation({}), prm);
    };
    const NonplanarResult a = slice(1), b = slice(2);
    ASSERT_EQ(a.toolpath.layers.size(), b.toolpath.layers.size()) << to_string(mode);
    for (std::size_t k = 0; k < a.toolpath.layers.size(); ++k) {
      const auto &pa = a.toolpath.layers[k].paths, &pb = b.toolpath.layers[k].paths;
      ASSERT_EQ(pa.size(), pb.size()) << to_string(mode) << " layer " << k;
      ASSERT_FALSE(pa.empty()) << to_string(mode) << " layer " << k;
      for (std::size_t i = 0; i < pa.size(); ++i)
        EXPECT_TRUE(pa[i].points == pb[i].points) << to_string(mode) << " layer " << k;
      EXPECT_EQ(a.layers[k].connector_length, b.layers[k].connector_length) << k;
      EXPECT_EQ(a.layers[k].travel_moves, b.layers[k].travel_moves) << k;
    }
    EXPECT_EQ(a.max_descent_deg, b.max_descent_deg) << to_string(mode);
  }
}

TEST(Nonplanar, MeshesOfTheSurfacesSliceTheSame) {
  NonplanarParams prm;
  prm.layers = 2;
  const HeightField fn = corrugation({});
  const HeightField mesh = HeightField::from_mesh(surface_mesh(fn, 0.1), "mesh");
  expect_properties(mesh, prm, true, "corrugation mesh");
  // The extruded-profile mesh is within the chord tolerance of the function.
  const NonplanarResult r = slice_nonplanar(mesh, prm);
  EXPECT_LE(surface_deviation(r.toolpath, fn, prm).max_point, 0.002);
  const HeightField cap = HeightField::from_mesh(surface_mesh(sphere_cap(10, 16), 0.25), "cap");
  expect_properties(cap, prm, false, "sphere cap mesh");
}

TEST(Nonplanar, RandomHeightFields) {
  std::mt19937 rng(7);
  for (int i = 0; i < 12; ++i) {
    const HeightField s = random_surface(rng);
    NonplanarParams prm;
    prm.layers = 3;
    prm.angles = {std::uniform_real_distribution<double>(0, 180)(rng)};
    prm.width = std::uniform_real_distribution<double>(0.2, 0.6)(rng);
    prm.offset = i % 3 == 0 ? OffsetMode::Normal : OffsetMode::Vertical;
    expect_properties(s, prm, true, "random " + std::to_string(i));
    const HeightField m = HeightField::from_mesh(surface_mesh(s, 0.2), "random mesh");
    prm.offset = OffsetMode::Vertical;
    expect_properties(m, prm, true, "random mesh " + std::to_string(i));
  }
}

TEST(Nonplanar, NonConvexFootprintTravelsOnlyBetweenParts) {
  // Two humps joined by nothing: z exists over two separate discs.
  const HeightField s = HeightField::from_expression(
      "(x-4)^2+y^2<9 ? 1 : ((x+4)^2+y^2<9 ? 2 : sqrt(-1))", {{-8, -4}, {8, 4}}, "two discs");
  NonplanarParams prm;
  prm.layers = 1;
  prm.angles = {90};  // lines across the gap: each disc its own serpentine
  const NonplanarResult r = slice_nonplanar(s, prm);
  EXPECT_EQ(r.toolpath.layers[0].paths.size(), 2u);
  EXPECT_GE(footprint_coverage(r.toolpath, 0, s, prm.width, 0.02), 0.98);
  EXPECT_LE(surface_deviation(r.toolpath, s, prm).max_point, 1e-9);
}

TEST(Nonplanar, NotAHeightFieldNamesWhere) {
  // A closed box: its top lies above its bottom.
  TriangleMesh box;
  box.add_prism({{0, 0}, {4, 0}, {4, 3}, {0, 3}}, 0, 2);
  try {
    HeightField::from_mesh(box, "box.stl");
    FAIL() << "a closed box was accepted";
  } catch (const GeometryError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("box.stl"), std::string::npos) << m;
    EXPECT_NE(m.find("not a height field"), std::string::npos) << m;
  }
  // A sheet folded over itself: z = 0 over [0,4]x[0,2], then back over [2,4] at z = 1.
  TriangleMesh fold;
  fold.vertices = {{0, 0, 0}, {4, 0, 0}, {4, 2, 0}, {0, 2, 0}, {2, 0, 1}, {2, 2, 1}};
  fold.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 4, 5}, {1, 5, 2}};
  try {
    HeightField::from_mesh(fold, "fold.stl");
    FAIL() << "a fold was accepted";
  } catch (const GeometryError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("above one another near ("), std::string::npos) << m;
  }
  // A vertical wall.
  TriangleMesh wall;
  wall.vertices = {{0, 0, 0}, {4, 0, 0}, {4, 0, 2}};
  wall.triangles = {{0, 1, 2}};
  EXPECT_THROW(HeightField::from_mesh(wall, "wall.stl"), GeometryError);
  EXPECT_THROW(HeightField::from_expression("x +* y", {{0, 0}, {1, 1}}, "bad"), ParseError);
}

// Found by fuzz_mesh: a sliver 444 km long once took millions of samples per connector.
TEST(Nonplanar, HugeSliverStaysBoundedWork) {
  TriangleMesh m;
  m.vertices = {{0, 8, 2}, {1, 444444, 1}, {0, 0, 1}};
  m.triangles = {{0, 1, 2}};
  const HeightField h = HeightField::from_mesh(m, "sliver");
  NonplanarParams p;
  p.layers = 2;
  p.width = p.layer_height = 444444.0 / 40;
  const NonplanarResult r = slice_nonplanar(h, p);
  std::size_t points = 0;
  for (const auto& l : r.toolpath.layers)
    for (const auto& path : l.paths) points += path.points.size();
  EXPECT_GT(points, 0u);
  EXPECT_LT(points, 200000u);
}

TEST(Nonplanar, ProfilesAreContinuousAndTangentAtFillets) {
  const Profile p = corrugation_profile({});
  const auto z = profile_function(p);
  double worst_jump = 0, worst_kink = 0;
  const double h = 1e-4;
  for (double x = h; x < 44 - h; x += 0.0037) {
    worst_jump = std::max(worst_jump, std::abs(z(x + 1e-9) - z(x - 1e-9)));
    const double s0 = (z(x) - z(x - h)) / h, s1 = (z(x + h) - z(x)) / h;
    worst_kink = std::max(worst_kink, std::abs(s1 - s0));
  }
  EXPECT_LT(worst_jump, 1e-6);
  EXPECT_LT(worst_kink, 0.01);  // slopes change smoothly: every corner is filleted
  // Peaks at ±amplitude: 5 periods over 30 mm at 45° rise 1.5 mm, less the fillet's cut.
  double top = -1, bottom = 1;
  for (double x = 0; x <= 44; x += 0.001)
    top = std::max(top, z(x)), bottom = std::min(bottom, z(x));
  const double cut = 0.25 / std::cos(45 * kDeg) - 0.25;  // fillet r = 0.25 at a 90° corner
  EXPECT_NEAR(top, 1.5 - cut, 1e-3);
  EXPECT_NEAR(bottom, -1.5 + cut, 1e-3);
  CorrugationParams odd;
  odd.periods = 2.3;
  EXPECT_THROW(corrugation_profile(odd), SettingError);
}

TEST(Nonplanar, AngleTestLinesHaveTheProgrammedAngles) {
  AngleTestParams p;
  const Toolpath tp = angle_test(p);
  ASSERT_EQ(tp.layers[0].paths.size(), p.angles.size());
  for (std::size_t i = 0; i < p.angles.size(); ++i) {
    const auto& pts = tp.layers[0].paths[i].points;
    double first_slope = 0;
    for (std::size_t k = 1; k < pts.size(); ++k) {
      const Vec3 s = pts[k] - pts[k - 1];
      if (std::abs(s.z) < 1e-12) continue;
      first_slope = std::atan2(s.z, std::hypot(s.x, s.y)) / kDeg;
      break;
    }
    EXPECT_NEAR(first_slope, p.angles[i], 1e-9) << "line " << i;
  }
}

TEST(Nonplanar, ToolGroupsAndInBathHopsInTheGcode) {
  NonplanarParams prm;
  prm.layers = 9;
  prm.angles = {0};
  prm.layer_tools = {0, 0, 0, 1, 1, 1, 0, 0, 0};
  const NonplanarResult r = slice_nonplanar(m_curve({}), prm);
  MachineProfile p = test::open_bed({}, 2);
  p.flavor = Flavor::Embedded;
  p.embedded_drive = EmbeddedDrive::Syringe;
  p.filament_diameter = 14.5;
  p.bath_surface = 20;
  p.bath_travel = 2;
  p.tool_offsets = "0,0; 35,0";
  GcodeStats g;
  const std::string text = write_gcode(r.toolpath, p, &g);
  EXPECT_EQ(g.tool_changes, 2u);
  // Read back: one continuous extrusion per layer, every deposit on its layer's surface offset.
  const test::Replay rep = test::replay_gcode(text);
  EXPECT_EQ(rep.extrusion_starts, 9u);
  const HeightField s = m_curve({});
  for (const auto& d : rep.deposits) {
    // Nozzle 1 sits 35 mm along +X: the head ran 35 mm to the left of its deposits (the replay
    // reads head positions).
    for (auto [x, y, z] : {std::tuple{d.x0, d.y0, d.z0}, std::tuple{d.x1, d.y1, d.z1}}) {
      double surf = s.height({x, y});
      if (!std::isfinite(surf)) surf = s.height({x + 35, y});
      ASSERT_TRUE(std::isfinite(surf)) << x << "," << y;
      const double k = (z - surf) / prm.layer_height;
      EXPECT_NEAR(k, std::round(k), 0.01 / prm.layer_height);
    }
  }
}

TEST(Nonplanar, DownFlowScalesSteepDescents) {
  Toolpath tp;
  tp.layers.emplace_back();
  Path p;
  p.points = {{0, 0, 5}, {10, 0, 5}, {11, 0, 5 - std::tan(60 * kDeg)}};  // flat, then 60° down
  tp.layers[0].paths.push_back(p);
  MachineProfile m = test::open_bed();
  m.relative_e = true;
  m.short_path_segments = 0;
  m.down_flow = "45,0.8; 80,0.6";
  const test::Replay r = test::replay_gcode(write_gcode(tp, m));
  ASSERT_EQ(r.deposits.size(), 2u);
  const double len0 = 10, len1 = 2;  // the steep move is 2 mm long
  EXPECT_NEAR((r.deposits[1].e / len1) / (r.deposits[0].e / len0), 0.8, 1e-3);
  // Pressure-driven: same flow, the nozzle moves faster by 1 / 0.8.
  m.flavor = Flavor::Pneumatic;
  const std::string nc = write_gcode(tp, m);
  EXPECT_NE(nc.find("F1200"), std::string::npos);  // 20 mm/s
  EXPECT_NE(nc.find("F1500"), std::string::npos);  // 20 / 0.8
  m.down_flow = "95,1";
  EXPECT_THROW(validate(m), SettingError);
}

// Every edge of a planar lattice, laid on a sphere cap and read back from the G-code, is
// deposited exactly once: deposits mapped back to XY cover each strut once, nothing else.
TEST(Nonplanar, ProjectedLatticeKeepsEveryEdgeOnce) {
  constexpr double kT = 1e-3;  // fraction of a strut: G-code rounding (1 µm) on 1-2 mm struts
  AtlasParams a;
  a.pattern = Pattern::Honeycomb;
  a.cell_size = 2;
  a.region.shape = RegionShape::Circle;
  a.region.diameter = 12;
  const Graph g = make_lattice2d(a);
  PlanParams pp;
  pp.planner = Planner::Euler;
  Diagnostics diag;
  Toolpath planar = plan_lattice(g, pp, diag).toolpath;
  // Three layers of the same lattice (as a multi-layer scaffold).
  for (int k = 1; k < 3; ++k) {
    Layer l = planar.layers[0];
    l.z += 0.148 * k;
    for (auto& path : l.paths)
      for (auto& q : path.points) q.z += 0.148 * k;
    planar.layers.push_back(l);
  }
  const HeightField cap = sphere_cap(12, 14);
  for (OffsetMode mode : {OffsetMode::Vertical, OffsetMode::Normal}) {
    SCOPED_TRACE(to_string(mode));
    ProjectParams prm;
    prm.offset = mode;
    const Toolpath on = project_onto_surface(planar, cap, prm);
    NonplanarParams check;
    check.layer_height = 0.148;
    check.offset = mode;
    const SurfaceDeviation dev = surface_deviation(on, cap, check);
    EXPECT_LE(dev.max_point, 0.01);
    EXPECT_LE(dev.max_chord, prm.chord_tolerance + 1e-4);
    MachineProfile m = test::open_bed();
    const test::Replay rep = test::replay_gcode(write_gcode(on, m));
    // Which layer a deposit belongs to: its height above the cap (vertical) or distance order.
    const std::size_t layers_checked = mode == OffsetMode::Vertical ? 3 : 1;
    for (std::size_t k = 0; k < layers_checked; ++k) {
      std::vector<std::vector<std::pair<double, double>>> cover(g.edges.size());
      double off_design = 0;
      for (const auto& d : rep.deposits) {
        const double mid_surface = cap.height({(d.x0 + d.x1) / 2, (d.y0 + d.y1) / 2});
        const double lift = (d.z0 + d.z1) / 2 - mid_surface;
        if (std::abs(lift - 0.148 * static_cast<double>(k)) > 0.05) continue;
        bool matched = false;
        for (std::size_t e = 0; e < g.edges.size() && !matched; ++e) {
          const Vec3 a3 = g.nodes[g.edges[e].a], b3 = g.nodes[g.edges[e].b];
          const Vec2 ab = b3.xy() - a3.xy();
          const double len2 = ab.x * ab.x + ab.y * ab.y;
          auto param = [&](double x, double y, double* off) {
            const Vec2 ap{x - a3.x, y - a3.y};
            *off = std::abs(ab.x * ap.y - ab.y * ap.x) / std::sqrt(len2);
            return (ap.x * ab.x + ap.y * ab.y) / len2;
          };
          double o0, o1;
          const double t0 = param(d.x0, d.y0, &o0), t1 = param(d.x1, d.y1, &o1);
          // G-code coordinates are rounded to 1 µm.
          if (o0 < 2e-3 && o1 < 2e-3 && t0 > -kT && t0 < 1 + kT && t1 > -kT && t1 < 1 + kT) {
            cover[e].push_back({std::min(t0, t1), std::max(t0, t1)});
            matched = true;
          }
        }
        if (!matched) off_design += std::hypot(d.x1 - d.x0, d.y1 - d.y0);
      }
      EXPECT_EQ(off_design, 0) << "layer " << k;
      for (std::size_t e = 0; e < g.edges.size(); ++e) {
        auto& c = cover[e];
        std::sort(c.begin(), c.end());
        double reach = 0, overlap = 0, gap = 0;
        for (const auto& [t0, t1] : c) {
          overlap += std::max(0.0, std::min(reach, t1) - t0);
          gap += std::max(0.0, t0 - reach);
          reach = std::max(reach, t1);
        }
        EXPECT_LT(gap, kT) << "edge " << e << " has a hole on layer " << k;
        EXPECT_FALSE(c.empty()) << "edge " << e << " missing on layer " << k;
        if (c.empty()) continue;
        EXPECT_NEAR(c.front().first, 0, kT) << "edge " << e;
        EXPECT_NEAR(reach, 1, kT) << "edge " << e;
        EXPECT_LT(overlap, kT) << "edge " << e << " deposited twice on layer " << k;
      }
    }
  }
  // Leaving the footprint is an error naming the place.
  EXPECT_THROW(project_onto_surface(planar, sphere_cap(12, 8), {}), GeometryError);
}

}  // namespace

#include <unistd.h>

#include "trellis/geom/mesh_io.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/job/job.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/toolpath/json.hpp"

namespace {

// Runs an example job into a fresh temporary folder with `sets` applied over it.
Job example_job(const std::string& file, const std::string& tag,
                const std::vector<std::string>& sets = {}) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("trellis_" + tag + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  Job job = load_job(std::string(TRELLIS_SOURCE_DIR) + "/examples/" + file, dir.string());
  for (const auto& s : sets)
    job.settings.set_text(s.substr(0, s.find('=')), s.substr(s.find('=') + 1), {"test"});
  job.gcode = job.preview = job.report = "";
  return job;
}

// GIPPO's per-layer infill: every strut of layer i lies in the solid's cross-section at that layer.
TEST(NonplanarJobs, SolidLayersAreCroppedToTheirCrossSections) {
  const Job job = example_job("concave_cylinder_honeycomb.toml", "solid", {"gippo.iterations=2"});
  Diagnostics d;
  run_job(job, d);
  Diagnostics d2;
  const Graph g = read_lattice(job.lattice, {}, d2);
  const Config c = job.settings.config();
  const TriangleMesh solid = read_mesh(c.layers.solid);
  const double h = c.machine.layer_height;
  EXPECT_DOUBLE_EQ(h, 0.148);  // the job's [extrusion] layer_height over the profile's
  std::set<long> layers;
  std::size_t checked = 0;
  for (const auto& e : g.edges) {
    const Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
    const long i = std::lround(a.z / h);
    layers.insert(i);
    const auto regions = slice_mesh(solid, solid_section_z(bounds(solid), static_cast<int>(i), h));
    const Vec2 mid = (a.xy() + b.xy()) * 0.5;
    bool inside = false;
    for (const auto& r : regions) inside = inside || contains(r, mid, 1e-6);
    EXPECT_TRUE(inside) << "strut at layer " << i << " leaves the cross-section";
    ++checked;
  }
  EXPECT_EQ(layers.size(), 28u);  // every started layer of 4 mm / 0.148 mm, as the paper prints
  EXPECT_GT(checked, 1000u);
}

TEST(NonplanarJobs, LatticeOnSphereFollowsItLayerByLayer) {
  const Job job = example_job("honeycomb_on_sphere.toml", "sphere", {"layers.count=4"});
  Diagnostics d;
  run_job(job, d);
  const Toolpath tp = read_toolpath(job.toolpath);
  ASSERT_EQ(tp.layers.size(), 4u);
  const Config c = job.settings.config();
  NonplanarParams check;
  check.layer_height = c.machine.layer_height;
  check.offset = OffsetMode::Normal;
  const SurfaceDeviation dev =
      surface_deviation(tp, sphere_cap(c.onto.radius, c.onto.diameter), check);
  EXPECT_LE(dev.max_point, 0.01);
  EXPECT_LE(dev.max_chord, c.onto.project.chord_tolerance + 1e-4);
}

}  // namespace

TEST(Nonplanar, SurfaceSpacingKeepsLinesOneWidthApartAlongTheSlope) {
  // The 45° corrugation, lines along Y (spaced in x): in the slicing planes they lie 0.4 mm
  // apart in x, 0.57 mm along the slopes; along the surface they lie 0.4 mm ± 5 % apart, measured
  // independently by integrating the profile z(x) between neighbouring lines.
  const CorrugationParams c;
  const HeightField surface = corrugation(c);
  const auto z = profile_function(corrugation_profile(c));
  auto along = [&](double x0, double x1) {
    double s = 0;
    const int n = 400;
    for (int i = 0; i < n; ++i) {
      const double a = x0 + (x1 - x0) * i / n, b = x0 + (x1 - x0) * (i + 1) / n;
      s += std::hypot(b - a, z(b) - z(a));
    }
    return s;
  };
  NonplanarParams prm;
  prm.width = 0.4;
  // Angle 90: lines along +Y, n = (-1, 0), so v = -x.
  prm.spacing_along_surface = true;
  std::vector<double> v = nonplanar_line_positions(surface, 90, prm);
  ASSERT_GT(v.size(), 50u);
  for (std::size_t i = 1; i < v.size(); ++i) {
    const double gap = along(-v[i - 1], -v[i]);
    EXPECT_NEAR(gap, prm.width, 0.05 * prm.width)
        << "between x = " << -v[i - 1] << " and " << -v[i];
  }
  prm.spacing_along_surface = false;
  v = nonplanar_line_positions(surface, 90, prm);
  double widest = 0;
  for (std::size_t i = 1; i < v.size(); ++i) widest = std::max(widest, along(-v[i - 1], -v[i]));
  EXPECT_GT(widest, 1.35 * prm.width);  // the planar spacing's limit, for contrast
  // The sliced layers follow: on the surface, one path per layer, the footprint covered.
  prm.spacing_along_surface = true;
  prm.layers = 2;
  const NonplanarResult r = slice_nonplanar(surface, prm);
  const SurfaceDeviation dev = surface_deviation(r.toolpath, surface, prm);
  EXPECT_LE(dev.max_point, 0.01);
  EXPECT_LE(dev.max_chord, prm.chord_tolerance + 1e-4);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(r.toolpath.layers[k].paths.size(), 1u) << "layer " << k;
    EXPECT_GE(footprint_coverage(r.toolpath, k, surface, prm.width, 0.04), 0.98) << "layer " << k;
  }
  // Along X (angle 0) the surface is level across the lines: the same lines as planar spacing.
  const auto a = nonplanar_line_positions(surface, 0, prm);
  prm.spacing_along_surface = false;
  const auto b = nonplanar_line_positions(surface, 0, prm);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-9);
}

namespace {

// The self-check's largest chord distance (found with pruning by upper bounds) equals a brute
// force: every chord midpoint's distance to the surface by dense sampling around it.
TEST(NonplanarCheck, PrunedChordDeviationEqualsBruteForce) {
  for (const HeightField& s : {corrugation(CorrugationParams{}), m_curve(MCurveParams{})}) {
    NonplanarParams prm;
    prm.layers = 2;
    prm.width = 1.0;  // fewer chords: the brute force stays quick
    prm.chord_tolerance = 0.02;
    const NonplanarResult r = slice_nonplanar(s, prm);
    const SurfaceDeviation dev = surface_deviation(r.toolpath, s, prm);
    auto f = s.evaluator();
    double brute = 0;
    for (std::size_t k = 0; k < r.toolpath.layers.size(); ++k)
      for (const auto& p : r.toolpath.layers[k].paths)
        for (std::size_t i = 1; i < p.points.size(); ++i) {
          const Vec3 m = (p.points[i - 1] + p.points[i]) * 0.5;
          const Vec3 q{m.x, m.y, m.z - static_cast<double>(k) * prm.layer_height};
          double best = 1e300;
          const double r0 = 0.08, step = 0.002;
          for (double dx = -r0; dx <= r0; dx += step)
            for (double dy = -r0; dy <= r0; dy += step) {
              const double z = f(q.x + dx, q.y + dy);
              if (std::isfinite(z)) best = std::min(best, std::hypot(dx, dy, z - q.z));
            }
          if (best < 1e299) brute = std::max(brute, best);
        }
    EXPECT_GT(brute, 0);
    // Sampling overestimates a distance by at most about half a step squared over it.
    EXPECT_NEAR(dev.max_chord, brute, 2e-4) << s.name();
  }
}

}  // namespace

// A height function with a jump (a raised disc) is split at the jump instead of bridged by a
// printed wall: no printed segment steeper than 80°, every chord on the surface, the jumps
// counted; a steep but continuous surface (tanh, 25:1 at its steepest) has no jump.
TEST(Nonplanar, JumpsSplitPathsInsteadOfBridgingThem) {
  NonplanarParams prm;
  prm.layers = 1;
  const HeightField step =
      HeightField::from_expression("x^2+y^2<4 ? 5 : 0", {{-5, -5}, {5, 5}}, "disc");
  const NonplanarResult r = slice_nonplanar(step, prm);
  std::size_t jumps = 0;
  for (const auto& l : r.layers) jumps += l.jumps;
  EXPECT_GE(jumps, 16u);
  double steepest = 0;
  for (const auto& l : r.toolpath.layers)
    for (const auto& p : l.paths)
      for (std::size_t i = 1; i < p.points.size(); ++i) {
        const Vec3 d = p.points[i] - p.points[i - 1];
        steepest = std::max(
            steepest, std::atan2(std::abs(d.z), std::hypot(d.x, d.y)) * 180 / 3.14159265358979);
      }
  EXPECT_LT(steepest, 80);
  EXPECT_LE(surface_deviation(r.toolpath, step, prm).max_chord, prm.chord_tolerance);
  const HeightField smooth =
      HeightField::from_expression("2.5*tanh(20*x)", {{-5, -5}, {5, 5}}, "tanh");
  const NonplanarResult s = slice_nonplanar(smooth, prm);
  for (const auto& l : s.layers) EXPECT_EQ(l.jumps, 0u);
}

// A straight step across the footprint splits every line that crosses it: the pieces on each
// side are one serpentine, and the layer crosses the step once (one travel), not once per line;
// every piece is still printed (the layer's length is that of the lines, same for any order).
TEST(Nonplanar, StepIsCrossedByOneTravelPerLayer) {
  NonplanarParams prm;
  prm.layers = 2;
  prm.angles = {0, 90};
  for (const char* expr : {"x < 0 ? 0 : 3", "x < 1.3 ? 2 : 0", "y < 0.5 ? 1 : 0"}) {
    const HeightField step = HeightField::from_expression(expr, {{-10, -5}, {10, 5}}, expr);
    const NonplanarResult r = slice_nonplanar(step, prm);
    for (const auto& l : r.layers) {
      EXPECT_LE(l.travel_moves, 1u) << expr << " at " << l.angle << " deg";
      EXPECT_EQ(l.paths, l.travel_moves + 1) << expr;
    }
    std::size_t jumps = 0;
    for (const auto& l : r.layers) jumps += l.jumps;
    EXPECT_GE(jumps, 10u) << expr;
    EXPECT_GE(footprint_coverage(r.toolpath, 0, step, prm.width, 0.02), 0.98) << expr;
    EXPECT_GE(footprint_coverage(r.toolpath, 1, step, prm.width, 0.02), 0.98) << expr;
    EXPECT_LE(surface_deviation(r.toolpath, step, prm).max_chord, prm.chord_tolerance) << expr;
  }
}

// A footprint with a hole: lines that meet the hole are joined around it along its edge (in the
// strip between neighbouring lines) instead of ending there, so a layer is a couple of paths,
// not one per piece; every point and chord stays on the surface.
TEST(Nonplanar, HolesAreJoinedAroundTheirEdge) {
  NonplanarParams prm;
  prm.layers = 2;
  prm.angles = {0, 90};
  const HeightField annulus =
      HeightField::from_expression("x^2+y^2<9 ? 0/0 : 0.1*x", {{-8, -8}, {8, 8}}, "annulus");
  const NonplanarResult r = slice_nonplanar(annulus, prm);
  for (const auto& l : r.layers) {
    EXPECT_LE(l.paths, 3u) << l.angle;
    EXPECT_GE(l.hole_joins, 10u) << l.angle;
  }
  const SurfaceDeviation dev = surface_deviation(r.toolpath, annulus, prm);
  EXPECT_LE(dev.max_point, 1e-6);
  EXPECT_LE(dev.max_chord, prm.chord_tolerance);
}

// A grid that would not fit in memory (an 8 TB allocation before), or whose count is beyond any
// integer, is refused naming surface.resolution before anything is allocated.
TEST(Nonplanar, AbsurdSurfaceGridIsRefusedWithItsSize) {
  auto flat = [](double w) {
    return HeightField::from_function([] { return [](double, double) { return 1.0; }; },
                                      {{0, 0}, {w, w}}, "flat");
  };
  EXPECT_GT(surface_mesh(flat(10), 0.5).triangles.size(), 0u);
  for (double resolution : {1e-4, 1e-300, std::numeric_limits<double>::denorm_min()}) {
    try {
      surface_mesh(flat(100), resolution);
      ADD_FAILURE() << "accepted resolution " << resolution;
    } catch (const ResourceError& e) {
      EXPECT_EQ(e.where().element, "surface.resolution");
      EXPECT_NE(std::string(e.what()).find("raise surface.resolution"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_THROW(surface_mesh(flat(10), std::numeric_limits<double>::infinity()), SettingError);
}
