// Parts of a build plate labelled in the G-code (issue 23): for Marlin/Prusa and RepRapFirmware
// (M486) and Klipper (EXCLUDE_OBJECT_*), the file read back puts every extrusion in exactly one
// labelled part, inside that part's footprint; Klipper's declared polygons hold their parts'
// moves; gcode.label_objects = false and the valve flavours write no labels; labels the firmware
// cannot take are renamed with a warning, and two that would read alike are refused.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <regex>

#include "trellis/analysis/metrics.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"

using namespace trellis;

namespace {

constexpr double kHalf = 4;  // each part is a 8 x 8 mm square around its centre

Vec2 centre(int part) {  // part >= 1: a 3 x 3 grid 15 mm apart
  return {40.0 + 15 * ((part - 1) % 3), 40.0 + 15 * ((part - 1) / 3)};
}

// Nine parts of random paths in their squares, printed in every layer in an order that changes.
Toolpath plate(const std::vector<std::string>& labels, int layers = 4, int points = 5) {
  Toolpath tp;
  tp.part_labels = labels;
  Rng rng(3);
  for (int l = 0; l < layers; ++l) {
    Layer layer{0.2 * (l + 1), {}};
    for (int k = 0; k < 9; ++k) {
      const int part = 1 + (k + 4 * l) % 9;
      for (int n = 0; n < 3; ++n) {
        Path path;
        path.part = part;
        for (int i = 0; i < points; ++i)
          path.points.push_back({centre(part).x + (2 * rng.uniform01() - 1) * kHalf,
                                 centre(part).y + (2 * rng.uniform01() - 1) * kHalf, layer.z});
        layer.paths.push_back(std::move(path));
      }
    }
    tp.layers.push_back(std::move(layer));
  }
  return tp;
}

std::vector<std::string> nine_labels() {
  std::vector<std::string> v;
  for (int k = 1; k <= 9; ++k) v.push_back("tile" + std::to_string(k));
  return v;
}

MachineProfile profile(const std::string& flavor) {
  MachineProfile p;
  p.flavor = flavor_from_string(flavor);
  p.center = false;  // plates are placed already
  p.retract_length = 0.8;
  p.nozzle_temperature = 215;
  return p;
}

// Every extrusion with the part open at that moment (none: "").
class PartOfEachExtrusion : public GcodeSink {
 public:
  std::vector<std::pair<std::string, Vec3>> ends;
  std::size_t opened = 0;
  void object(std::string_view label) override {
    open_ = std::string(label);
    opened += !label.empty();
  }
  void extrude(Vec3 a, Vec3 b, double, double) override {
    ends.emplace_back(open_, a);
    ends.emplace_back(open_, b);
  }

 private:
  std::string open_;
};

bool inside_square(Vec3 q, int part) {
  return std::abs(q.x - centre(part).x) <= kHalf + 1e-3 &&
         std::abs(q.y - centre(part).y) <= kHalf + 1e-3;
}

}  // namespace

TEST(GcodeObjects, EveryExtrusionIsInExactlyOneLabelledPartInsideItsFootprint) {
  const auto labels = nine_labels();
  const Toolpath tp = plate(labels);
  for (const std::string flavor : {"marlin", "reprap", "klipper"}) {
    GcodeStats stats;
    const std::string g = write_gcode(tp, profile(flavor), &stats);
    EXPECT_TRUE(stats.warnings.empty()) << flavor;
    if (flavor == "klipper") {
      EXPECT_NE(g.find("EXCLUDE_OBJECT_DEFINE NAME=tile9 CENTER="), std::string::npos);
      EXPECT_EQ(g.find("M486"), std::string::npos);
    } else {
      EXPECT_NE(g.find("M486 T9\n"), std::string::npos) << flavor;
      EXPECT_NE(g.find("M486 S8 A\"tile9\"\n"), std::string::npos) << flavor;
    }
    // The scanner's events: each extrusion inside the one part open at that time.
    Diagnostics diag;
    PartOfEachExtrusion sink;
    GcodeScanner scanner(sink, {}, diag, flavor);
    scanner.feed(g);
    scanner.finish();
    EXPECT_EQ(diag.total(), 0u) << flavor;
    EXPECT_EQ(sink.opened, 4u * 9u) << flavor << ": each part once per layer";
    ASSERT_FALSE(sink.ends.empty());
    for (const auto& [label, q] : sink.ends) {
      const auto it = std::find(labels.begin(), labels.end(), label);
      ASSERT_NE(it, labels.end()) << flavor << ": an extrusion at " << q.x << "," << q.y
                                  << " is in no labelled part";
      EXPECT_TRUE(inside_square(q, static_cast<int>(it - labels.begin()) + 1))
          << flavor << ": " << q.x << "," << q.y << " is outside " << label;
    }
    // The IR read back: the labels, and each path in its part.
    const Toolpath back = read_gcode(g, {}, diag, flavor);
    EXPECT_EQ(back.part_labels, labels) << flavor;
    std::size_t paths = 0;
    for (const auto& l : back.layers)
      for (const auto& p : l.paths) {
        ASSERT_GE(p.part, 1) << flavor;
        for (const Vec3& q : p.points) EXPECT_TRUE(inside_square(q, p.part)) << flavor;
        ++paths;
      }
    EXPECT_EQ(paths, tp.path_count()) << flavor;
  }
}

// Klipper's EXCLUDE_OBJECT_DEFINE polygon (the convex hull of the part's moves) holds every one
// of the part's extrusions, and its CENTER lies inside it.
TEST(GcodeObjects, KlipperPolygonsHoldTheirPartsMoves) {
  const auto labels = nine_labels();
  const Toolpath tp = plate(labels);
  const std::string g = write_gcode(tp, profile("klipper"));
  const std::regex define(
      R"(EXCLUDE_OBJECT_DEFINE NAME=(\S+) CENTER=(\S+),(\S+) POLYGON=\[(.*)\])");
  const std::regex vertex(R"(\[([-0-9.]+),([-0-9.]+)\])");
  std::map<std::string, std::vector<Vec2>> polygons;
  for (auto it = std::sregex_iterator(g.begin(), g.end(), define); it != std::sregex_iterator();
       ++it) {
    const std::string list = (*it)[4];
    auto& poly = polygons[(*it)[1]];
    for (auto v = std::sregex_iterator(list.begin(), list.end(), vertex);
         v != std::sregex_iterator(); ++v)
      poly.push_back({std::stod((*v)[1]), std::stod((*v)[2])});
    EXPECT_GE(poly.size(), 3u);
  }
  ASSERT_EQ(polygons.size(), 9u);
  auto inside = [](const std::vector<Vec2>& poly, Vec2 q) {  // counter-clockwise, convex
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Vec2 a = poly[i], b = poly[(i + 1) % poly.size()];
      if ((b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x) < -1e-3) return false;
    }
    return true;
  };
  Diagnostics diag;
  PartOfEachExtrusion sink;
  GcodeScanner scanner(sink, {}, diag);
  scanner.feed(g);
  scanner.finish();
  for (const auto& [label, q] : sink.ends)
    EXPECT_TRUE(inside(polygons.at(label), {q.x, q.y}))
        << q.x << "," << q.y << " outside " << label;
}

TEST(GcodeObjects, OffForTheSettingTheValveFlavoursAndSinglePartPrints) {
  const Toolpath tp = plate(nine_labels());
  MachineProfile off = profile("marlin");
  off.label_objects = false;
  const std::regex any("M486|EXCLUDE_OBJECT");
  EXPECT_FALSE(std::regex_search(write_gcode(tp, off), any));
  MachineProfile valve = profile("pneumatic");
  EXPECT_FALSE(std::regex_search(write_gcode(tp, valve), any));
  Toolpath one = tp;
  one.part_labels.clear();
  for (auto& l : one.layers)
    for (auto& p : l.paths) p.part = 0;
  EXPECT_FALSE(std::regex_search(write_gcode(one, profile("klipper")), any));
  Diagnostics diag;
  EXPECT_TRUE(read_gcode(write_gcode(tp, off), {}, diag).part_labels.empty());
}

TEST(GcodeObjects, LabelsTheFirmwareCannotTakeAreRenamedWithAWarningOrRefused) {
  auto labels = nine_labels();
  labels[0] = "tile 1";
  GcodeStats stats;
  const std::string g = write_gcode(plate(labels), profile("klipper"), &stats);
  ASSERT_EQ(stats.warnings.size(), 1u);
  EXPECT_EQ(stats.warnings[0].first, "label_renamed");
  EXPECT_NE(stats.warnings[0].second.find("'tile 1' is written as 'tile_1'"), std::string::npos);
  EXPECT_NE(g.find("EXCLUDE_OBJECT_START NAME=tile_1\n"), std::string::npos);
  labels[1] = "tile_1";
  EXPECT_THROW(write_gcode(plate(labels), profile("marlin")), MachineError);
}

// Foreign spellings: M486 without A (the id names the part), Klipper's quoted names.
TEST(GcodeObjects, ReaderTakesOtherSlicersSpellings) {
  Diagnostics diag;
  const Toolpath a = read_gcode(
      "M486 T2\nM486 S0\nG1 X1 Y1 E1\nG1 X2 Y1 E2\nM486 S-1\nM486 S1 A\"b\"\nG1 X3 Y1 E3\n"
      "M486 S-1\nG1 X4 Y1 E4\nEXCLUDE_OBJECT_START NAME='c'\nG1 X5 Y1 E5\nEXCLUDE_OBJECT_END "
      "NAME='c'\n",
      {}, diag);
  EXPECT_EQ(diag.total(), 0u);
  EXPECT_EQ(a.part_labels, (std::vector<std::string>{"0", "b", "c"}));
  std::vector<int> parts;
  for (const auto& l : a.layers)
    for (const auto& p : l.paths) parts.push_back(p.part);
  EXPECT_EQ(parts, (std::vector<int>{1, 2, 0, 3}));
  read_gcode("M486 S1.5\nM486 Sx\nEXCLUDE_OBJECT_START\n", {}, diag);
  EXPECT_EQ(diag.count("gcode_bad_line"), 3u);
}

// The writer's time estimate per part (the plate report's) is what `trellis analyze` measures
// for that part in the file, labels on or off, and the parts' times add up to no more than the
// whole print's.
TEST(GcodeObjects, TimePerPartIsWhatTheFileMeasures) {
  const Toolpath tp = plate(nine_labels());
  for (const bool labels : {true, false}) {
    MachineProfile p = profile("marlin");
    p.label_objects = labels;
    GcodeStats stats;
    const std::string g = write_gcode(tp, p, &stats);
    ASSERT_EQ(stats.part_time_s.size(), 9u);
    double sum = 0;
    for (double t : stats.part_time_s) {
      EXPECT_GT(t, 0);
      sum += t;
    }
    EXPECT_LE(sum, stats.print_time_s + 1e-9);
    if (!labels) continue;
    Diagnostics diag;
    CountingSink counter(5, p.acceleration);
    GcodeScanner scanner(counter, {}, diag);
    scanner.feed(g);
    scanner.finish();
    counter.finish();
    ASSERT_EQ(counter.counts.parts.size(), 9u);
    // The writer estimates the file it wrote as the reader does (the first part holds the travel
    // from home for both).
    for (std::size_t k = 0; k < 9; ++k)
      EXPECT_NEAR(counter.counts.parts[k].print_time_s, stats.part_time_s[k],
                  0.01 * stats.part_time_s[k])
          << counter.counts.parts[k].label;
  }
}

// Streamed writing (layers visited, never held: FDM plates from `trellis run`) labels the parts
// with the same bytes as the whole toolpath's writing, Klipper's hull polygons included, and the
// same time per part.
TEST(GcodeObjects, StreamedPlateIsLabelledWithTheSameBytes) {
  const Toolpath tp = plate(nine_labels());
  Toolpath meta;
  meta.part_labels = tp.part_labels;
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("trellis_objects_" + std::to_string(::getpid()) + ".gcode"))
                               .string();
  for (const std::string flavor : {"marlin", "klipper"}) {
    GcodeStats whole_stats;
    const std::string whole = write_gcode(tp, profile(flavor), &whole_stats);
    const GcodeStats s =
        write_gcode_stream(path, meta, tp.layers.size(), layers_of(tp), profile(flavor));
    const std::string streamed = read_file(path);
    std::filesystem::remove(path);
    EXPECT_TRUE(streamed == whole) << flavor;
    EXPECT_NE(streamed.find(flavor == "klipper" ? "POLYGON=[[" : "M486 S8 A"), std::string::npos);
    EXPECT_EQ(s.part_time_s, whole_stats.part_time_s) << flavor;
  }
}

// Streamed writing hands each written megabyte to the time estimate, which reads it on another
// thread while the next is written: a plate of many megabytes (marks of layers and parts in every
// piece, some at a piece's end) gives the whole toolpath's bytes, M73 lines and times included,
// with one thread and with two.
TEST(GcodeObjects, StreamedPlateOfManyMegabytesIsTheWholeOnesAtAnyThreadCount) {
  const Toolpath tp = plate(nine_labels(), 300, 60);
  Toolpath meta;
  meta.part_labels = tp.part_labels;
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("trellis_objects_big_" + std::to_string(::getpid()) + ".gcode"))
                               .string();
  const MachineProfile p = profile("marlin");
  GcodeStats whole_stats;
  const std::string whole = write_gcode(tp, p, &whole_stats);
  ASSERT_GT(whole.size(), std::size_t{4} << 20);  // several pieces
  ASSERT_NE(whole.find("M73 P50 "), std::string::npos);
  for (const std::size_t threads : {1u, 2u}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const GcodeStats s = write_gcode_stream(path, meta, tp.layers.size(), layers_of(tp), p);
    const std::string streamed = read_file(path);
    std::filesystem::remove(path);
    EXPECT_TRUE(streamed == whole) << threads << " threads";
    EXPECT_EQ(s.print_time_s, whole_stats.print_time_s) << threads << " threads";
    EXPECT_EQ(s.part_time_s, whole_stats.part_time_s) << threads << " threads";
    EXPECT_GT(s.print_time_s, 0);
  }
}
