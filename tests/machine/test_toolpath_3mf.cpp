// 3MF packages with the Toolpath Extension: random laser and deposition toolpaths (planar and
// 3-axis, with every value a path carries) read back as written — order, roles, values, parts,
// planned travel — with coordinates on the 10 nm grid; the same toolpath makes the same bytes.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/toolpath_3mf.hpp"

using namespace trellis;

namespace {

double on_grid(double mm) {
  return std::round(mm / 1e-5) * 1e-5;
}

Toolpath random_toolpath(unsigned seed, bool laser, bool nonplanar) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-80, 80), unit(0, 1);
  std::uniform_int_distribution<int> count(0, 25), pts(2, 7), coin(0, 9);
  Toolpath tp;
  tp.source = "test & <source> \"quoted\"";
  tp.job = "[job]\nroute = \"slice\"\n# a < b & c\n";
  if (seed % 2) tp.part_labels = {"left", "right part"};
  for (int i = 0; i < 10; ++i) {
    Layer l;
    l.z = 0.03 * (i + 1);
    const int n = count(rng);
    for (int k = 0; k < n; ++k) {
      Path p;
      if (laser) {
        p.role = coin(rng) < 5 ? PathRole::Contour : PathRole::Hatch;
        p.power = coin(rng) < 5 ? 60 : 117.5;
        p.speed = coin(rng) < 5 ? 800 : 1234.5;
      } else {
        p.role = static_cast<PathRole>(coin(rng) % kPathRoleCount);
        p.tool = coin(rng) % 3;
        p.width = coin(rng) < 3 ? 0 : 0.4 + 0.01 * coin(rng);
        p.height = coin(rng) < 3 ? 0 : 0.2;
        p.speed = coin(rng) < 2 ? 0 : 20 + coin(rng);
        if (coin(rng) == 0) p.mixture = {0.25, 0.75};
        if (coin(rng) < 2) p.temperature = 205;
        if (coin(rng) < 2) p.flow = 1.05;
        if (coin(rng) < 2) p.fan = 40;
        if (coin(rng) < 3) p.filament = unit(rng) * 10;
        p.joined = coin(rng) == 0;
        p.inside = coin(rng) < 3;
        if (coin(rng) < 2) p.via = {{xy(rng), xy(rng), l.z}, {xy(rng), xy(rng), l.z + 0.5}};
      }
      if (!tp.part_labels.empty()) p.part = coin(rng) % 3;
      const int m = p.role == PathRole::Hatch ? 2 : pts(rng);
      for (int j = 0; j < m; ++j)
        p.points.push_back({xy(rng), xy(rng), nonplanar ? l.z + unit(rng) : l.z});
      if (m >= 4 && coin(rng) < 3) p.points.back() = p.points.front();  // a closed contour
      l.paths.push_back(std::move(p));
    }
    tp.layers.push_back(std::move(l));
  }
  return tp;
}

void expect_same(const Toolpath& a, const Toolpath& b, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(b.source, a.source);
  EXPECT_EQ(b.job, a.job);
  EXPECT_EQ(b.part_labels, a.part_labels);
  ASSERT_EQ(b.layers.size(), a.layers.size());
  for (std::size_t i = 0; i < a.layers.size(); ++i) {
    const Layer& la = a.layers[i];
    const Layer& lb = b.layers[i];
    EXPECT_NEAR(lb.z, la.z, 1e-9);
    ASSERT_EQ(lb.paths.size(), la.paths.size()) << "layer " << i;
    for (std::size_t j = 0; j < la.paths.size(); ++j) {
      const Path& p = la.paths[j];
      const Path& q = lb.paths[j];
      SCOPED_TRACE("layer " + std::to_string(i) + " path " + std::to_string(j));
      EXPECT_EQ(q.role, p.role);
      EXPECT_EQ(q.tool, p.tool);
      EXPECT_EQ(q.mixture, p.mixture);
      EXPECT_EQ(q.width, p.width);
      EXPECT_EQ(q.height, p.height);
      EXPECT_EQ(q.speed, p.speed);
      EXPECT_EQ(q.power, p.power);
      EXPECT_EQ(q.filament, p.filament);
      EXPECT_EQ(q.temperature, p.temperature);
      EXPECT_EQ(q.flow, p.flow);
      EXPECT_EQ(q.fan, p.fan);
      EXPECT_EQ(q.joined, p.joined);
      EXPECT_EQ(q.inside, p.inside);
      EXPECT_EQ(q.part, p.part);
      ASSERT_EQ(q.points.size(), p.points.size());
      for (std::size_t k = 0; k < p.points.size(); ++k) {
        EXPECT_NEAR(q.points[k].x, on_grid(p.points[k].x), 1e-9);
        EXPECT_NEAR(q.points[k].y, on_grid(p.points[k].y), 1e-9);
        EXPECT_NEAR(q.points[k].z, on_grid(p.points[k].z), 1e-9);
      }
      ASSERT_EQ(q.via.size(), p.via.size());
      for (std::size_t k = 0; k < p.via.size(); ++k)
        EXPECT_NEAR(distance(q.via[k], p.via[k]), 0, 2e-5);
    }
  }
}

Toolpath round_trip(const Toolpath& tp, const Toolpath3mfOptions& o, const test::TempDir& dir,
                    const std::string& name) {
  const std::string path = dir.file(name);
  write_toolpath_3mf_file(path, tp, o);
  return read_toolpath_3mf_file(path);
}

}  // namespace

TEST(Toolpath3mf, LaserToolpathsReadBackAsWritten) {
  test::TempDir dir;
  LaserProfile laser;
  Toolpath3mfOptions o;
  o.laser = &laser;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const Toolpath tp = random_toolpath(seed, true, false);
    const std::string path = dir.file("laser.3mf");
    write_toolpath_3mf_file(path, tp, o);
    EXPECT_EQ(toolpath_3mf_kind(path), Toolpath3mfKind::Laser);
    expect_same(tp, read_toolpath_3mf_file(path), "laser seed " + std::to_string(seed));
  }
}

TEST(Toolpath3mf, DepositionToolpathsPlanarAndThreeAxisReadBackAsWritten) {
  test::TempDir dir;
  for (unsigned seed = 1; seed <= 4; ++seed)
    for (bool nonplanar : {false, true}) {
      const Toolpath tp = random_toolpath(seed, false, nonplanar);
      const std::string path = dir.file("deposition.3mf");
      write_toolpath_3mf_file(path, tp, {});
      EXPECT_EQ(toolpath_3mf_kind(path), Toolpath3mfKind::Deposition);
      expect_same(tp, read_toolpath_3mf_file(path),
                  std::string(nonplanar ? "3-axis" : "planar") + " seed " + std::to_string(seed));
    }
}

TEST(Toolpath3mf, SameToolpathSameBytes) {
  LaserProfile laser;
  Toolpath3mfOptions o;
  o.laser = &laser;
  const Toolpath tp = random_toolpath(7, true, false);
  const std::string a = write_toolpath_3mf(tp, o), b = write_toolpath_3mf(tp, o);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, write_toolpath_3mf(random_toolpath(8, true, false), o));
}

TEST(Toolpath3mf, MeshIsTheBuildItem) {
  test::TempDir dir;
  TriangleMesh mesh;
  mesh.add_prism({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, 0, 5);
  Toolpath3mfOptions o;
  o.mesh = &mesh;
  const Toolpath tp = random_toolpath(3, false, false);
  expect_same(tp, round_trip(tp, o, dir, "mesh.3mf"), "with a mesh");
}

// The geometry the toolpath's parts name (Part II §1.1.1) does not change what reads back: a
// strut lattice as beams (with the design's mesh, or alone), and, for a plate's parts, the beads
// they print. Beams the Beam Lattice Extension cannot hold are refused, naming the beam.
TEST(Toolpath3mf, LatticeAndBeadsAreBuildItemsAndTheToolpathReadsBackTheSame) {
  test::TempDir dir;
  BeamLattice3mf lattice;
  lattice.vertices = {{0, 0, 0}, {10, 0, 0}, {10, 10, 5}, {0, 10, 5}};
  lattice.beams = {{0, 1, 0.2, 0.2, 0}, {1, 2, 0.2, 0.3, 1}, {2, 3, 0.25, 0.25, 0}};
  TriangleMesh mesh;
  mesh.add_prism({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, 0, 5);
  for (unsigned seed = 1; seed <= 4; ++seed)  // odd seeds: a plate of two labelled parts
    for (bool with_mesh : {false, true}) {
      Toolpath3mfOptions o;
      o.lattice = &lattice;
      o.mesh = with_mesh ? &mesh : nullptr;
      o.bead_width = 0.4;
      const Toolpath tp = random_toolpath(seed, false, seed > 2);
      const std::string what = "seed " + std::to_string(seed) + (with_mesh ? " with a mesh" : "");
      const std::string bytes = write_toolpath_3mf(tp, o);
      EXPECT_EQ(bytes, write_toolpath_3mf(tp, o)) << what;
      expect_same(tp, round_trip(tp, o, dir, "lattice.3mf"), what);
    }
  Toolpath3mfOptions o;
  o.lattice = &lattice;
  const Toolpath tp = random_toolpath(2, false, false);
  for (const BeamLattice3mf::Beam bad :
       {BeamLattice3mf::Beam{1, 1, 0.2, 0.2, 0}, BeamLattice3mf::Beam{0, 4, 0.2, 0.2, 0},
        BeamLattice3mf::Beam{0, 1, 0, 0.2, 0}}) {
    BeamLattice3mf l = lattice;
    l.beams.push_back(bad);
    o.lattice = &l;
    try {
      write_toolpath_3mf(tp, o);
      ADD_FAILURE() << "wrote beam " << bad.v1 << "-" << bad.v2 << " r " << bad.r1;
    } catch (const GeometryError& e) {
      EXPECT_NE(std::string(e.what()).find("beam 3"), std::string::npos) << e.what();
    }
  }
}

TEST(Toolpath3mf, RefusesWhatItCannotWrite) {
  Toolpath tp;
  tp.layers.push_back({0.2, {}});
  Path p;
  p.points = {{0, 0, 0.2}, {3e4, 0, 0.2}};  // 30 m
  tp.layers[0].paths.push_back(p);
  EXPECT_THROW(write_toolpath_3mf(tp, {}), GeometryError);
  tp.layers[0].paths[0].points = {{0, 0, 0.2}};
  EXPECT_THROW(write_toolpath_3mf(tp, {}), GeometryError);
}

TEST(Toolpath3mf, NotAPackageIsRefusedNamingTheFile) {
  test::TempDir dir;
  const std::string path = dir.file("text.3mf");
  std::ofstream(path) << "not a zip";
  EXPECT_EQ(toolpath_3mf_kind(path), Toolpath3mfKind::None);
  try {
    read_toolpath_3mf_file(path);
    FAIL() << "read a text file as a package";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.where().file, path);
  }
}

// Several lasers: each laser path's laser (Path::tool) is its profile's laserindex (§4.5), one
// <tp:lasersource> per laser with its field, and reads back as written.
TEST(Toolpath3mf, LaserIndicesRoundTrip) {
  test::TempDir dir;
  LaserProfile laser;
  laser.lasers = 3;
  laser.fields = {0, 0, 40, 50, 30, 0, 70, 50, 60, 0, 100, 50};
  Toolpath3mfOptions o;
  o.laser = &laser;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    Toolpath tp = random_toolpath(seed, true, false);
    std::mt19937 rng(seed);
    for (auto& l : tp.layers)
      for (auto& p : l.paths) p.tool = static_cast<int>(rng() % 3);
    expect_same(tp, round_trip(tp, o, dir, "lasers.3mf"), "lasers seed " + std::to_string(seed));
  }
}

// Lasers that differ ([lasers]): each profile carries its laser's spot radius and jump speed
// (§4.1), our toolpath data every per-laser value (§4.4), read back exactly (Toolpath::lasers);
// paths keep their laser, power and speed.
TEST(Toolpath3mf, LasersThatDifferReadBackWithTheirParameters) {
  test::TempDir dir;
  LaserProfile laser;
  laser.lasers = 2;
  laser.each.hatch_power = {200, 150}, laser.each.hatch_speed = {1200, 700.25};
  laser.each.spot_diameter = {0.03, 0.055}, laser.each.jump_speed = {6000, 4000};
  laser.each.mark_delay = {90.5, 130}, laser.each.laser_off_delay = {5, 0};
  const std::vector<LaserParameters> each = laser_parameters(laser);
  Toolpath3mfOptions o;
  o.laser = &laser;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    Toolpath tp = random_toolpath(seed, true, false);
    std::mt19937 rng(seed);
    for (auto& l : tp.layers)
      for (auto& p : l.paths) {
        p.tool = static_cast<int>(rng() % 2);
        p.power = each[static_cast<std::size_t>(p.tool)].hatch_power;
      }
    const Toolpath back = round_trip(tp, o, dir, "unequal.3mf");
    expect_same(tp, back, "unequal lasers seed " + std::to_string(seed));
    EXPECT_EQ(back.lasers, each);
    // Written again from what was read (no profile lasers): the same lasers.
    Toolpath3mfOptions plain;
    EXPECT_EQ(round_trip(back, plain, dir, "again.3mf").lasers, each);
  }
  // Each laser's profiles name its own spot radius and jump speed.
  const std::string path = dir.file("unequal.3mf"), model = dir.file("model.xml");
  const std::string cmd =
      "/usr/bin/python3 -c \"import sys, zipfile; sys.stdout.buffer.write("
      "zipfile.ZipFile('" +
      path + "').read('3D/3dmodel.model'))\" > " + model;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(model);
  const std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* want : {"jumpspeed=\"6000\" spotradius=\"0.015\" laserindex=\"0\"",
                           "jumpspeed=\"4000\" spotradius=\"0.0275\" laserindex=\"1\""})
    EXPECT_NE(xml.find(want), std::string::npos) << want;
  // Equal lasers: no laser data.
  LaserProfile same;
  same.lasers = 2;
  o.laser = &same;
  EXPECT_TRUE(round_trip(random_toolpath(1, true, false), o, dir, "same.3mf").lasers.empty());
}
