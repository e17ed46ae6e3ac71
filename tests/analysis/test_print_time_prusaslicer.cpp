// `trellis analyze`'s print-time estimate against an independent one: PrusaSlicer's, stated in
// the G-code it made (tests/data/prusaslicer/README.md), with the file's own motion limits. And
// the writer's estimate is what analyze reads from the written file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "support/temp_dir.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/settings/settings.hpp"

using namespace trellis;

namespace {

// "; estimated printing time (normal mode) = 1h 2m 3s" in seconds (-1 if absent).
double stated_estimate(const std::string& text) {
  const std::string key = "; estimated printing time (normal mode) = ";
  const auto at = text.find(key);
  if (at == std::string::npos) return -1;
  std::istringstream in(text.substr(at + key.size(), text.find('\n', at) - at - key.size()));
  double total = 0, v = 0;
  char unit = 0;
  while (in >> v >> unit)
    total += v * (unit == 'd' ? 86400 : unit == 'h' ? 3600 : unit == 'm' ? 60 : 1);
  return total;
}

}  // namespace

TEST(PrintTime, WithinTenPercentOfPrusaSlicersEstimate) {
  for (const std::string name : {"box_20mm.gcode", "cylinder_half.gcode"}) {
    const std::string path = std::string(TRELLIS_TEST_DATA) + "/prusaslicer/" + name;
    const double theirs = stated_estimate(read_file(path));
    ASSERT_GT(theirs, 60) << name;
    Diagnostics d;
    const Analysis a = analyze_gcode_file(path, nullptr, {}, {}, d);
    // PrusaSlicer leaves the heater waits out (the file waits for its nozzle with M109 S200).
    EXPECT_GT(a.counts.heating_s, 0) << name;
    const double ours = a.counts.print_time_s - a.counts.heating_s;
    const double ratio = ours / theirs;
    std::printf("%s: ours %.1f s (+ %.1f s heating), PrusaSlicer %.0f s, ratio %.3f\n",
                name.c_str(), ours, a.counts.heating_s, theirs, ratio);
    RecordProperty(name + "_ratio", std::to_string(ratio));
    EXPECT_GT(ratio, 0.9) << name;
    EXPECT_LT(ratio, 1.1) << name;
    // The acceleration matters: feeds alone are farther off.
    GcodeReadOptions feeds_only;
    CountingSink plain;
    GcodeScanner s(plain, feeds_only, d);
    std::string text = read_file(path);
    for (const char* limit : {"\nM201", "\nM204", "\nM205"})
      for (auto p = text.find(limit); p != std::string::npos; p = text.find(limit, p))
        text[p + 1] = ';';
    s.feed(text);
    s.finish();
    plain.finish();
    const double feeds = plain.counts.print_time_s - plain.counts.heating_s;
    std::printf("%s: feeds only %.1f s, ratio %.3f\n", name.c_str(), feeds, feeds / theirs);
    EXPECT_LT(std::abs(ours - theirs), std::abs(feeds - theirs)) << name;
  }
}

// The writer's "; estimated printing time" and its stats are what `trellis analyze` reads from
// the written file (one estimate, read from the file both times).
TEST(PrintTime, TheWritersEstimateIsAnalyzesEstimate) {
  Toolpath tp;
  for (int l = 0; l < 4; ++l) {
    const double z = 0.2 * (l + 1);
    Path a;
    for (int k = 0; k <= 40; ++k)
      a.points.push_back({100 + 20 * std::cos(k * 0.157), 100 + 20 * std::sin(k * 0.157), z});
    Path b;
    b.points = {{90, 90, z}, {110, 110, z}, {90, 110, z}};
    tp.layers.push_back({z, {a, b}});
  }
  test::TempDir dir("print_time_writer");
  for (const std::string profile : {"ender3_s1_pro_tpu.toml", "voron_klipper.toml",
                                    "pneumatic_pcl_27g.toml", "e3d_toolchanger_rrf.toml"}) {
    const MachineProfile p =
        load_machine_profile(std::string(TRELLIS_SOURCE_DIR) + "/profiles/" + profile);
    const std::string file = dir.file(profile + ".gcode");
    const GcodeStats stats = write_gcode_file(file, tp, p);
    Diagnostics d;
    const Analysis a = analyze_gcode_file(file, nullptr, {}, {}, d);
    EXPECT_NEAR(a.counts.print_time_s, stats.print_time_s, 1e-6 * stats.print_time_s) << profile;
    EXPECT_NEAR(a.counts.heating_s, stats.heating_s, 1e-9) << profile;
    EXPECT_GT(stats.heating_s, 0) << profile;  // every one heats (the PCL cartridge too)
    // The footer states it as PrusaSlicer does.
    EXPECT_NEAR(stated_estimate(read_file(file)), stats.print_time_s, 0.5) << profile;
  }
}
