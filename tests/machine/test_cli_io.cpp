// Laser build files: CLI written by Trellis (ASCII and binary, with CLI+ blocks) reads back into
// the same vectors; malformed files are refused with the byte offset of the problem.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/slice/pbf_lasers.hpp"

using namespace trellis;

namespace {

// Random layers: open contour polylines of 2–6 points and two-point hatch vectors, anywhere in
// ±60 mm, including negative and tiny coordinates.
Toolpath random_laser_toolpath(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-60, 60), small(-0.01, 0.01);
  std::uniform_int_distribution<int> count(0, 30), pts(2, 6), coin(0, 9);
  Toolpath tp;
  for (int i = 0; i < 12; ++i) {
    Layer l;
    l.z = 0.02 * (i + 1);
    const int n = count(rng);
    for (int k = 0; k < n; ++k) {
      Path p;
      p.role = coin(rng) < 5 ? PathRole::Contour : PathRole::Hatch;
      const int m = p.role == PathRole::Hatch ? 2 : pts(rng);
      for (int j = 0; j < m; ++j) {
        const bool tiny = coin(rng) == 0;
        p.points.push_back({tiny ? small(rng) : xy(rng), tiny ? small(rng) : xy(rng), l.z});
      }
      l.paths.push_back(std::move(p));
    }
    tp.layers.push_back(std::move(l));
  }
  return tp;
}

// The writer puts each layer's contours first, then its hatches: compare in that order.
std::vector<const Path*> in_file_order(const Layer& l) {
  std::vector<const Path*> out;
  for (const auto& p : l.paths)
    if (!(p.role == PathRole::Hatch && p.points.size() == 2)) out.push_back(&p);
  for (const auto& p : l.paths)
    if (p.role == PathRole::Hatch && p.points.size() == 2) out.push_back(&p);
  return out;
}

TEST(CliIo, AsciiAndBinaryRoundTripWithin1Micrometre) {
  LaserProfile prof;
  prof.contour_power = 55;
  prof.contour_speed = 700;
  prof.hatch_power = 120;
  prof.hatch_speed = 1100;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Toolpath tp = random_laser_toolpath(seed);
    for (const bool binary : {false, true}) {
      const std::string bytes = write_cli(tp, prof, {binary, true});
      const Toolpath back = read_cli(bytes, "mem.cli");
      ASSERT_EQ(back.layers.size(), tp.layers.size());
      for (std::size_t i = 0; i < tp.layers.size(); ++i) {
        EXPECT_NEAR(back.layers[i].z, tp.layers[i].z, 1e-3);
        const auto want = in_file_order(tp.layers[i]);
        ASSERT_EQ(back.layers[i].paths.size(), want.size()) << "layer " << i;
        for (std::size_t k = 0; k < want.size(); ++k) {
          const Path& got = back.layers[i].paths[k];
          EXPECT_EQ(got.role, want[k]->role);
          ASSERT_EQ(got.points.size(), want[k]->points.size());
          for (std::size_t j = 0; j < got.points.size(); ++j) {
            EXPECT_NEAR(got.points[j].x, want[k]->points[j].x, 1e-3);
            EXPECT_NEAR(got.points[j].y, want[k]->points[j].y, 1e-3);
          }
          // CLI+: the profile's power and speed per id.
          const bool hatch = got.role == PathRole::Hatch;
          EXPECT_EQ(got.power, hatch ? 120 : 55);
          EXPECT_EQ(got.speed, hatch ? 1100 : 700);
        }
      }
    }
  }
}

// Each broken file is refused with a ParseError naming the file and the byte offset where the
// problem starts.
TEST(CliIo, MalformedFilesNameTheOffset) {
  const std::string head = "$$HEADERSTART\n$$ASCII\n$$UNITS/0.001\n$$HEADEREND\n$$GEOMETRYSTART\n";
  struct Case {
    std::string text, at;  // `at`: the text the reported offset must point to
  };
  const std::vector<Case> cases = {
      {"no header here", ""},
      {head + "$$LAYER/20\n$$POLYLINE/1,2,2,0,0,1x0,5\n$$GEOMETRYEND\n", "1x0,5"},
      {head + "$$LAYER/20\n$$POLYLINE/1,2,3,0,0,10,5\n$$GEOMETRYEND\n", "$$POLYLINE/1,2,3"},
      {head + "$$POLYLINE/1,2,2,0,0,10,5\n$$GEOMETRYEND\n", "$$POLYLINE"},
      {head + "$$LAYER/40\n$$LAYER/20\n$$GEOMETRYEND\n", "$$LAYER/20"},
      {head + "$$LAYER/20\n$$HATCHES/2,1,0,0,1\n$$GEOMETRYEND\n", "$$HATCHES"},
      {head + "$$LAYER/20\n$$HATCHES/2,1,0,0,1,nan\n$$GEOMETRYEND\n", "nan"},
      {head + "$$LAYER/20\n", ""},
      {head + "LAYER/20\n$$GEOMETRYEND\n", "LAYER/20"},
      {head + "$$LAYER/20\n$$POLYLINE/1e38,2,2,0,0,10,5\n$$GEOMETRYEND\n", "$$POLYLINE/1e38"},
      {head + "$$LAYER/20\n$$HATCHES/1,1.5,0,0,1,1\n$$GEOMETRYEND\n", "$$HATCHES/1,1.5"},
      // $$UNITS beyond 1000 mm per unit, and coordinates beyond ±1e6 mm once scaled.
      {"$$HEADERSTART\n$$ASCII\n$$UNITS/1e300\n$$HEADEREND\n$$GEOMETRYSTART\n$$LAYER/1\n"
       "$$POLYLINE/1,2,2,0,0,1,5\n$$GEOMETRYEND\n",
       "1e300\n$$HEADEREND"},
      {"$$HEADERSTART\n$$ASCII\n$$UNITS/1\n$$HEADEREND\n$$GEOMETRYSTART\n$$LAYER/1\n"
       "$$POLYLINE/1,2,2,0,0,2e6,5\n$$GEOMETRYEND\n",
       "$$POLYLINE/1,2,2,0,0,2e6"},
      {"$$HEADERSTART\n$$ASCII\n$$UNITS/1\n$$HEADEREND\n$$GEOMETRYSTART\n$$LAYER/3e6\n"
       "$$POLYLINE/1,2,2,0,0,2,5\n$$GEOMETRYEND\n",
       "$$LAYER/3e6"},
  };
  for (const auto& c : cases) {
    try {
      read_cli(c.text, "bad.cli");
      ADD_FAILURE() << "accepted: " << c.text;
    } catch (const ParseError& e) {
      EXPECT_EQ(e.where().file, "bad.cli");
      const std::size_t want =
          c.at.empty() ? (c.text.find("$$HEADERSTART") == std::string::npos ? 0 : c.text.size())
                       : c.text.find(c.at);
      EXPECT_NE(std::string(e.what()).find("offset " + std::to_string(want)), std::string::npos)
          << e.what() << " / expected offset " << want;
    }
  }
  // Binary: an unknown command, a count larger than the file, a file cut inside a command.
  const std::string bhead = "$$HEADERSTART\n$$BINARY\n$$UNITS/0.001\n$$HEADEREND";
  auto u16 = [](std::uint16_t v) { return std::string(reinterpret_cast<const char*>(&v), 2); };
  auto i32 = [](std::int32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  auto f32 = [](float v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  const std::string layer = u16(127) + f32(20);
  const std::vector<std::pair<std::string, std::size_t>> bins = {
      {bhead + layer + u16(99), bhead.size() + layer.size()},
      {bhead + layer + u16(132) + i32(2) + i32(1000000) + f32(1), bhead.size() + layer.size()},
      {bhead + layer + u16(130) + i32(1) + i32(2) + i32(2) + f32(0) + f32(0) + f32(1),
       bhead.size() + layer.size()},
      {bhead + u16(132) + i32(2) + i32(1) + f32(0) + f32(0) + f32(1) + f32(1), bhead.size()},
  };
  for (const auto& [bytes, want] : bins) {
    try {
      read_cli(bytes, "bad.cli");
      ADD_FAILURE() << "binary case accepted";
    } catch (const ParseError& e) {
      EXPECT_NE(std::string(e.what()).find("offset " + std::to_string(want)), std::string::npos)
          << e.what() << " / expected offset " << want;
    }
  }
}

// Another tool's CLI: short binary commands and $$UNITS other than 1 µm, ids without CLI+
// blocks (roles from the command and the $$LABEL text).
TEST(CliIo, ReadsShortBinaryCommandsAndOtherUnits) {
  auto u16 = [](std::uint16_t v) { return std::string(reinterpret_cast<const char*>(&v), 2); };
  std::string f = "$$HEADERSTART\n$$BINARY\n$$UNITS/0.01\n$$LABEL/3,part hatch\n$$HEADEREND\n";
  f += u16(128) + u16(5);  // layer z = 0.05 mm
  f += u16(129) + u16(1) + u16(0) + u16(3) + u16(0) + u16(0) + u16(100) + u16(0) + u16(100) +
       u16(100);                                                            // contour, 3 points
  f += u16(131) + u16(3) + u16(1) + u16(10) + u16(20) + u16(30) + u16(40);  // one hatch
  const Toolpath tp = read_cli(f, "short.cli");
  ASSERT_EQ(tp.layers.size(), 1u);
  EXPECT_NEAR(tp.layers[0].z, 0.05, 1e-12);
  ASSERT_EQ(tp.layers[0].paths.size(), 2u);
  EXPECT_EQ(tp.layers[0].paths[0].role, PathRole::Contour);
  EXPECT_NEAR(tp.layers[0].paths[0].points[2].y, 1.0, 1e-12);
  EXPECT_EQ(tp.layers[0].paths[1].role, PathRole::Hatch);
  EXPECT_NEAR(tp.layers[0].paths[1].points[1].x, 0.3, 1e-12);
}

}  // namespace

// Several lasers: each path's laser (Path::tool) is written as its block's id and read back,
// ASCII and binary, with and without CLI+ blocks (then from the ids' labels alone); a plate's
// parts keep theirs too.
TEST(CliIo, LaserIdsRoundTrip) {
  LaserProfile prof;
  prof.lasers = 3;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    Toolpath tp = random_laser_toolpath(seed);
    std::mt19937 rng(seed);
    for (auto& l : tp.layers)
      for (auto& p : l.paths) p.tool = static_cast<int>(rng() % 3);
    if (seed % 2 == 0) {
      tp.part_labels = {"a", "b"};
      for (auto& l : tp.layers)
        for (auto& p : l.paths) p.part = 1 + static_cast<int>(rng() % 2);
    }
    for (const bool binary : {false, true})
      for (const bool plus : {false, true}) {
        const Toolpath back = read_cli(write_cli(tp, prof, {binary, plus}), "mem.cli");
        ASSERT_EQ(back.layers.size(), tp.layers.size());
        for (std::size_t i = 0; i < tp.layers.size(); ++i) {
          // In the file: per part, per laser, its contours then its hatches.
          std::vector<const Path*> want;
          const int parts = static_cast<int>(tp.part_labels.size());
          for (int part = parts ? 1 : 0; part <= parts; ++part)
            for (int laser = 0; laser < 3; ++laser)
              for (const Path* p : in_file_order(tp.layers[i]))
                if (p->tool == laser && p->part == part) want.push_back(p);
          ASSERT_EQ(back.layers[i].paths.size(), want.size());
          for (std::size_t k = 0; k < want.size(); ++k) {
            const Path& got = back.layers[i].paths[k];
            EXPECT_EQ(got.tool, want[k]->tool)
                << "seed " << seed << " layer " << i << " path " << k;
            EXPECT_EQ(got.role, want[k]->role);
            ASSERT_EQ(got.points.size(), want[k]->points.size());
            EXPECT_NEAR(got.points[0].x, want[k]->points[0].x, 1e-3);
          }
        }
      }
  }
}

namespace {

// A twin-laser machine whose lasers differ in every per-laser value ([lasers]).
LaserProfile unequal_lasers() {
  LaserProfile prof;
  prof.lasers = 2;
  LaserProfile::PerLaser& e = prof.each;
  e.contour_power = {60, 45.5}, e.contour_speed = {900, 600};
  e.hatch_power = {200, 150}, e.hatch_speed = {1200, 700.25};
  e.spot_diameter = {0.03, 0.055}, e.jump_speed = {6000, 4000};
  e.jump_delay = {200, 310}, e.mark_delay = {90.5, 130}, e.polygon_delay = {40, 60};
  e.laser_on_delay = {0, 12}, e.laser_off_delay = {5, 0};
  return prof;
}

// Paths on random lasers at their laser's contour or hatch power and speed, as pbf exposes them.
Toolpath on_unequal_lasers(unsigned seed, const LaserProfile& prof) {
  Toolpath tp = random_laser_toolpath(seed);
  const std::vector<LaserParameters> each = laser_parameters(prof);
  std::mt19937 rng(seed);
  for (auto& l : tp.layers)
    for (auto& p : l.paths) {
      p.tool = static_cast<int>(rng() % each.size());
      const LaserParameters& L = each[static_cast<std::size_t>(p.tool)];
      const bool hatch = p.role == PathRole::Hatch;
      p.power = hatch ? L.hatch_power : L.contour_power;
      p.speed = hatch ? L.hatch_speed : L.contour_speed;
    }
  return tp;
}

}  // namespace

// Lasers that differ: each laser's parameters are in the header and read back exactly
// (Toolpath::lasers), each path's laser, power and speed too (CLI+), and the lasers' times of
// the file read back are those of the toolpath written.
TEST(CliIo, LasersThatDifferReadBackWithTheirParameters) {
  const LaserProfile prof = unequal_lasers();
  const std::vector<LaserParameters> each = laser_parameters(prof);
  ASSERT_NE(each[0], each[1]);
  std::vector<ScanTiming> timings;
  for (const auto& l : each) timings.push_back(l.timing);
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const Toolpath tp = on_unequal_lasers(seed, prof);
    for (const bool binary : {false, true})
      for (const bool plus : {false, true}) {
        const Toolpath back = read_cli(write_cli(tp, prof, {binary, plus}), "mem.cli");
        EXPECT_EQ(back.lasers, each) << "binary " << binary << " plus " << plus;
        if (!plus) continue;
        ASSERT_EQ(back.layers.size(), tp.layers.size());
        for (std::size_t i = 0; i < tp.layers.size(); ++i) {
          const auto want = in_file_order(tp.layers[i]);
          std::vector<const Path*> sorted;  // in the file: laser by laser
          for (int laser = 0; laser < 2; ++laser)
            for (const Path* p : want)
              if (p->tool == laser) sorted.push_back(p);
          ASSERT_EQ(back.layers[i].paths.size(), sorted.size());
          for (std::size_t k = 0; k < sorted.size(); ++k) {
            const Path& got = back.layers[i].paths[k];
            EXPECT_EQ(got.tool, sorted[k]->tool) << "layer " << i << " path " << k;
            EXPECT_EQ(got.power, sorted[k]->power) << "layer " << i << " path " << k;
            EXPECT_EQ(got.speed, sorted[k]->speed) << "layer " << i << " path " << k;
          }
        }
        // The times `trellis analyze` reports from the file's own lasers.
        std::vector<ScanTiming> read;
        for (const auto& l : back.lasers) read.push_back(l.timing);
        EXPECT_EQ(laser_times(back, read).totals().size(), 2u);
        EXPECT_NEAR(laser_times(back, read).build_seconds(),
                    laser_times(back, timings).build_seconds(), 1e-12);
      }
  }
  // Lasers that do not differ: no laser lines, nothing read back.
  LaserProfile same;
  same.lasers = 2;
  EXPECT_TRUE(
      read_cli(write_cli(random_laser_toolpath(1), same, {false, true}), "m.cli").lasers.empty());
}

// A [lasers] list of another length than laser.lasers is refused, naming its key.
TEST(CliIo, PerLaserListsOfTheWrongLengthAreRefusedByName) {
  for (const char* key : {"lasers.hatch_speed", "lasers.spot_diameter", "lasers.mark_delay"}) {
    LaserProfile prof = unequal_lasers();
    std::vector<double>& list = std::string(key) == "lasers.hatch_speed" ? prof.each.hatch_speed
                                : std::string(key) == "lasers.spot_diameter"
                                    ? prof.each.spot_diameter
                                    : prof.each.mark_delay;
    list.push_back(list.back());
    try {
      laser_parameters(prof);
      FAIL() << key << " with 3 values for 2 lasers was taken";
    } catch (const SettingError& e) {
      EXPECT_EQ(e.where().element, key);
      EXPECT_NE(std::string(e.what()).find("3 values for 2 laser(s)"), std::string::npos)
          << e.what();
    }
    EXPECT_THROW(write_cli(random_laser_toolpath(1), prof), SettingError) << key;
  }
}

// One laser: no laser in any label, the ids of a single-laser machine.
TEST(CliIo, OneLaserNamesNoLaser) {
  const std::string bytes = write_cli(random_laser_toolpath(2), LaserProfile{}, {false, true});
  EXPECT_EQ(bytes.find("laser 1"), std::string::npos);
  EXPECT_EQ(bytes.find("LASER="), std::string::npos);
  EXPECT_NE(bytes.find("$$LABEL/1,contour\n$$LABEL/2,hatch\n"), std::string::npos);
}
