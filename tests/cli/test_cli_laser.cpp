// The laser route from the command line: the paper's wall experiment with its per-layer report,
// binary CLI, and `analyze` on a build file — including a broken one (exit 2, file and offset);
// lasers that differ in the .cli, 3MF and toolpath JSON, skywriting per laser.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "trellis/core/file.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/settings/settings.hpp"
#include "trellis/toolpath/json.hpp"

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

// A solid part with skin, core, up-skin, down-skin and a parameter set per contour, through the
// command line: the report's region areas add up to the layers' areas; `analyze` with the profile
// finds every parameter set in the .cli and in the 3MF (the same vectors per set), its per-set
// times adding up to the total; the kinds' own settings are refused where they are not used.
TEST(CliLaser, SolidPartRegionKindsAndParameterSetsReadBack) {
  const std::string profile = std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_25um.toml";
  const std::string part = std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/bracket_20mm.stl";
  const std::string common =
      "pbf " + part + " --machine " + profile +
      " --layer-height 0.25 --strategy island --contours 2 --set laser.contour_powers=70,90"
      " --set laser.contour_speeds=700,900 --set pbf.skin_thickness=0.75"
      " --set pbf.upskin_thickness=0.5 --set pbf.downskin_thickness=0.5"
      " --set laser.core_power=180 --set laser.core_speed=1200 --set pbf.core_hatch_distance=0.08";
  for (const char* ext : {"cli", "3mf"}) {
    CmdRun r = run(common + " -o " + path(std::string("b.") + ext) + " --report " +
                   path(std::string("b_") + ext + ".json"));
    ASSERT_EQ(r.code, 0) << r.err;
  }
  const auto rep = nlohmann::json::parse(trellis::read_file(path("b_cli.json")));
  double layers_area = 0, kinds_area = 0;
  for (const auto& a : rep["per_layer"]["area_mm2"]) layers_area += a.get<double>();
  for (const char* k : {"skin", "core", "upskin", "downskin"}) {
    EXPECT_GT(rep["regions"][k]["area_mm2"].get<double>(), 0) << k;
    EXPECT_GT(rep["regions"][k]["hatch_mm"].get<double>(), 0) << k;
    kinds_area += rep["regions"][k]["area_mm2"].get<double>();
  }
  EXPECT_NEAR(kinds_area, layers_area, 1e-6 * layers_area);
  std::map<std::string, std::pair<double, double>> sets[2];  // "hatch 180 1200" → vectors, time
  for (int f = 0; f < 2; ++f) {
    const std::string file = path(f ? "b.3mf" : "b.cli");
    CmdRun r = run("analyze " + file + " --machine " + profile + " --report " + path("a.json"));
    ASSERT_EQ(r.code, 0) << r.err;
    const auto a = nlohmann::json::parse(trellis::read_file(path("a.json")));
    double sum = 0;
    for (const auto& s : a["parameter_sets"]) {
      const std::string key = s["kind"].get<std::string>() + " " +
                              std::to_string(s["power_w"].get<int>()) + " " +
                              std::to_string(s["speed_mm_s"].get<int>());
      sets[f][key] = {s["vectors"].get<double>(), s["scan_time_s"].get<double>()};
      sum += s["scan_time_s"].get<double>();
    }
    EXPECT_NEAR(sum, a["scan_time"]["total_s"].get<double>(), 1e-6) << file;
  }
  // The contours' two sets, the core's, the profile's up-skin and down-skin, the skin hatch.
  for (const char* key : {"contour 70 700", "contour 90 900", "hatch 180 1200", "hatch 100 800",
                          "hatch 60 1000", "hatch 100 1000"}) {
    ASSERT_EQ(sets[0].count(key), 1u) << key;
    EXPECT_GT(sets[0][key].first, 0) << key;
    EXPECT_EQ(sets[0][key].first, sets[1][key].first) << key << ": .cli and 3MF differ";
  }
  EXPECT_EQ(sets[0].size(), 6u);
  const std::string cli = trellis::read_file(path("b.cli"));
  for (const char* label :
       {"contour 1", "contour 2", "core hatch", "upskin hatch", "downskin hatch"})
    EXPECT_NE(cli.find(std::string(",") + label + "\n"), std::string::npos) << label;
  // Refused where unused: a core power without a core, a power per contour not matching them.
  CmdRun r = run("pbf " + part + " --machine " + profile +
                 " --layer-height 0.25 --set laser.core_power=150 -o " + path("c.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("laser.core_power"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("pbf.skin_thickness"), std::string::npos) << r.err;
  r = run("pbf " + part + " --machine " + profile +
          " --layer-height 0.25 --contours 3 --set laser.contour_powers=60,80 -o " + path("c.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("laser.contour_powers"), std::string::npos) << r.err;
  r = run("pbf --cell 2.5 --size 2.5,2.5,0.2 --set pbf.skin_thickness=0.5 -o " + path("g.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("pbf.skin_thickness"), std::string::npos) << r.err;
}

// Lasers that differ (profiles/pbf_316l_2laser_unequal.toml): the build's lasers are balanced on
// their own speeds and delays; `analyze` of its .cli and 3MF times each laser as the route did,
// with the profile or from the file's own laser values alone; a [lasers] list of the wrong length
// exits 2 naming its key.
TEST(CliLaser, LasersThatDifferAreBalancedWrittenAndTimedBack) {
  const std::string profile =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_2laser_unequal.toml";
  const std::string base = "pbf --cell 2.5 --size 5,5,0.4 --machine " + profile;
  CmdRun r = run(base + " -o " + path("u.cli") + " --report " + path("u.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(run(base + " -o " + path("u.3mf")).code, 0);
  const auto j = nlohmann::json::parse(trellis::read_file(path("u.json")));
  const auto made = j["lasers"]["scan_time_s"].get<std::vector<double>>();
  ASSERT_EQ(made.size(), 2u);
  EXPECT_LT(std::max(made[0], made[1]) / std::min(made[0], made[1]), 1.1);
  for (const std::string& file : {path("u.cli"), path("u.3mf")})
    for (const std::string& machine : {" --machine " + profile, std::string()}) {
      r = run("analyze " + file + machine + " --report " + path("a.json"));
      ASSERT_EQ(r.code, 0) << r.err;
      const auto a = nlohmann::json::parse(trellis::read_file(path("a.json")));
      const auto read = a["lasers"]["scan_time_s"].get<std::vector<double>>();
      ASSERT_EQ(read.size(), 2u) << file << machine;
      // The file orders each laser's paths its own way (contours first): jumps differ a little.
      for (int l = 0; l < 2; ++l) EXPECT_NEAR(read[l], made[l], 0.03 * made[l]) << file << machine;
    }
  r = run(base + " --set lasers.hatch_speed=1000,900,800 -o " + path("w.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("lasers.hatch_speed"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("3 values for 2 laser(s)"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("w.cli")));
}

namespace {

// The lasers a profile declares, read through the settings schema as `trellis pbf` reads them.
std::vector<trellis::LaserParameters> profile_lasers(const std::string& profile,
                                                     const std::string& set = "") {
  trellis::Settings s;
  s.load_toml_file(profile);
  if (!set.empty())
    s.set_text(set.substr(0, set.find('=')), set.substr(set.find('=') + 1), {"--set"});
  return trellis::laser_parameters(s.config().laser);
}

std::vector<double> laser_seconds(const std::string& report) {
  return nlohmann::json::parse(trellis::read_file(report))["lasers"]["scan_time_s"]
      .get<std::vector<double>>();
}

}  // namespace

// The lasers that differ in the toolpath JSON (issue 43): `pbf --toolpath` writes the profile's
// lasers, the JSON, the .cli and the 3MF read them back equal; `analyze` of the JSON times each
// laser as the route did, and as `analyze` of the .cli does for the same paths (the .cli read back
// and written as JSON).
TEST(CliLaser, LasersOfTheToolpathJsonReadBackAndAreTimedAsTheCli) {
  const std::string profile =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_2laser_unequal.toml";
  const std::string base = "pbf --cell 2.5 --size 5,5,0.4 --machine " + profile;
  CmdRun r = run(base + " -o " + path("j.cli") + " --toolpath " + path("j.json") + " --report " +
                 path("jr.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(run(base + " -o " + path("j.3mf")).code, 0);
  const auto want = profile_lasers(profile);
  ASSERT_EQ(want.size(), 2u);
  EXPECT_EQ(trellis::read_toolpath(path("j.json")).lasers, want);
  EXPECT_EQ(trellis::read_cli_file(path("j.cli")).lasers, want);
  EXPECT_EQ(trellis::read_toolpath_3mf_file(path("j.3mf")).lasers, want);
  // The route's toolpath as written: each laser's time as the route balanced it.
  r = run("analyze " + path("j.json") + " --report " + path("ja.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("2 lasers scan"), std::string::npos) << r.out;
  const std::vector<double> made = laser_seconds(path("jr.json")),
                            json = laser_seconds(path("ja.json"));
  ASSERT_EQ(json.size(), 2u);
  for (int l = 0; l < 2; ++l) EXPECT_NEAR(json[l], made[l], 1e-6 * made[l]) << "laser " << l;
  // The .cli's paths (its own order, µm coordinates) as a toolpath JSON: analyze times both alike.
  trellis::write_toolpath(path("from_cli.json"), trellis::read_cli_file(path("j.cli")));
  ASSERT_EQ(run("analyze " + path("j.cli") + " --report " + path("jc.json")).code, 0);
  ASSERT_EQ(run("analyze " + path("from_cli.json") + " --report " + path("jf.json")).code, 0);
  const std::vector<double> cli = laser_seconds(path("jc.json")),
                            again = laser_seconds(path("jf.json"));
  ASSERT_EQ(cli.size(), 2u);
  for (int l = 0; l < 2; ++l) EXPECT_NEAR(again[l], cli[l], 1e-9 * cli[l]) << "laser " << l;
}

// Skywriting per laser ([lasers] skywriting): said in the .cli, the 3MF and the toolpath JSON and
// read back; `analyze` from the file's lasers charges the laser that skywrites its skywriting time
// instead of its mark delay per vector, the other laser's time unchanged; with the profile (--set
// over it, [lasers] now read by analyze) the same. A list of the wrong length exits 2 naming it.
TEST(CliLaser, ALaserThatSkywritesIsWrittenReadBackAndTimedSo) {
  const std::string profile =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_2laser_unequal.toml";
  const std::string sky = "lasers.skywriting=false,true";
  const std::string base = "pbf --cell 2.5 --size 5,5,0.4 --machine " + profile + " --set " + sky;
  CmdRun r = run(base + " -o " + path("s.cli") + " --toolpath " + path("s.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(run(base + " -o " + path("s.3mf")).code, 0);
  const auto want = profile_lasers(profile, sky);
  ASSERT_FALSE(want[0].timing.skywriting);
  ASSERT_TRUE(want[1].timing.skywriting);
  EXPECT_NE(trellis::read_file(path("s.cli")).find("; skywriting on "), std::string::npos);
  const trellis::Toolpath cli = trellis::read_cli_file(path("s.cli"));
  EXPECT_EQ(cli.lasers, want);
  EXPECT_EQ(trellis::read_toolpath(path("s.json")).lasers, want);
  EXPECT_EQ(trellis::read_toolpath_3mf_file(path("s.3mf")).lasers, want);
  ASSERT_EQ(run("analyze " + path("s.cli") + " --report " + path("sf.json")).code, 0);
  ASSERT_EQ(
      run("analyze " + path("s.cli") + " --machine " + profile + " --report " + path("sp.json"))
          .code,
      0);
  r = run("analyze " + path("s.cli") + " --machine " + profile + " --set " + sky + " --report " +
          path("ss.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const std::vector<double> file = laser_seconds(path("sf.json")),
                            plain = laser_seconds(path("sp.json")),
                            set = laser_seconds(path("ss.json"));
  std::size_t vectors = 0;  // laser 2's
  for (const auto& l : cli.layers)
    for (const auto& p : l.paths) vectors += p.tool == 1 ? 1 : 0;
  ASSERT_GT(vectors, 0u);
  const auto& t = want[1].timing;
  EXPECT_NEAR(file[0], plain[0], 1e-9 * plain[0]);
  EXPECT_NEAR(file[1], plain[1] + vectors * (t.skywriting_time - t.mark_delay) * 1e-6,
              1e-9 * plain[1]);
  EXPECT_NE(t.skywriting_time, t.mark_delay);
  for (int l = 0; l < 2; ++l) EXPECT_NEAR(set[l], file[l], 1e-9 * file[l]) << "laser " << l;
  r = run("pbf --cell 2.5 --size 5,5,0.4 --machine " + profile +
          " --set lasers.skywriting=true -o " + path("never.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("lasers.skywriting"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("never.cli")));
}
