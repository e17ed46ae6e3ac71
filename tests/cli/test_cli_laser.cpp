// The laser route from the command line: the paper's wall experiment with its per-layer report,
// binary CLI, and `analyze` on a build file — including a broken one (exit 2, file and offset).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "trellis/core/file.hpp"

namespace fs = std::filesystem;

namespace {

struct CmdRun {
  int code;
  std::string out, err;
};

fs::path dir() {
  static const fs::path d = [] {
    // One directory per process: other checkouts on the machine run the same tests.
    const fs::path p =
        fs::temp_directory_path() / ("trellis_cli_laser_test_" + std::to_string(getpid()));
    fs::remove_all(p);
    fs::create_directories(p);
    return p;
  }();
  return d;
}

CmdRun run(const std::string& args) {
  const std::string out = (dir() / "out.txt").string(), err = (dir() / "err.txt").string();
  const int status =
      std::system((std::string(TRELLIS_CLI) + " " + args + " >" + out + " 2>" + err).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, trellis::read_file(out),
          trellis::read_file(err)};
}

std::string path(const std::string& name) {
  return (dir() / name).string();
}

TEST(CliLaser, WallExperimentReportsTheLayerSeriesAndAnalyzeReadsItBack) {
  CmdRun r =
      run("pbf --wall-thickness 0.2 --wall-inclination 60 --size 1,1,0.4 --binary -o " +
          path("wall.cli") + " --report " + path("wall.json") + " --preview " + path("prev"));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(trellis::read_file(path("wall.json")));
  const auto& s = j["per_layer"];
  ASSERT_EQ(s["z_mm"].size(), 20u);
  for (const char* k :
       {"fr_a", "fr_a_r67", "contour_mm", "hatch_mm", "area_mm2", "scan_time_s", "scan_time_r67_s"})
    EXPECT_EQ(s[k].size(), 20u) << k;
  EXPECT_GT(j["scan_time_s"]["r67_baseline"].get<double>(), 0);
  EXPECT_TRUE(fs::exists(path("prev/fr_a.png")));
  // The vcad of the same wall: a 60° plane slab in the same box.
  std::ofstream(path("wall.vcad")) << "root((-0.5,-0.5,-0.2), (0.5,0.5,0.2), (0.01,0.01,0.01)) {\n"
                                      "  intersection() {\n    rectprism(1, 1, 0.4);\n"
                                      "    function((-1,-1,-1), (1,1,1), "
                                      "\"abs(0.8660254037844386*y - 0.5*z) - 0.1\");\n  }\n}\n";
  r = run("analyze " + path("wall.cli") + " --design " + path("wall.vcad") + " --report " +
          path("an.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto a = nlohmann::json::parse(trellis::read_file(path("an.json")));
  EXPECT_EQ(a["outside_vectors"].get<int>(), 0) << r.out;
  EXPECT_GT(a["vectors"].get<int>(), 10);
  EXPECT_NEAR(a["fr_a"]["mean"].get<double>(), j["fr_a"]["mean"].get<double>(),
              0.03 * j["fr_a"]["mean"].get<double>());
}

TEST(CliLaser, BrokenBuildFileExits2WithFileAndOffset) {
  const std::string bad =
      "$$HEADERSTART\n$$ASCII\n$$UNITS/0.001\n$$HEADEREND\n$$GEOMETRYSTART\n$$LAYER/20\n"
      "$$HATCHES/2,1,0,0,1\n$$GEOMETRYEND\n";
  std::ofstream(path("bad.cli")) << bad;
  const CmdRun r = run("analyze " + path("bad.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.cli"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("offset " + std::to_string(bad.find("$$HATCHES"))), std::string::npos)
      << r.err;
}

}  // namespace

// `analyze` of a .cli with a machine profile times it with the profile's scanner: the layers'
// times add up to the total, the total is marks + jumps + delays, and a laser on + off delay of
// 100 µs adds exactly 100 µs per vector (the vector count read back from the file).
TEST(CliLaser, AnalyzeTimesABuildFileWithTheProfilesDelays) {
  CmdRun r = run("pbf --cell 2.5 --size 2.5,2.5,0.2 -o " + path("g.cli"));
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string profile = std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_25um.toml";
  std::string slow = trellis::read_file(profile);
  for (const auto& [from, to] :
       {std::pair<std::string, std::string>{"laser_on_delay = 0", "laser_on_delay = 40"},
        {"laser_off_delay = 0", "laser_off_delay = 60"}}) {
    const auto at = slow.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    slow.replace(at, from.size(), to);
  }
  std::ofstream(path("slow.toml")) << slow;
  r = run("analyze " + path("g.cli") + " --machine " + profile + " --report " + path("a.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  r = run("analyze " + path("g.cli") + " --machine " + path("slow.toml") + " --report " +
          path("b.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto a = nlohmann::json::parse(trellis::read_file(path("a.json")));
  const auto b = nlohmann::json::parse(trellis::read_file(path("b.json")));
  const auto& t = a["scan_time"];
  double sum = 0;
  for (const auto& v : t["per_layer_s"]) sum += v.get<double>();
  EXPECT_EQ(t["per_layer_s"].size(), a["layers"].get<std::size_t>());
  EXPECT_NEAR(sum, t["total_s"].get<double>(), 1e-9);
  EXPECT_NEAR(t["mark_s"].get<double>() + t["jump_s"].get<double>() + t["delay_s"].get<double>(),
              t["total_s"].get<double>(), 1e-9);
  EXPECT_GT(t["jumps"].get<std::size_t>(), 10u);
  const double vectors = a["vectors"].get<double>();
  EXPECT_NEAR(b["scan_time"]["total_s"].get<double>(),
              t["total_s"].get<double>() + vectors * 100e-6, 1e-9);
}
