// Machines as they are: each nozzle of a multi-nozzle bath head where its offset puts it, the
// bath's floor, prime lines where the profiles say they prime, heated pneumatic cartridges.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "trellis/core/error.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/settings/settings.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

MachineProfile shipped(const std::string& name, const std::vector<std::string>& sets = {}) {
  return load_machine_profile(std::string(TRELLIS_SOURCE_DIR) + "/profiles/" + name, sets);
}

// Paths for two tools, each a strut at its own place in a small bath print.
Toolpath two_tool_print() {
  Toolpath tp;
  for (int l = 0; l < 2; ++l) {
    const double z = 1 + l;
    Layer layer{z, {}};
    for (int tool = 0; tool < 2; ++tool) {
      Path p;
      p.tool = tool;
      p.points = {{60.0 + 7 * tool, 30.0 + 3 * l, z}, {75.0 + 7 * tool, 41.0 - 2 * tool, z}};
      layer.paths.push_back(p);
    }
    tp.layers.push_back(layer);
  }
  return tp;
}

// The head's XY of each G0/G1 with X and Y, in order, with the tool selected then (T<n> lines).
struct HeadMove {
  int tool;
  double x, y;
};
std::vector<HeadMove> head_moves(const std::string& g) {
  std::vector<HeadMove> out;
  std::istringstream in(g);
  std::string line;
  int tool = 0;
  while (std::getline(in, line)) {
    if (line.size() > 1 && line[0] == 'T') tool = std::stoi(line.substr(1));
    if (line.rfind("G1 X", 0) != 0) continue;
    const auto y = line.find(" Y");
    out.push_back({tool, std::stod(line.substr(4)), std::stod(line.substr(y + 2))});
  }
  return out;
}

// G-code read back with the profile's valve commands (nothing else: offsets come from the header).
Toolpath read_with_valves(const std::string& gcode, const MachineProfile& p, Diagnostics& d) {
  GcodeReadOptions o;
  o.valve_on = p.valve_on;
  o.valve_off = p.valve_off;
  return read_gcode(gcode, o, d);
}

}  // namespace

// The sign convention (docs/formats.md, "Machines"): embedded.tool_offsets says where nozzle t sits
// relative to nozzle 0; the writer moves the head to design - offset so that nozzle t prints on the
// design, and the reader adds the offset back. Read back, every point of every tool is where the
// design put it; the head of tool 1 (40 mm along +X) ran 40 mm to the left of the design.
TEST(ToolOffsets, ATwoNozzlePrintReadsBackOnTheDesign) {
  MachineProfile p = shipped("embedded_aero_two_nozzle.toml");
  p.center = false;  // design coordinates are bed coordinates
  const Toolpath tp = two_tool_print();
  const std::string g = write_gcode(tp, p);
  // The head.
  const auto moves = head_moves(g);
  ASSERT_EQ(moves.size(), 4u);
  std::size_t k = 0;
  for (const auto& l : tp.layers)
    for (const auto& path : l.paths) {
      const Vec2 o = p.tool_offset(path.tool);
      EXPECT_EQ(moves[k].tool, path.tool);
      EXPECT_NEAR(moves[k].x, path.points[1].x - o.x, 1e-9);
      EXPECT_NEAR(moves[k].y, path.points[1].y - o.y, 1e-9);
      ++k;
    }
  EXPECT_DOUBLE_EQ(p.tool_offset(1).x, 40);
  // Read back (no options: the offsets come from the file's header): the nozzles' positions.
  Diagnostics d;
  const Toolpath back = read_with_valves(g, p, d);
  EXPECT_EQ(d.total(), 0u);
  ASSERT_EQ(back.layers.size(), tp.layers.size());
  for (std::size_t l = 0; l < tp.layers.size(); ++l) {
    ASSERT_EQ(back.layers[l].paths.size(), 2u);
    for (std::size_t i = 0; i < 2; ++i) {
      const Path& a = tp.layers[l].paths[i];
      const Path& b = back.layers[l].paths[i];
      EXPECT_EQ(b.tool, a.tool);
      ASSERT_EQ(b.points.size(), a.points.size());
      for (std::size_t q = 0; q < a.points.size(); ++q) {
        EXPECT_NEAR(b.points[q].x, a.points[q].x, 1e-6) << "tool " << a.tool;
        EXPECT_NEAR(b.points[q].y, a.points[q].y, 1e-6) << "tool " << a.tool;
      }
    }
  }
  // The same offsets given to the reader by hand read the same; a file whose firmware applies
  // the offsets carries design XY for the head, and reads back the same too.
  GcodeReadOptions o;
  o.valve_on = p.valve_on;
  o.valve_off = p.valve_off;
  o.tool_offsets = p.tool_offsets;
  const Toolpath given = read_gcode(g, o, d);
  EXPECT_NEAR(given.layers[1].paths[1].points[0].x, tp.layers[1].paths[1].points[0].x, 1e-6);
  p.firmware_offsets = true;
  const std::string fw = write_gcode(tp, p);
  const auto fw_moves = head_moves(fw);
  ASSERT_EQ(fw_moves.size(), 4u);
  EXPECT_NEAR(fw_moves[1].x, tp.layers[0].paths[1].points[1].x, 1e-9);  // design XY, not shifted
  o.tool_offsets.clear();
  const Toolpath fw_back = read_gcode(fw, o, d);
  EXPECT_NEAR(fw_back.layers[0].paths[1].points[1].x, tp.layers[0].paths[1].points[1].x, 1e-6);
  // The bed check follows the same sign: nozzle 1 printing at design X 37 puts the head at
  // X -3, off the bed.
  p.firmware_offsets = false;
  Toolpath near_edge = two_tool_print();
  for (auto& l : near_edge.layers)
    for (auto& path : l.paths)
      for (auto& q : path.points) q.x -= 30;
  EXPECT_THROW(write_gcode(near_edge, p), MachineError);
}

// embedded.floor_z: the design's Z 0 is printed on the bath's floor, read back in design
// coordinates; a floor at or above the bath's surface, or on a machine without a bath, is refused.
TEST(BathFloor, TheFirstStrutSitsOnTheFloor) {
  MachineProfile p = shipped("embedded_aero_410um.toml");
  p.center = false;
  Toolpath tp;
  Path s;
  s.points = {{50, 50, 0}, {60, 50, 0}, {60, 50, 4}};
  tp.layers.push_back({0, {s}});
  for (const double floor : {0.0, 3.5}) {
    p.floor_z = floor;
    GcodeStats stats;
    const std::string g = write_gcode(tp, p, &stats);
    for (const auto& w : stats.warnings) EXPECT_NE(w.first, "lifted") << w.second;
    Diagnostics d;
    GcodeReadOptions o;
    o.valve_on = p.valve_on;
    o.valve_off = p.valve_off;
    Toolpath back = read_gcode(g, o, d);
    ASSERT_EQ(back.path_count(), 1u);
    EXPECT_NEAR(back.layers[0].paths[0].points[0].z, floor, 1e-9);  // on the floor
    EXPECT_NEAR(back.layers[0].paths[0].points[2].z, floor + 4, 1e-9);
    to_design_coordinates(back, g);
    EXPECT_NEAR(back.layers[0].paths[0].points[0].z, 0, 1e-9);
  }
  p.floor_z = p.bath_surface;
  EXPECT_THROW(validate(p), SettingError);
  EXPECT_THROW(machine_profile_from_toml("", "fdm.toml", {"embedded.floor_z=2"}), SettingError);
  EXPECT_THROW(shipped("embedded_aero_410um.toml", {"embedded.floor_z=100"}),
               SettingError);  // bed_z 100
  EXPECT_NO_THROW(shipped("embedded_aero_410um.toml", {"embedded.floor_z=5"}));
}

// Every shipped profile that says it primes (a comment naming a prime line) draws one, and every
// profile that draws one says so: the line is in its G-code, read back as priming (not a path)
// with the filament or valve it takes.
TEST(PrimeLine, ProfilesPrimeAsTheirCommentsSay) {
  int priming = 0;
  Toolpath tp;
  Path s;
  s.points = {{0, 0, 0.2}, {10, 0, 0.2}, {10, 10, 0.2}};
  tp.layers.push_back({0.2, {s}});
  for (const auto& e : fs::directory_iterator(fs::path(TRELLIS_SOURCE_DIR) / "profiles")) {
    std::ifstream in(e.path());
    std::stringstream text;
    text << in.rdbuf();
    const std::string t = text.str();
    if (t.find("flavor") == std::string::npos) continue;  // a laser
    const MachineProfile p = load_machine_profile(e.path().string());
    const bool says = t.find("prime line") != std::string::npos;
    EXPECT_EQ(says, p.prime_line > 0) << e.path().filename() << " says it primes: " << says;
    if (p.prime_line <= 0) continue;
    ++priming;
    GcodeStats stats;
    const std::string g = write_gcode(tp, p, &stats);
    EXPECT_NE(g.find(";TYPE:Prime line"), std::string::npos) << e.path();
    // Before the first layer.
    EXPECT_LT(g.find(";TYPE:Prime line"), g.find(";LAYER:0")) << e.path();
    Diagnostics d;
    GcodeReadOptions o;
    if (!p.marlin_family()) o.valve_on = p.valve_on, o.valve_off = p.valve_off;
    Toolpath back = read_gcode(g, o, d);
    EXPECT_EQ(back.path_count(), 1u) << e.path();  // the prime line is not a path
    EXPECT_NEAR(stats.prime_length, p.prime_line, 1e-9);
    // Read as priming: its length, and on E machines the filament the writer put into it.
    struct PrimeSink : GcodeSink {
      double length = 0, e = 0;
      void prime(Vec3 a, Vec3 b, double de, double) override { length += distance(a, b), e += de; }
    } primed;
    GcodeScanner scan(primed, o, d);
    scan.feed(g);
    scan.finish();
    EXPECT_NEAR(primed.length, p.prime_line, 1e-3) << e.path();
    EXPECT_NEAR(primed.e, stats.prime_filament, 1e-4) << e.path();
    if (p.marlin_family()) EXPECT_GT(stats.prime_filament, 0) << e.path();
  }
  EXPECT_GE(priming, 4);  // the FDM printers and the pneumatic one
}

TEST(PrimeLine, ThePneumaticLineOpensTheValveAndALongLineIsRefused) {
  MachineProfile p = shipped("pneumatic_pcl_27g.toml");
  Toolpath tp;
  Path s;
  s.points = {{0, 0, 0.2}, {10, 0, 0.2}};
  tp.layers.push_back({0.2, {s}});
  const std::string g = write_gcode(tp, p);
  const auto prime = g.find(";TYPE:Prime line");
  ASSERT_NE(prime, std::string::npos);
  const auto open = g.find(p.valve_on, prime);
  const auto line = g.find("G1 X", prime);
  const auto close = g.find(p.valve_off, prime);
  EXPECT_LT(open, line);
  EXPECT_LT(line, close);
  EXPECT_LT(close, g.find(";LAYER:0"));
  p = shipped("pneumatic_pcl_27g.toml",
              {"gcode.prime_line=195"});  // bed_x 200: refused when written
  EXPECT_THROW(write_gcode(tp, p), MachineError);
  EXPECT_THROW(shipped("embedded_aero_410um.toml", {"gcode.prime_line=20"}), SettingError);
}

// A pneumatic melt printer heats its cartridge: the heater is set and waited for before the
// valve first opens, the estimate counts the heat-up, and the reader sees the temperature.
TEST(HeatedPneumatic, TheCartridgeIsHeatedAndWaitedFor) {
  const MachineProfile p = shipped("pneumatic_pcl_27g.toml");
  ASSERT_GT(p.nozzle_temperature, 60);  // PCL melts at 60 °C
  ASSERT_LE(p.nozzle_temperature, p.max_nozzle_temperature);
  Toolpath tp;
  Path s;
  s.points = {{0, 0, 0.15}, {10, 0, 0.15}};
  tp.layers.push_back({0.15, {s}});
  GcodeStats stats;
  const std::string g = write_gcode(tp, p, &stats);
  const auto wait = g.find("M109 S" + std::to_string(static_cast<int>(p.nozzle_temperature)));
  ASSERT_NE(wait, std::string::npos) << g.substr(0, 3000);
  EXPECT_LT(wait, g.find("\n" + p.valve_on));  // before the valve first opens
  EXPECT_NEAR(
      stats.heating_s,
      (p.nozzle_temperature - PrintTimeEstimator::kAmbient) / PrintTimeEstimator::kNozzleRate,
      1e-6);
  Diagnostics d;
  const Toolpath back = read_with_valves(g, p, d);
  ASSERT_EQ(back.path_count(), 1u);
  EXPECT_EQ(back.layers[0].paths[0].temperature, p.nozzle_temperature);
}

// The bed check takes a path on a rectangular bed by its extent (the writer hands it each
// path's extent from its one pass over the points): the verdict and the extent named in the
// message are those of checking every point placed, one by one. Random prints, a few points
// pushed just past an edge, signed zeros and NaN among them, both origins, centred or not.
TEST(BedCheck, ByExtentAsPointByPoint) {
  std::mt19937 rng(40);
  std::uniform_real_distribution<double> u(0, 1);
  const double eps = 1e-6;
  for (int trial = 0; trial < 300; ++trial) {
    MachineProfile p = shipped("ender3_s1_pro_tpu.toml");
    p.origin = trial % 2 ? BedOrigin::Center : BedOrigin::Corner;
    p.center = trial % 3 == 0;
    const double x0 = p.origin == BedOrigin::Center ? -p.bed_x / 2 : 0;
    const double y0 = p.origin == BedOrigin::Center ? -p.bed_y / 2 : 0;
    Toolpath tp;
    for (int l = 0; l < 3; ++l) {
      Layer layer{0.2 * (l + 1), {}};
      for (int k = 0; k < 4; ++k) {
        Path path;
        const int n = 1 + static_cast<int>(u(rng) * 6);
        for (int i = 0; i < n; ++i)
          path.points.push_back({x0 + u(rng) * p.bed_x, y0 + u(rng) * p.bed_y, layer.z});
        layer.paths.push_back(path);
      }
      tp.layers.push_back(layer);
    }
    auto& q = tp.layers[trial % 3].paths[trial % 4].points[0];
    if (trial % 5 == 1) q.x = x0 + p.bed_x + (trial % 10 == 1 ? 2 * eps : eps / 2);  // out / in
    if (trial % 5 == 2) q.y = y0 - 3 * eps;
    if (trial % 7 == 3) q.x = -0.0;
    if (trial % 29 == 4) q.z = std::nan("");
    // The reference: every point placed, one by one.
    BBox3 all;
    std::vector<BBox3> extents;
    for (const auto& layer : tp.layers)
      for (const auto& path : layer.paths) {
        for (const auto& v : path.points) all.add(v);
        extents.push_back(path_extent(path.points));
      }
    const Vec2 shift = placement_offset(all, p);
    BBox3 placed;
    bool outside = false;
    for (const auto& layer : tp.layers)
      for (const auto& path : layer.paths) {
        if (path.points.size() < 2) continue;
        for (const auto& v : path.points) {
          const Vec3 at{v.x + shift.x, v.y + shift.y, v.z};
          placed.add(at);
          outside = outside ||
                    !(at.z >= -eps && at.z <= p.bed_z + eps && at.x >= x0 - eps &&
                      at.x <= x0 + p.bed_x + eps && at.y >= y0 - eps && at.y <= y0 + p.bed_y + eps);
        }
      }
    for (const std::vector<BBox3>* given : {&extents, static_cast<std::vector<BBox3>*>(nullptr)}) {
      SCOPED_TRACE("trial " + std::to_string(trial) + (given ? " with extents" : ""));
      std::string message;
      try {
        check_for_machine(layers_of(tp), all, p, given);
      } catch (const MachineError& e) {
        message = e.what();
      }
      EXPECT_EQ(!message.empty(), outside) << message;
      if (outside && !std::isnan(placed.min.z))
        EXPECT_NE(message.find(fmt::format("spans X {:.6g}..{:.6g}, Y {:.6g}..{:.6g}, Z {:.6g}..",
                                           placed.min.x, placed.max.x, placed.min.y, placed.max.y,
                                           placed.min.z)),
                  std::string::npos)
            << message;
    }
  }
}
