// A G-code file read by scan_gcode_file (mapped, on two threads from 2 MB on) gives what the
// general reader gives reading the same text line by line on one thread: every sink event with
// every bit of every number, every warning, and analyze's JSON; on PrusaSlicer's files, a
// Cura-style file, our own, and hostile spellings of each (lower case, tabs, CRLF, comments,
// checksums, bad lines, no newline at the end), small (one thread) and large (two).
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "support/gcode_log_sink.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/job/reports.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/toolpath/json.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

using trellis::test::LogSink;

std::string warnings(const Diagnostics& d) {
  std::string s;
  for (const auto& m : d.messages()) s += m.kind + ": " + m.text + "\n";
  for (const auto& [kind, count] : d.counts()) s += kind + " x" + std::to_string(count) + "\n";
  return s;
}

// The general reader: line by line, one thread, no file.
std::string line_by_line(std::string_view text, GcodeSink& sink, const std::string& origin) {
  Diagnostics diag;
  GcodeScanner scanner(sink, {}, diag, origin);
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t nl = std::min(text.find('\n', pos), text.size());
    scanner.line(text.substr(pos, nl - pos));
    pos = nl + 1;
  }
  scanner.finish();
  return warnings(diag);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A Cura-style print: ;FLAVOR, ;LAYER:n, ;TYPE:WALL-OUTER / SKIN / FILL, "G1 F.. X.. Y.. E..",
// G0 travels with their feed first, retractions as G1 F.. E.., M-codes between.
std::string cura_style(int layers, std::uint64_t seed) {
  Rng rng(seed);
  std::string g =
      ";FLAVOR:Marlin\n;Generated with Cura_SteamEngine 4.13.1\nM140 S60\nM105\n"
      "M190 S60\nM104 S200\nM109 S200\nM82 ;absolute extrusion mode\nG28 ;Home\n"
      "G92 E0\nG1 F2700 E-5\n;LAYER_COUNT:" +
      std::to_string(layers) + "\n";
  double e = 0;
  char buf[160];
  for (int l = 0; l < layers; ++l) {
    std::snprintf(buf, sizeof buf, ";LAYER:%d\nM106 S255\nG0 F3600 X%.3f Y%.3f Z%.1f\n", l,
                  50 + rng.uniform01() * 10, 50 + rng.uniform01() * 10, 0.2 * (l + 1));
    g += buf;
    for (const char* type : {"WALL-OUTER", "SKIN", "FILL"}) {
      g += std::string(";TYPE:") + type + "\nG1 F2700 E" + std::to_string(e) + "\n";
      for (int k = 0; k < 400; ++k) {
        e += 0.01 + rng.uniform01() * 0.05;
        std::snprintf(buf, sizeof buf,
                      k == 0 ? "G1 F1200 X%.3f Y%.3f E%.5f\n" : "G1 X%.3f Y%.3f E%.5f\n",
                      40 + rng.uniform01() * 40, 40 + rng.uniform01() * 40, e);
        g += buf;
        if (k % 97 == 96) {
          std::snprintf(buf, sizeof buf, "G1 F2700 E%.5f\nG0 F3600 X%.2f Y%.2f\nG1 F2700 E%.5f\n",
                        e - 5, 40 + rng.uniform01() * 40, 40 + rng.uniform01() * 40, e);
          g += buf;
        }
      }
    }
  }
  return g + "M140 S0\nM107\nG91\nG1 E-2 F2700\nG1 E-2 Z0.2 F2400\nG90\nM84\n;End of Gcode\n";
}

// `text` in hostile spellings, line by line at random: lower case, tabs and runs of blanks, CRLF,
// trailing comments, line numbers with checksums, parenthesised comments, leading blanks, bad
// lines; no newline at the end.
std::string hostile(std::string_view text, std::uint64_t seed) {
  Rng rng(seed);
  std::string out;
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t nl = std::min(text.find('\n', pos), text.size());
    std::string line(text.substr(pos, nl - pos));
    pos = nl + 1;
    const int pick = static_cast<int>(rng.uniform01() * 12);
    switch (pick) {
      case 0:
        for (char& c : line)
          if (c >= 'A' && c <= 'Z') c = static_cast<char>(c + 32);
        break;
      case 1:
        for (char& c : line)
          if (c == ' ') c = '\t';
        break;
      case 2:
        line += "\r";
        break;
      case 3:
        line += " ; a comment G1 X5";
        break;
      case 4:
        line = "N" + std::to_string(pos) + " " + line + "*71";
        break;
      case 5:
        line = "   " + line + "   ";
        break;
      case 6:
        line += " (note)";
        break;
      case 7:
        if (rng.uniform01() < 0.05) line = "G1 X1e5 Y2";  // refused: an exponent
        break;
      case 8:
        if (rng.uniform01() < 0.05) line = "G1 X Y";  // refused: no numbers
        break;
      case 9: {
        std::string spaced;
        for (char c : line) spaced += c == ' ' ? "  " : std::string(1, c);
        line = spaced;
        break;
      }
      default:
        break;
    }
    out += line;
    out += '\n';
  }
  if (!out.empty()) out.pop_back();  // no newline at the end of the file
  return out;
}

// Our own G-code: paths with travels, retractions, Z hops, several roles and widths.
std::string ours(std::uint64_t seed) {
  MachineProfile profile;
  profile.retract_length = 0.8;
  profile.z_hop = 0.2;
  Toolpath tp;
  Rng rng(seed);
  for (int l = 0; l < 12; ++l) {
    Layer layer{0.2 * (l + 1), {}};
    for (int k = 0; k < 120; ++k) {
      Path path;
      Vec3 q{20 + rng.uniform01() * 150, 20 + rng.uniform01() * 150, layer.z};
      for (int i = 0; i < 30; ++i) {
        path.points.push_back(q);
        q = q + Vec3{rng.uniform01() - 0.5, rng.uniform01() - 0.5, 0};
      }
      path.speed = 10 + k % 5;
      path.role = static_cast<PathRole>(k % 4);
      path.width = 0.4 + 0.05 * (k % 3);
      layer.paths.push_back(std::move(path));
    }
    tp.layers.push_back(std::move(layer));
  }
  return write_gcode(tp, profile);
}

// `base` repeated until it is at least `bytes` long.
std::string at_least(const std::string& base, std::size_t bytes) {
  std::string s = base;
  if (!s.empty() && s.back() != '\n') s += '\n';
  const std::string unit = s;
  while (s.size() < bytes) s += unit;
  return s;
}

struct Temp {
  std::string path;
  explicit Temp(const std::string& text, const std::string& name) {
    path = (fs::temp_directory_path() /
            ("trellis_scan_file_" + std::to_string(::getpid()) + "_" + name + ".gcode"))
               .string();
    std::ofstream(path, std::ios::binary) << text;
  }
  ~Temp() { std::remove(path.c_str()); }
};

std::string analysis_of(const GcodeCounts& counts, const std::string& name) {
  Analysis a = analyze(Toolpath{}, counts, nullptr, AnalysisParams{});
  a.name = name;
  return analysis_json(a);
}

// The file's events, warnings and analysis as scan_gcode_file / analyze_gcode_file give them,
// against the general reader's of its text; with `threads` allowed.
void expect_same_as_line_by_line(const std::string& text, const std::string& name, int threads) {
  const Temp file(text, name);
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                  static_cast<std::size_t>(threads));
  const std::string label = name + " (" + std::to_string(text.size()) + " bytes, " +
                            std::to_string(threads) + " thread(s))";
  LogSink general;
  const std::string general_warnings = line_by_line(text, general, file.path);
  EXPECT_GT(general.log.size(), 1000u) << label;
  LogSink mapped;
  Diagnostics diag;
  scan_gcode_file(file.path, mapped, {}, diag);
  EXPECT_EQ(warnings(diag), general_warnings) << label;
  ASSERT_EQ(mapped.log.size(), general.log.size()) << label;
  EXPECT_TRUE(mapped.log == general.log) << label;

  // analyze's JSON: the counts of the general reader's events against analyze_gcode_file's.
  CountingSink counter;
  line_by_line(text, counter, file.path);
  counter.finish();
  Diagnostics d2;
  const Analysis a = analyze_gcode_file(file.path, nullptr, AnalysisParams{}, {}, d2);
  EXPECT_EQ(analysis_json(a), analysis_of(counter.counts, file.path)) << label;

  // view's pass (counts and the IR in one pass, two sinks behind a tee) against the IR of the
  // text read in memory.
  Diagnostics d3, d4;
  CountingSink view_counter;
  const GcodeRead r = read_gcode_file(file.path, {}, d3, &view_counter, true);
  const Toolpath in_memory = read_gcode(text, {}, d4, file.path);
  EXPECT_TRUE(toolpath_to_json(r.toolpath) == toolpath_to_json(in_memory)) << label;
}

}  // namespace

TEST(ScanFile, SameAsTheGeneralReaderOnEveryKindOfFileSmallAndLarge) {
  const std::string data = std::string(TRELLIS_TEST_DATA) + "/prusaslicer/";
  const std::vector<std::pair<std::string, std::string>> texts{
      {"prusa_box", read_text(data + "box_20mm.gcode")},
      {"prusa_cylinder", read_text(data + "cylinder_half.gcode")},
      {"cura", cura_style(6, 3)},
      {"ours", ours(7)},
  };
  std::uint64_t seed = 11;
  for (const auto& [name, text] : texts) {
    ASSERT_GT(text.size(), 100000u) << name;
    const std::string bad = hostile(text, seed++);
    for (int threads : {1, 2}) {
      expect_same_as_line_by_line(text, name, threads);
      expect_same_as_line_by_line(bad, name + "_hostile", threads);
    }
    // Large: two threads from 2 MB on (one where only one is allowed).
    for (int threads : {1, 2}) {
      expect_same_as_line_by_line(at_least(text, 3u << 20), name + "_large", threads);
      expect_same_as_line_by_line(at_least(bad, 3u << 20), name + "_hostile_large", threads);
    }
  }
}

// Stopping at the first bad line: the same error from a large file on two threads as from the
// text, and every event before it delivered.
TEST(ScanFile, StopOnErrorGivesTheSameErrorAndEventsOnTwoThreads) {
  std::string text = at_least(ours(3), 3u << 20);
  const std::size_t at = text.size() * 2 / 3;
  text.insert(text.find('\n', at) + 1, "G1 X1 X2\n");
  const Temp file(text, "stop");
  GcodeReadOptions opt;
  opt.stop_on_error = true;
  auto run = [&](bool from_file) {
    LogSink sink;
    Diagnostics d;
    std::string what;
    try {
      if (from_file) {
        scan_gcode_file(file.path, sink, opt, d);
      } else {
        GcodeScanner scanner(sink, opt, d, file.path);
        scanner.feed(text);
        scanner.finish();
      }
    } catch (const ParseError& e) {
      what = e.what();
    }
    return std::make_pair(what, sink.log);
  };
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
  const auto [file_error, file_log] = run(true);
  const auto [text_error, text_log] = run(false);
  EXPECT_NE(text_error, "");
  EXPECT_EQ(file_error, text_error);
  EXPECT_TRUE(file_log == text_log);
  EXPECT_GT(file_log.size(), 1000u);
}

// A sink that throws part-way: the exception reaches the caller of a two-thread scan, and no
// event after it is delivered.
TEST(ScanFile, ASinkThatThrowsStopsTheScan) {
  struct Throwing : LogSink {
    long moves = 0;
    void motion(Vec3 a, Vec3 b, double de, double f) override {
      if (++moves == 50000) throw std::runtime_error("enough");
      LogSink::motion(a, b, de, f);
    }
  };
  const std::string text = at_least(ours(5), 3u << 20);
  const Temp file(text, "throw");
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
  Throwing sink;
  Diagnostics d;
  EXPECT_THROW(scan_gcode_file(file.path, sink, {}, d), std::runtime_error);
  EXPECT_EQ(sink.moves, 50000);
  Throwing again;
  GcodeScanner scanner(again, {}, d, file.path);
  EXPECT_THROW(scanner.feed(text), std::runtime_error);
  EXPECT_TRUE(sink.log == again.log);
}

// A file another program changes while it is read: an error naming the file (a mapped file cut
// short ended the process with SIGBUS), on one thread and on two, with every event before it
// delivered. The sink changes the file at the first move, when at most 2 MB of it has been read
// (sixteen 128 kB windows ahead on two threads): shortened to 4 MB, the read past that finds
// the end; lengthened, the size read is no longer the file's.
TEST(ScanFile, AFileChangedWhileReadIsAnErrorNamingIt) {
  const std::string text = at_least(ours(9), 8u << 20);
  struct Changing : GcodeSink {
    std::string path;
    bool shorten = true;
    long moves = 0;
    void motion(Vec3, Vec3, double, double) override {
      if (++moves > 1) return;
      if (shorten)
        fs::resize_file(path, 4u << 20);
      else
        std::ofstream(path, std::ios::binary | std::ios::app) << "G1 X1 Y1\n";
    }
  };
  for (const bool shorten : {true, false})
    for (const int threads : {1, 2}) {
      const std::string label =
          std::string(shorten ? "shortened" : "lengthened") + ", " + std::to_string(threads);
      const Temp file(text, "changed_" + std::to_string(shorten) + std::to_string(threads));
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                      static_cast<std::size_t>(threads));
      Changing sink;
      sink.path = file.path;
      sink.shorten = shorten;
      Diagnostics d;
      std::string where, what;
      try {
        scan_gcode_file(file.path, sink, {}, d);
      } catch (const IoError& e) {
        where = e.where().file;
        what = e.message();
      }
      EXPECT_EQ(where, file.path) << label;
      EXPECT_NE(what.find("changed while it was read"), std::string::npos) << label << ": " << what;
      // The moves of what was read before (at least the 4 MB left), all delivered.
      EXPECT_GT(sink.moves, 40000) << label;
    }
}
