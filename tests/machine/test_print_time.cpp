// The print-time estimate (machine/print_time.hpp) against what trapezoids, corners, dwells and
// heaters must give, and the writer's estimate against the file it wrote read back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <utility>

#include "support/machines.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/print_time.hpp"

using namespace trellis;

namespace {

MotionLimits accel(double a, double jerk) {
  MotionLimits l;
  l.acceleration = a;
  l.jerk = {jerk, jerk, jerk, jerk};
  return l;
}

// A tiny jerk: every move starts and ends (almost) at rest.
constexpr double kStop = 1e-9;

// The estimate a reader makes of a whole file: seconds, and heating seconds within them.
std::pair<double, double> read_back_time(const std::string& gcode) {
  PrintTimeSink sink;
  Diagnostics d;
  GcodeScanner s(sink, {}, d);
  s.feed(gcode);
  s.finish();
  return {sink.time.seconds(), sink.time.heating_s()};
}

double time_of(const std::string& gcode, const MotionLimits& limits = {}) {
  Diagnostics d;
  GcodeReadOptions o;
  o.limits = limits;
  PrintTimeSink sink;
  GcodeScanner s(sink, o, d);
  s.feed(gcode);
  s.finish();
  EXPECT_EQ(d.total(), 0u) << gcode;
  return sink.time.seconds();
}

}  // namespace

TEST(PrintTime, OneMoveIsATrapezoidOrATriangle) {
  PrintTimeEstimator t(accel(100, kStop));
  t.move({0, 0, 0}, {10, 0, 0}, 0, 10);  // ramps of 0.5 mm: cruise 0.9 s + 2 x 0.1 s
  EXPECT_NEAR(t.seconds(), 1.1, 1e-6);
  PrintTimeEstimator u(accel(100, kStop));
  u.move({0, 0, 0}, {0.25, 0, 0}, 0, 10);  // never reaches the feed: 2 sqrt(d / a)
  EXPECT_NEAR(u.seconds(), 0.1, 1e-6);
  PrintTimeEstimator feeds_only;  // acceleration 0
  feeds_only.move({0, 0, 0}, {10, 0, 0}, 0, 10);
  EXPECT_DOUBLE_EQ(feeds_only.seconds(), 1.0);
}

// A straight line cut into many pieces takes the time of the line: the look-ahead keeps the
// speed through joints that do not turn, whatever the jerk.
TEST(PrintTime, PiecesOfAStraightLineKeepTheirSpeed) {
  for (const double pieces : {1.0, 7.0, 1000.0, 5000.0}) {
    PrintTimeEstimator t(accel(500, kStop));
    for (int k = 0; k < pieces; ++k)
      t.move({100 * k / pieces, 0, 0}, {100 * (k + 1) / pieces, 0, 0}, 0, 50);
    EXPECT_NEAR(t.seconds(), 100.0 / 50 + 50.0 / 500, 1e-6) << pieces;
  }
}

// Corners: a square's sides stop at every corner when the jerk is tiny, and keep the feed
// through them when it is large; a real jerk lies between.
TEST(PrintTime, CornersCostWhatTheJerkAllows) {
  auto square = [](double jerk) {
    PrintTimeEstimator t(accel(200, jerk));
    const Vec3 c[] = {{0, 0, 0}, {20, 0, 0}, {20, 20, 0}, {0, 20, 0}, {0, 0, 0}};
    for (int k = 0; k < 4; ++k) t.move(c[k], c[k + 1], 0, 40);
    return t.seconds();
  };
  const double side = 20.0 / 40 + 40.0 / 200;  // one side from rest to rest
  EXPECT_NEAR(square(kStop), 4 * side, 1e-6);
  EXPECT_NEAR(square(1e6), 80.0 / 40, 1e-6);  // any speed change at once: no ramps at all
  // A jerk of 10 mm/s starts and stops at 10 mm/s and turns the corners at 10 mm/s per axis.
  EXPECT_LT(square(10), 4 * side);
  EXPECT_GT(square(10), 80.0 / 40);
}

TEST(PrintTime, DwellsAndHeaterWaitsCount) {
  EXPECT_NEAR(time_of("G1 X10 F600\nG4 P500\nG4 S2\n"), 1 + 0.5 + 2, 1e-9);
  // From ambient: the nozzle at kNozzleRate, the bed at kBedRate.
  const double a = PrintTimeEstimator::kAmbient;
  EXPECT_NEAR(time_of("M109 S205\n"), (205 - a) / PrintTimeEstimator::kNozzleRate, 1e-9);
  EXPECT_NEAR(time_of("M190 S60\n"), (60 - a) / PrintTimeEstimator::kBedRate, 1e-9);
  // Heating starts when the target is set: 30 s of moves after M104 shorten the wait by 30 s.
  const double full = (205 - a) / PrintTimeEstimator::kNozzleRate;
  EXPECT_NEAR(time_of("M104 S205\nG1 X300 F600\nM109 S205\n"), 30 + (full - 30), 1e-9);
  // Cooling is not waited for; a wait already satisfied costs nothing.
  EXPECT_NEAR(time_of("M109 S205\nM109 S180\nM109 S180\n"), full, 1e-9);
  // Both heaters at once (RepRapFirmware M116 waits for all): the longer wait.
  EXPECT_NEAR(time_of("M140 S60\nM568 P0 S205 A2\nM116\n"),
              std::max(full, (60 - a) / PrintTimeEstimator::kBedRate), 1e-9);
  // Klipper's wait.
  EXPECT_NEAR(time_of("SET_HEATER_TEMPERATURE HEATER=extruder TARGET=205\n"
                      "TEMPERATURE_WAIT SENSOR=extruder MINIMUM=204\n"),
              (204 - a) / PrintTimeEstimator::kNozzleRate, 1e-9);
}

// The file's own limits are the ones its time is estimated with.
TEST(PrintTime, TheFilesLimitsApply) {
  const double plain = time_of("G1 X100 F6000\n");
  EXPECT_NEAR(plain, 1.0, 1e-9);
  const double slow = time_of("M204 P100 T100\nM205 X0.001 Y0.001\nG1 X100 F6000\n");
  EXPECT_NEAR(slow, 2.0, 1e-4);  // 50 mm up to 100 mm/s, 50 mm down: a triangle of 2 s
  // M203 caps the feed per axis (Marlin: mm/s; RepRapFirmware, known from our header: mm/min).
  EXPECT_NEAR(time_of("M203 Z2\nG1 Z10 F6000\n"), 5.0, 1e-9);
  EXPECT_NEAR(time_of("; setting machine.flavor = reprap\nM203 Z120\nG1 Z10 F6000\n"), 5.0, 1e-9);
}

// The writer's estimate is the estimate of the file it wrote, as a reader gets it: first travel
// from home, dwells, heater waits, acceleration and jerk from its header.
TEST(PrintTime, TheWriterEstimatesTheFileItWrites) {
  Toolpath tp;
  for (int l = 0; l < 3; ++l) {
    const double z = 0.2 * (l + 1);
    Path a, b;
    a.points = {{10, 10, z}, {30, 10, z}, {30, 30, z}, {10, 30, z}};
    b.points = {{12, 12, z}, {28, 28, z}};
    tp.layers.push_back({z, {a, b}});
  }
  for (const std::string flavor : {"marlin", "klipper", "reprap", "pneumatic"}) {
    MachineProfile p = test::open_bed();
    p.flavor = flavor_from_string(flavor);
    p.nozzle_temperature = 205;
    p.bed_temperature = flavor == "pneumatic" ? 0 : 60;
    p.acceleration = 800;
    p.jerk = 8;
    p.pre_flow_dwell = 0.25;
    GcodeStats stats;
    const std::string g = write_gcode(tp, p, &stats);
    const auto [seconds, heating] = read_back_time(g);
    EXPECT_NEAR(stats.print_time_s, seconds, 1e-9) << flavor;
    EXPECT_NEAR(stats.heating_s, heating, 1e-9) << flavor;
    // Heating from ambient is in it (the bed is the longer wait where there is one).
    const double a = PrintTimeEstimator::kAmbient;
    EXPECT_GE(stats.heating_s, (205 - a) / PrintTimeEstimator::kNozzleRate - 1e-9) << flavor;
    // The dwells are in it: 6 paths x 0.25 s.
    MachineProfile q = p;
    q.pre_flow_dwell = 0;
    GcodeStats quick;
    write_gcode(tp, q, &quick);
    EXPECT_NEAR(stats.print_time_s - quick.print_time_s, 6 * 0.25, 0.15) << flavor;
    // Acceleration costs time.
    q.acceleration = 0;
    write_gcode(tp, q, &quick);
    EXPECT_GT(stats.print_time_s - 6 * 0.25, quick.print_time_s) << flavor;
  }
}

// The writer hands its own moves to the estimate as numbers, not text: the estimate must be the
// very one a reader makes of the file (to the last bit), whatever the profile's own G-code puts
// the reader in (relative moves, inches, relative E) and whether the file is written whole or
// streamed.
TEST(PrintTime, TheWritersEstimateIsTheReadersToTheBit) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(5, 95), step(-3, 3);
  Toolpath tp;
  for (int l = 0; l < 6; ++l) {
    const double z = 0.2 * (l + 1);
    Layer layer{z, {}};
    for (int k = 0; k < 12; ++k) {
      Path p;
      Vec3 q{xy(rng), xy(rng), z};
      for (int i = 0; i < 30; ++i) {
        p.points.push_back(q);
        q = {std::clamp(q.x + step(rng), 1.0, 99.0), std::clamp(q.y + step(rng), 1.0, 99.0), z};
      }
      p.speed = k % 3 == 0 ? 0 : 20 + k;
      layer.paths.push_back(std::move(p));
    }
    tp.layers.push_back(std::move(layer));
  }
  struct Case {
    const char* start;
    bool relative_e;
    double acceleration;
  };
  for (const Case& c :
       {Case{"G28", false, 0}, Case{"G28\nG91\nG1 Z2 F600\nG1 X1 E0.5 F600", true, 900},
        Case{"G28\nG20\nG1 Z0.1 F600", false, 1500},
        // Relative, then absolute again with moves and E set in the profile's text: the
        // writer's moves go to the estimate as numbers again from where the text left them.
        Case{"G28\nG91\nG1 Z2 F600\nG90\nG1 X5 Y5 F3000\nG92 E3\nG1 E4 F1800", false, 1200},
        Case{"G28\nG1 X3 Y4 Z5 F4800\nG1 X4 E0.2", true, 700}}) {
    MachineProfile p = test::open_bed();
    p.start_gcode = c.start;
    p.relative_e = c.relative_e;
    p.acceleration = c.acceleration;
    p.retract_length = 0.8;
    p.z_hop = 0.2;
    GcodeStats stats;
    const std::string g = write_gcode(tp, p, &stats);
    EXPECT_EQ(stats.print_time_s, read_back_time(g).first) << c.start;
    EXPECT_GT(stats.print_time_s, 0) << c.start;
    // Streamed, the same bytes (M73 lines from the same estimate).
    const std::string path = ::testing::TempDir() + "/streamed_estimate.gcode";
    const LayerSource layers = [&](const LayerVisitor& visit) {
      for (std::size_t i = 0; i < tp.layers.size(); ++i) visit(i, tp.layers[i]);
    };
    const GcodeStats streamed = write_gcode_stream(path, tp, tp.layers.size(), layers, p);
    std::ifstream in(path, std::ios::binary);
    const std::string back((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(streamed.print_time_s, stats.print_time_s) << c.start;
    EXPECT_EQ(back, g) << c.start;
    std::remove(path.c_str());
  }
}
