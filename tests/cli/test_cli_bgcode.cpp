// Binary G-code from the command line: `-o x.bgcode` (or --binary-gcode) on a machine with
// Prusa's firmware writes a file whose G-code blocks are the text G-code of the same run (less
// its thumbnail comments), for the whole-toolpath writer and the streamed slicer alike; analyze
// and check read it to the same numbers as the text; rerun regenerates it byte for byte; other
// firmwares are refused (exit 2, named, no file).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "support/cli_run.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/bgcode.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;
const std::string kPrusa = kRoot + "/profiles/prusa_mk4s_lwpla.toml";
const std::string kVoron = kRoot + "/profiles/voron_klipper.toml";

fs::path work() {
  return trellis::test::scratch("trellis_cli_bgcode");
}
std::string at(const std::string& name) {
  return (work() / name).string();
}
trellis::test::CliRun run(const std::string& args) {
  return trellis::test::run_cli(args, work());
}

// The G-code blocks of a .bgcode joined.
std::string gcode_of(const std::string& path) {
  std::string out;
  for (const auto& b : trellis::bgcode_blocks(trellis::read_file(path), path))
    if (b.type == trellis::BgcodeBlock::Gcode) out += b.data;
  return out;
}

// Every ";\n; thumbnail begin ... ; thumbnail end\n;\n" block cut out (by search, not std::regex:
// its matcher recurses once per character and overflowed the stack on a whole file under ASan).
std::string without_thumbnails(const std::string& text) {
  static const std::string begin = ";\n; thumbnail begin", end = "; thumbnail end\n;\n";
  std::string out;
  std::size_t at = 0;
  for (std::size_t b; (b = text.find(begin, at)) != std::string::npos;) {
    const std::size_t e = text.find(end, b + begin.size());
    if (e == std::string::npos) break;
    out.append(text, at, b - at);
    at = e + end.size();
  }
  return out.append(text, at, std::string::npos);
}

// A command's output with the two file names made one.
std::string same_names(std::string s, const std::string& a, const std::string& b) {
  for (std::size_t p; (p = s.find(b)) != std::string::npos;) s.replace(p, b.size(), a);
  return s;
}

}  // namespace

TEST(CliBgcode, PlannedToolpathAnalyzesAndChecksAsItsText) {
  const std::string lat = at("l.json"), tp = at("l.tp.json"), gc = at("l.gcode"),
                    bg = at("l.bgcode");
  ASSERT_EQ(run("lattice2d --pattern triangle --cell 4 --size 20,20 -o " + lat).code, 0);
  ASSERT_EQ(run("plan euler " + lat + " -o " + tp).code, 0);
  auto r = run("gcode " + tp + " --machine " + kPrusa + " -o " + gc);
  ASSERT_EQ(r.code, 0) << r.err;
  r = run("gcode " + tp + " --machine " + kPrusa + " -o " + bg);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string text = trellis::read_file(gc);
  ASSERT_NE(text.find("; thumbnail begin"), std::string::npos);
  EXPECT_TRUE(gcode_of(bg) == same_names(without_thumbnails(text), "l.bgcode", "l.gcode"));
  EXPECT_LT(fs::file_size(bg), fs::file_size(gc));
  for (const std::string& cmd :
       {"analyze {} --design " + lat + " --align", "check " + lat + " {}"}) {
    const auto with = [&](const std::string& f) {
      return std::regex_replace(cmd, std::regex("\\{\\}"), f);
    };
    const auto a = run(with(gc)), b = run(with(bg));
    EXPECT_EQ(a.code, b.code) << cmd << "\n" << b.err;
    EXPECT_EQ(same_names(a.out, "F", gc), same_names(b.out, "F", bg)) << cmd;
    EXPECT_FALSE(a.out.empty()) << cmd;
  }
  // The job in the G-code blocks' header: rerun makes the same file.
  r = run("rerun " + bg + " -o " + at("again.bgcode"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(trellis::read_file(at("again.bgcode")) == trellis::read_file(bg));
}

TEST(CliBgcode, StreamedSliceAndBinaryGcodeFlag) {
  const std::string vase = kRoot + "/examples/designs/Vase.stl";
  const std::string gc = at("v.gcode"), bg = at("v.bgcode");
  const std::string slice = "slice " + vase + " --machine " + kPrusa + " --layer-height 0.3 ";
  auto r = run(slice + "-o " + gc);
  ASSERT_EQ(r.code, 0) << r.err;
  r = run(slice + "-o " + bg);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(gcode_of(bg) ==
              same_names(without_thumbnails(trellis::read_file(gc)), "v.bgcode", "v.gcode"));
  const auto a = run("analyze " + gc), b = run("analyze " + bg);
  ASSERT_EQ(b.code, 0) << b.err;
  EXPECT_EQ(same_names(a.out, "F", gc), same_names(b.out, "F", bg));
  // The viewer's page: the same moves, told apart only by name and kind.
  ASSERT_EQ(run("view " + gc + " -o " + at("g.html")).code, 0);
  ASSERT_EQ(run("view " + bg + " -o " + at("b.html")).code, 0);
  EXPECT_TRUE(same_names(trellis::read_file(at("g.html")), "v.gcode", "v.bgcode") ==
              same_names(same_names(trellis::read_file(at("b.html")), "v.gcode", "v.bgcode"),
                         "\"kind\":\"gcode\"", "\"kind\":\"bgcode\""));
  // --binary-gcode (gcode.binary) writes the same format, and wants the name to say so.
  r = run(slice + "--binary-gcode -o " + at("flag.bgcode"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(trellis::is_bgcode(trellis::read_file(at("flag.bgcode"))));
  r = run(slice + "--binary-gcode -o " + at("x.gcode"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("gcode.binary"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(at("x.gcode")));
}

TEST(CliBgcode, OtherFirmwaresAreRefused) {
  const std::string vase = kRoot + "/examples/designs/Vase.stl";
  const auto r = run("slice " + vase + " --machine " + kVoron + " -o " + at("voron.bgcode"));
  EXPECT_EQ(r.code, 2);
  for (const char* w : {"machine.firmware", "klipper", ".bgcode"})
    EXPECT_NE(r.err.find(w), std::string::npos) << w << "\n" << r.err;
  EXPECT_FALSE(fs::exists(at("voron.bgcode")));
}

TEST(CliBgcode, ShardsMergeIntoTheFileOneProcessWrites) {
  const std::string job = at("v.toml");
  std::ofstream(job) << "[job]\nroute = \"slice\"\nname = \"v\"\ninput = \"" << kRoot
                     << "/examples/designs/Vase.stl\"\nmachine = \"" << kPrusa
                     << "\"\noutput = \"s.bgcode\"\noutput_dir = \"" << work().string()
                     << "/jobout\"\n[extrusion]\nlayer_height = 0.3\n[output]\npng = false\n";
  for (const char* k : {"1/2", "2/2"}) ASSERT_EQ(run("run " + job + " --shard " + k).code, 0) << k;
  const std::string shards = at("jobout/s.bgcode.shard-");
  auto r = run("merge " + shards + "1-of-2.json " + shards + "2-of-2.json -o " +
               at("jobout/merged.bgcode"));
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(run("run " + job).code, 0);
  EXPECT_TRUE(trellis::is_bgcode(trellis::read_file(at("jobout/merged.bgcode"))));
  EXPECT_TRUE(trellis::read_file(at("jobout/merged.bgcode")) ==
              trellis::read_file(at("jobout/s.bgcode")));
}
