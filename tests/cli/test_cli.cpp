// Runs the trellis binary as a user would: exit codes, messages, outputs.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "support/gcode_replay.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/file.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/job/job.hpp"
#include "trellis/settings/settings.hpp"
#include "trellis/toolpath/json.hpp"

namespace fs = std::filesystem;

namespace {

struct CmdResult {
  int code;
  std::string out, err;
};

// One private folder per test process (removed at exit): runs in parallel never collide.
const fs::path& work() {
  static const trellis::test::TempDir dir("trellis_cli_test");
  return dir.path();
}

CmdResult run(const std::string& args) {
  const std::string out = (work() / "stdout.txt").string(), err = (work() / "stderr.txt").string();
  const std::string cmd = std::string(TRELLIS_CLI) + " " + args + " >" + out + " 2>" + err;
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, trellis::read_file(out),
          trellis::read_file(err)};
}

std::string write(const std::string& name, const std::string& text) {
  const fs::path p = work() / name;
  std::ofstream(p) << text;
  return p.string();
}

std::string in_work(const std::string& name) {
  return (work() / name).string();
}

// A JSON report without the command line it records.
std::string without_job(const std::string& path) {
  auto j = nlohmann::json::parse(trellis::read_file(path));
  j.erase("command");  // the command lines differ (--threads 1 or 2)
  return j.dump(1);
}

}  // namespace

TEST(Cli, HelpForEveryCommand) {
  for (const char* c :
       {"", "lattice2d", "lattice3d", "plan", "gcode", "render", "run", "analyze", "compare",
        "slice", "pbf", "check", "nonplanar", "surface", "rerun", "settings", "walls"}) {
    const CmdResult r = run(std::string(c) + " --help");
    EXPECT_EQ(r.code, 0) << c;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << c;
  }
  const CmdResult s = run("settings extrusion");
  EXPECT_EQ(s.code, 0);
  EXPECT_NE(s.out.find("extrusion.nozzle_diameter"), std::string::npos);
}

TEST(Cli, DocumentedPipelineWorksAsWritten) {
  const std::string lat = in_work("hc.json"), tp = in_work("hc.toolpath.json"),
                    rep = in_work("hc.report.json");
  ASSERT_EQ(run("lattice2d --pattern honeycomb --cell 1 -o " + lat).code, 0);
  CmdResult r = run("plan gippo " + lat + " -o " + tp + " --report " + rep +
                    " --mode min --iterations 50 --seed 4");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string report = trellis::read_file(rep);
  for (const char* key :
       {"\"planner\"", "\"mode\"", "\"iterations\"", "\"seed\"", "\"paths\"",
        "\"lower_bound_paths\"", "\"score\"", "\"lts\"", "\"oe\"", "\"total_length_mm\"",
        "\"travel_moves\"", "\"travel_length_mm\"", "\"warnings\""})
    EXPECT_NE(report.find(key), std::string::npos) << key;
  r = run("plan euler " + lat + " -o " + in_work("hc.euler.json") + " --report " +
          in_work("e.json") + " --order travel");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string gc = in_work("hc.gcode");
  r = run("gcode " + tp + " --machine " + TRELLIS_SOURCE_DIR +
          "/profiles/ender3_s1_pro_tpu.toml -o " + gc);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(trellis::test::replay_gcode(trellis::read_file(gc)).deposits.empty());
  r = run("render " + tp + " -o " + in_work("hc.png"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(in_work("hc.layer000.png")));
}

TEST(Cli, PrintedWhereTheCoordinatesSayUnlessCentred) {
  const std::string lat = in_work("corner.json"), tp = in_work("corner.tp.json");
  ASSERT_EQ(run("lattice2d --pattern square --cell 1 --size 6,4 -o " + lat).code, 0);
  ASSERT_EQ(run("plan euler " + lat + " -o " + tp).code, 0);
  const std::string profile = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  for (bool centre : {false, true}) {
    const std::string gc = in_work(centre ? "c.gcode" : "nc.gcode");
    ASSERT_EQ(run("gcode " + tp + " --machine " + profile + " -o " + gc +
                  (centre ? "" : " --set placement.center=false"))
                  .code,
              0);
    double lo = 1e9, hi = -1e9;
    for (const auto& d : trellis::test::replay_gcode(trellis::read_file(gc)).deposits) {
      lo = std::min({lo, d.x0, d.x1});
      hi = std::max({hi, d.x0, d.x1});
    }
    EXPECT_NEAR(lo, centre ? 110 - 3 : 0, 1e-9);
    EXPECT_NEAR(hi, centre ? 110 + 3 : 6, 1e-9);
  }
}

TEST(Cli, SameSeedByteIdenticalAcrossThreadCounts) {
  const std::string lat = in_work("v.json");
  ASSERT_EQ(run("lattice2d --pattern voronoi --density 2 --seed 3 -o " + lat).code, 0);
  ASSERT_EQ(
      run("plan gippo " + lat + " -o " + in_work("v1.json") + " --threads 1 --iterations 80").code,
      0);
  ASSERT_EQ(
      run("plan gippo " + lat + " -o " + in_work("v2.json") + " --threads 2 --iterations 80").code,
      0);
  EXPECT_EQ(trellis::read_file(in_work("v1.json")), trellis::read_file(in_work("v2.json")));
  ASSERT_EQ(run("plan gippo " + lat + " -o " + in_work("v3.json") +
                " --threads 1 --iterations 80 --report " + in_work("r1.json"))
                .code,
            0);
  ASSERT_EQ(run("plan gippo " + lat + " -o " + in_work("v4.json") +
                " --threads 2 --iterations 80 --report " + in_work("r2.json"))
                .code,
            0);
  EXPECT_EQ(without_job(in_work("r1.json")), without_job(in_work("r2.json")));
}

TEST(Cli, BadInputExitsTwoWithOneClearMessageAndNoOutput) {
  struct Case {
    std::string file, text, expect;
  };
  const std::vector<Case> cases = {
      {"bad_number.csv", "0,0,0,1,0,0\n0,0,0,1,x,0\n", "bad_number.csv:2"},
      {"missing_col.csv", "0,0,0,1,0\n", "missing_col.csv:1"},
      {"nan.csv", "0,0,0,NaN,0,0\n", "nan.csv:1"},
      {"empty.json", "", "empty.json:1"},
      {"range.json", "{\"nodes\":[[0,0,0]],\"edges\":[[0,3]]}", "edges[0]"},
      {"pair_vertices.csv", "0,0,0\n1,1,1\n", "pair_edges.csv:2"},
  };
  write("pair_edges.csv", "0,1\n1,7\n");
  for (const auto& c : cases) {
    const std::string in = write(c.file, c.text), out = in_work("never.json");
    const CmdResult r = run("plan euler " + in + " -o " + out);
    EXPECT_EQ(r.code, 2) << c.file;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.file << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.file;
  }
  // The pair's edges file names the line with the bad index.
  EXPECT_NE(run("plan euler " + in_work("pair_vertices.csv") + " -o " + in_work("x.json"))
                .err.find("pair_edges.csv:2"),
            std::string::npos);
  // Unknown key in a profile: file and line.
  const std::string prof = write("bad.toml", "[speed]\nprint = 10\nprnt = 3\n");
  ASSERT_EQ(run("lattice2d -o " + in_work("l.json")).code, 0);
  ASSERT_EQ(run("plan euler " + in_work("l.json") + " -o " + in_work("l.tp.json")).code, 0);
  const CmdResult r =
      run("gcode " + in_work("l.tp.json") + " --machine " + prof + " -o " + in_work("never.gcode"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.toml:3"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(in_work("never.gcode")));
  EXPECT_EQ(
      run("plan gippo " + in_work("l.json") + " -o " + in_work("x.json") + " --iterations 0").code,
      2);
  EXPECT_EQ(run("lattice2d --pattern hexagons -o " + in_work("never2.json")).code, 2);
  EXPECT_FALSE(fs::exists(in_work("never2.json")));
}

TEST(Cli, JobRunsEndToEnd) {
  const std::string job = write(
      "job.toml", std::string("[job]\nroute = \"plan\"\nname = \"t\"\nmachine = \"") +
                      TRELLIS_SOURCE_DIR +
                      "/profiles/pneumatic_pcl_27g.toml\"\n[lattice2d]\npattern = \"snub-square\"\n"
                      "size = [6, 6]\n[layers]\ncount = 3\nrotation = 30\n"
                      "[gippo]\niterations = 30\n[output]\npreview_layers = 3\n");
  const CmdResult r = run("run " + job + " -o " + in_work("jobout"));
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"t.lattice.json", "t.toolpath.json", "t.report.json", "t.nc",
                        "t_preview/layer_0002.png", "t_preview/scores.png"})
    EXPECT_TRUE(fs::exists(work() / "jobout" / f)) << f;
  const std::string bad =
      write("badjob.toml",
            "[job]\nroute = \"plan\"\nname = \"t\"\n[lattice2d]\npatern = \"honeycomb\"\n");
  const CmdResult b = run("run " + bad);
  EXPECT_EQ(b.code, 2);
  EXPECT_NE(b.err.find("badjob.toml:5"), std::string::npos) << b.err;
  EXPECT_NE(b.err.find("did you mean lattice2d.pattern"), std::string::npos) << b.err;
}

TEST(Cli, AnalyzeAndCompareOurOwnGcode) {
  const std::string lat = in_work("an.json"), tp = in_work("an.tp.json"), gc = in_work("an.gcode");
  ASSERT_EQ(run("lattice2d --pattern triangle --cell 1 --size 5,5 -o " + lat).code, 0);
  ASSERT_EQ(run("plan euler " + lat + " -o " + tp).code, 0);
  ASSERT_EQ(run("gcode " + tp + " --machine " + std::string(TRELLIS_SOURCE_DIR) +
                "/profiles/ender3_s1_pro_tpu.toml --center -o " + gc)
                .code,
            0);
  CmdResult r =
      run("analyze " + gc + " --design " + lat + " --align --report " + in_work("an.report.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("ratio 1.000, double 0.00 mm, off-design 0.00 mm, missing 0 of"),
            std::string::npos)
      << r.out;
  const std::string report = trellis::read_file(in_work("an.report.json"));
  EXPECT_NE(report.find("\"missing_edges\": 0"), std::string::npos);
  r = run("compare " + lat + " " + gc + " " + gc + " --align --preview " + in_work("cmp"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("ratio"), std::string::npos);
  EXPECT_TRUE(fs::exists(in_work("cmp/an_layer_0000.png")));
  // Garbage lines are warnings naming the line, not crashes.
  const std::string bad = write("bad.gcode", "G1 X1 Y1 E1\nG1 X@@ E2\nG1 X2 Y2 E3\n");
  r = run("analyze " + bad);
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.err.find("bad.gcode:2"), std::string::npos) << r.err;
  EXPECT_EQ(run("analyze " + bad + " --strict").code, 2);
  EXPECT_EQ(run("analyze " + in_work("missing.gcode")).code, 2);
}

TEST(Cli, SliceDesignWritesGcodeReportAndPreviews) {
  const std::string design =
      std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/fgm_column5_ring_radial.vcad";
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  const CmdResult r =
      run("slice " + design + " --machine " + prof + " -o " + in_work("ring.gcode") + " --report " +
          in_work("ring.json") + " --preview " + in_work("ring_png") +
          " --layer-height 0.5 --set extrusion.nozzle_diameter=0.8 --bead-width 0.4 --walls 2 "
          "--infill 0.3 --strategy none");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("field route: 20 layers"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(in_work("ring_png") + "/layer_0000.png"));
  const std::string report = trellis::read_file(in_work("ring.json"));
  EXPECT_NE(report.find("\"layers\": 20"), std::string::npos);
  EXPECT_NE(report.find("\"print_time_s\""), std::string::npos);
  // Read the G-code back: every extruding move lies inside the ring (15 <= rho <= 50 around
  // the bed centre where the design was placed), and extrusion happens on 20 heights.
  const auto g = trellis::test::replay_gcode(trellis::read_file(in_work("ring.gcode")));
  ASSERT_FALSE(g.deposits.empty());
  double cx = 0, cy = 0, n = 0;
  for (const auto& d : g.deposits) {
    cx += d.x0 + d.x1;
    cy += d.y0 + d.y1;
    n += 2;
  }
  cx /= n;
  cy /= n;
  std::set<long> heights;
  for (const auto& d : g.deposits) {
    for (const double rho : {std::hypot(d.x0 - cx, d.y0 - cy), std::hypot(d.x1 - cx, d.y1 - cy)}) {
      EXPECT_GE(rho, 15 - 0.05);
      EXPECT_LE(rho, 50 + 0.05);
    }
    heights.insert(std::lround(d.z0 * 1000));
  }
  EXPECT_EQ(heights.size(), 20u);
  // Reproducible: the same command writes the same bytes.
  // Reproducible from itself: the job in the header regenerates the same bytes.
  const CmdResult again = run("rerun " + in_work("ring.gcode") + " -o " + in_work("ring2.gcode"));
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_EQ(trellis::read_file(in_work("ring.gcode")), trellis::read_file(in_work("ring2.gcode")));
}

TEST(Cli, SliceBadDesignsExitTwoNamingLineAndColumn) {
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  struct Case {
    std::string file, text, expect;
  };
  const std::vector<Case> cases = {
      {"unknown.vcad", "union() {\n  spere(3);\n}\n", "unknown.vcad:2:3: unknown node 'spere'"},
      {"arity.vcad", "cylinder(15);\n", "arity.vcad:1:1: cylinder takes 2 arguments"},
      {"braces.vcad", "difference() {\n cylinder(5, 5);\n", "braces.vcad:1:1: block not closed"},
      {"expr.vcad", "fgrade([\"sin(x\"], [\"a\"]) { sphere(2); }", "expr.vcad:1:"},
      {"nomesh.vcad", "mesh(\"missing.stl\");", "nomesh.vcad:1:6"},
      {"open.stl",
       "solid o\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
       "0\nendloop\nendfacet\nendsolid o\n",
       "open edges"},
  };
  for (const auto& c : cases) {
    const std::string in = write(c.file, c.text), out = in_work("never_slice.gcode");
    const CmdResult r = run("slice " + in + " --machine " + prof + " -o " + out);
    EXPECT_EQ(r.code, 2) << c.file;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.file << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.file;
  }
}

TEST(Cli, PbfWritesACliFileWithTheRightStructure) {
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_25um.toml";
  const CmdResult r =
      run("pbf --cell-type gyroid --cell 2.5 --size 2.5,2.5,1 --layer-height 0.05 --machine " +
          prof + " -o " + in_work("g.cli") + " --report " + in_work("g.json") + " --preview " +
          in_work("g_png") + " --preview-layers 2");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string cli = trellis::read_file(in_work("g.cli"));
  EXPECT_EQ(cli.rfind("$$HEADERSTART\n$$ASCII\n$$UNITS/0.001\n", 0), 0u);
  EXPECT_NE(cli.find("$$LAYERS/20\n$$HEADEREND\n$$GEOMETRYSTART\n"), std::string::npos);
  EXPECT_EQ(cli.substr(cli.size() - 14), "$$GEOMETRYEND\n");
  EXPECT_NE(cli.find("$$GEOMETRYEND\n"), std::string::npos);
  // Every $$POLYLINE and $$HATCHES record has as many coordinates as it says.
  std::istringstream in(cli);
  std::string line;
  std::size_t layers = 0, polylines = 0, hatch_records = 0;
  while (std::getline(in, line)) {
    if (line.rfind("$$LAYER/", 0) == 0) ++layers;
    const bool poly = line.rfind("$$POLYLINE/", 0) == 0, hat = line.rfind("$$HATCHES/", 0) == 0;
    if (!poly && !hat) continue;
    std::vector<double> v;
    std::stringstream ss(line.substr(line.find('/') + 1));
    std::string tok;
    while (std::getline(ss, tok, ',')) v.push_back(std::stod(tok));
    if (poly) {
      ++polylines;
      ASSERT_GE(v.size(), 3u);
      EXPECT_EQ(v[1], 2);  // open line
      EXPECT_EQ(v.size(), 3 + 2 * static_cast<std::size_t>(v[2]));
    } else {
      ++hatch_records;
      ASSERT_GE(v.size(), 2u);
      EXPECT_EQ(v.size(), 2 + 4 * static_cast<std::size_t>(v[1]));
    }
  }
  EXPECT_EQ(layers, 20u);
  EXPECT_GT(polylines, 20u);
  EXPECT_GT(hatch_records, 0u);
  const std::string report = trellis::read_file(in_work("g.json"));
  EXPECT_NE(report.find("\"fr_a_r67_baseline\""), std::string::npos);
  EXPECT_TRUE(fs::exists(in_work("g_png") + "/layer_0000.png"));
}

TEST(Cli, PbfBadInputExitsTwo) {
  const std::string bad_prof =
      write("bad_laser.toml", "[laser]\nhatch_power = 100\nhatch_pwr = 3\n");
  CmdResult r = run("pbf --machine " + bad_prof + " -o " + in_work("never.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad_laser.toml:3"), std::string::npos) << r.err;
  r = run("pbf --cell-type gyriod -o " + in_work("never.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'gyriod' is not allowed"), std::string::npos) << r.err;
  // SL beyond the paper's tested 5–400 µm is planned, with a warning (issue 21).
  r = run("pbf --sl 2 --size 1,1,0.2 -o " + in_work("long_sl.cli"));
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("SL = 2000 µm"), std::string::npos) << r.err;
  r = run("pbf --c \"0.1+\" -o " + in_work("never.cli"));
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(fs::exists(in_work("never.cli")));
}

TEST(Cli, AeroPipelineLatticePlanGcodeCheck) {
  const std::string lat = in_work("octet.json"), tp = in_work("octet_path.json"),
                    rep = in_work("octet_report.json"), nc = in_work("octet.nc");
  const std::string prof =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/embedded_aero_two_nozzle.toml";
  CmdResult r = run("lattice3d --cell-type octet --cell 7 --count 2,2,2 --materials xy-plane -o " +
                    lat + " --preview " + in_work("octet_pv"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("2 material(s)"), std::string::npos) << r.out;
  r = run("plan aero " + lat + " -o " + tp + " --report " + rep + " --preview " + in_work("plan") +
          " --frames 3");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string report = trellis::read_file(rep);
  for (const char* key : {"\"groups\"", "\"trails\"", "\"lower_bound_trails\"", "\"travel_moves\"",
                          "\"travel_length_mm\"", "\"max_trail_edges\"", "\"collisions\": 0",
                          "\"violations\": []", "\"struts_printed_once\": true"})
    EXPECT_NE(report.find(key), std::string::npos) << key;
  for (const char* png :
       {"octet_pv/3d.png", "plan/3d.png", "plan/step_0001.png", "plan/step_0003.png"})
    EXPECT_TRUE(fs::exists(work() / png)) << png;
  r = run("gcode " + tp + " --machine " + prof + " -o " + nc);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("tool changes"), std::string::npos) << r.out;
  r = run("check " + lat + " " + nc + " --machine " + prof + " --report " + in_work("check.json"));
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("0 collisions"), std::string::npos) << r.out;
  // The same struts printed top layer first: the checker finds collisions, exit 1.
  const std::string flat =
      write("flat.json", "{\"nodes\":[[0,0,0],[5,0,0],[0,0,2],[5,0,2]],\"edges\":[[0,1],[2,3]]}");
  const std::string wrong =
      write("wrong.json",
            "{\"format\":\"trellis.toolpath\",\"version\":1,\"layers\":[{\"z\":0,\"paths\":["
            "{\"points\":[[0,0,2],[5,0,2]]},{\"points\":[[0,0,0],[5,0,0]]}]}]}");
  r = run("check " + flat + " " + wrong + " --report " + in_work("wrong_check.json"));
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("1 collisions"), std::string::npos) << r.out;
  EXPECT_NE(trellis::read_file(in_work("wrong_check.json")).find("\"hit_strut\": 1"),
            std::string::npos);
  // Bad input: exit 2 with the file and line.
  write("bad_vertices.csv", "0,0,0\n1,1,x\n");
  write("bad_edges.csv", "0,1\n");
  r = run("plan aero " + in_work("bad_vertices.csv") + " -o " + in_work("never.json"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad_vertices.csv:2"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(in_work("never.json")));
  EXPECT_EQ(run("lattice3d --cell-type octahedral -o " + in_work("never.json")).code, 2);
  EXPECT_EQ(run("plan aero " + lat + " -o x --nozzle-radius -1").code, 2);
  EXPECT_EQ(run("check " + lat + " " + in_work("missing.nc")).code, 2);
}

// The reader commands' flags are the schema's: each offers every flagged setting of its sections
// that its route= conditions allow, and none that they exclude.
TEST(Cli, ReaderFlagsAreTheSchemasSettingsTheyRead) {
  for (const trellis::RouteSpec& reader : trellis::route_specs()) {
    if (!reader.reads) continue;
    const CmdResult r = run(reader.name + " --help");
    ASSERT_EQ(r.code, 0) << reader.name;
    std::size_t offered = 0, withheld = 0;
    for (const trellis::Setting& s : trellis::all_settings()) {
      if (s.flag.empty()) continue;
      const bool own = std::find(reader.sections.begin(), reader.sections.end(), s.section()) !=
                       reader.sections.end();
      if (!own) continue;
      const bool listed = std::regex_search(r.out, std::regex("\\n  --" + s.flag + "[ \\n]"));
      EXPECT_EQ(listed, trellis::route_reads(reader, s)) << reader.name << " --" << s.flag;
      (listed ? offered : withheld) += 1;
      if (listed) EXPECT_NE(r.out.find(s.key), std::string::npos) << reader.name << " " << s.key;
    }
    EXPECT_GT(offered, 0u) << reader.name;
    // Every reader shares the run section and leaves some of it (run.threads) to the routes.
    EXPECT_GT(withheld, 0u) << reader.name;
  }
}

// A setting a reader does not read is refused (exit 2) naming it, never accepted silently:
// another route's section, or one of its own sections' settings its route= condition excludes.
TEST(Cli, ReadersRefuseSettingsTheyDoNotRead) {
  const std::string lat = in_work("rr.json"), tp = in_work("rr.toolpath.json");
  ASSERT_EQ(run("lattice2d --pattern square --cell 2 --size 6,6 -o " + lat).code, 0);
  ASSERT_EQ(run("plan euler " + lat + " -o " + tp).code, 0);
  struct Case {
    std::string args, named;
  };
  for (const Case& c : std::vector<Case>{
           {"check " + lat + " " + tp + " --set slice.seam_seed=3", "[slice]"},
           {"check " + lat + " " + tp + " --set read.strict=true", "read.strict"},
           {"render " + tp + " -o " + in_work("rr.png") + " --set read.commanded_mixtures=true",
            "read.commanded_mixtures"},
           {"compare " + lat + " " + tp + " --set analyze.filament_diameter=2.85",
            "analyze.filament_diameter"},
           {"view " + tp + " -o " + in_work("rr.html") + " --set run.max_time=5", "run.max_time"},
           {"analyze " + tp + " --set render.layer=1", "[render]"}}) {
    const CmdResult r = run(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.err.find(c.named), std::string::npos) << c.args << "\n" << r.err;
  }
  // What they read is taken, from --set as from the flag.
  const CmdResult flag =
      run("check " + lat + " " + tp + " --snap 0.2 --report " + in_work("a.json"));
  const CmdResult set =
      run("check " + lat + " " + tp + " --set check.snap=0.2 --report " + in_work("b.json"));
  ASSERT_EQ(flag.code, 0) << flag.err;
  ASSERT_EQ(set.code, 0) << set.err;
  EXPECT_NE(trellis::read_file(in_work("a.json")).find("\"snap_mm\": 0.2"), std::string::npos);
  EXPECT_EQ(trellis::read_file(in_work("a.json")), trellis::read_file(in_work("b.json")));
}

TEST(Cli, GradedDesignStrategy2WritesMixtures) {
  const std::string d = write("graded.vcad",
                              "fgrade([\"0.5 + x/24\", \"0.5 - x/24\"], [\"a\", \"b\"]) {\n"
                              "  rectprism(20, 10, 0.6);\n}\n");
  const std::string prof =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/geeetech_mizar_m_mixing.toml";
  CmdResult r = run(
      "slice " + d + " --machine " + prof + " -o " + in_work("graded.gcode") +
      " --strategy 2 --colors 4 --layer-height 0.3 --set extrusion.nozzle_diameter=0.4 --report " +
      in_work("graded.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("strategy 2: 4 colours"), std::string::npos) << r.out;
  const std::string g = trellis::read_file(in_work("graded.gcode"));
  for (const char* m :
       {"M165 A0.125 B0.875", "M165 A0.375 B0.625", "M165 A0.625 B0.375", "M165 A0.875 B0.125"})
    EXPECT_NE(g.find(m), std::string::npos) << m;
  EXPECT_NE(trellis::read_file(in_work("graded.json")).find("\"colour_changes\""),
            std::string::npos);
  // One material: a clear error, exit 2.
  const std::string plain = write("plain.vcad", "cube(5);\n");
  r = run("slice " + plain + " --machine " + prof + " -o " + in_work("never.gcode") +
          " --strategy 2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("two or three materials"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(in_work("never.gcode")));
}

// "<route> route: N layers": 10 mm at 0.25 mm is 40 planes; a mesh remade from the distance
// field by marching cubes may lose the plane at its very top.
void expect_layers_of_a_10mm_cube(const std::string& out, const std::string& route) {
  const auto at = out.find(route + " route: ");
  ASSERT_NE(at, std::string::npos) << out;
  const int layers = std::stoi(out.substr(at + route.size() + 8));
  EXPECT_GE(layers, 39) << out;
  EXPECT_LE(layers, 40) << out;
}

// The routes that run in libtrellis's run-time modules, through the CLI from the build tree: a
// .vcad made of a mesh (mesh -> distance field, OpenVDB), the same design by the mesh route
// (field -> mesh, OpenVDB), a 3MF mesh (lib3mf), a preview (cairo); Voronoi (CGAL) is above.
TEST(Cli, RoutesInRuntimeModules) {
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/prusa_mk4s_lwpla.toml";
  trellis::TriangleMesh cube;
  cube.add_prism({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, 0, 10);
  trellis::write_stl(in_work("cube.stl"), cube);
  trellis::write_3mf(in_work("cube.3mf"), cube);
  const std::string design = write("meshed.vcad", "mesh(\"cube.stl\");\n");
  for (const std::string route : {"field", "mesh"}) {
    const std::string out = in_work("meshed_" + route + ".gcode");
    const CmdResult r = run("slice " + design + " --route " + route + " --machine " + prof +
                            " -o " + out + " --layer-height 0.25 --preview " + in_work(route));
    ASSERT_EQ(r.code, 0) << r.err;
    expect_layers_of_a_10mm_cube(r.out, route);
    EXPECT_NE(trellis::read_file(out).find("G1 "), std::string::npos);
    EXPECT_FALSE(fs::is_empty(in_work(route)));
  }
  const CmdResult r = run("slice " + in_work("cube.3mf") + " --machine " + prof + " -o " +
                          in_work("cube3mf.gcode") + " --layer-height 0.25");
  ASSERT_EQ(r.code, 0) << r.err;
  expect_layers_of_a_10mm_cube(r.out, "mesh");
}

TEST(Cli, ThreeMaterialDesignOnAThreeInputMixer) {
  // The bundled three-material disc: M165 with three factors on the A20T profile; a two-input
  // hotend or a palette that is not d² colours is refused naming why, nothing written.
  const std::string root = std::string(TRELLIS_SOURCE_DIR);
  const std::string d = root + "/examples/designs/fgm_three_materials.vcad";
  CmdResult r =
      run("slice " + d + " --machine " + root + "/profiles/geeetech_a20t_mixing.toml -o " +
          in_work("tri.gcode") + " --strategy 2 --colors 9 --report " + in_work("tri.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string g = trellis::read_file(in_work("tri.gcode"));
  // All nine centroids of the triangle cut in three: the corners' and the down triangles'.
  for (const char* m : {"M165 A0.7778 B0.1111 C0.1111", "M165 A0.1111 B0.7778 C0.1111",
                        "M165 A0.1111 B0.1111 C0.7778", "M165 A0.2222 B0.2222 C0.5556",
                        "M165 A0.5556 B0.2222 C0.2222", "M165 A0.2222 B0.5556 C0.2222"})
    EXPECT_NE(g.find(m), std::string::npos) << m;
  EXPECT_NE(trellis::read_file(in_work("tri.json")).find("\"materials\": 3"), std::string::npos);
  r = run("slice " + d + " --machine " + root + "/profiles/geeetech_mizar_m_mixing.toml -o " +
          in_work("tri_never.gcode") + " --strategy 2 --colors 9");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("machine.mixing_inputs = 2"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(in_work("tri_never.gcode")));
  r = run("slice " + d + " --machine " + root + "/profiles/geeetech_a20t_mixing.toml -o " +
          in_work("tri_never.gcode") + " --strategy 1 --colors 8");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("d² colours"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(in_work("tri_never.gcode")));
}

TEST(Cli, NonplanarFromGeneratedSurfaceWithToolGroups) {
  const std::string prof =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/fresh_nonplanar_2syringe.toml";
  ASSERT_EQ(run("surface m-curve -o " + in_work("m.stl")).code, 0);
  const CmdResult r = run("nonplanar " + in_work("m.stl") + " --machine " + prof + " -o " +
                          in_work("m.gcode") + " --report " + in_work("m.json") +
                          " --layer-tools 3:0,3:1,3:0 --angles 0 --preview " + in_work("m_pv"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("9 layers of 0.300 mm, 9 paths of 0.400 mm width, 0 travel moves within "
                       "layers, 2 tool changes"),
            std::string::npos)
      << r.out;
  const std::string report = trellis::read_file(in_work("m.json"));
  EXPECT_NE(report.find("\"tool_changes\": 2"), std::string::npos) << report;
  EXPECT_TRUE(fs::exists(in_work("m_pv/3d.png")));
  // Read back independently: nine continuous extrusions (one per layer).
  const auto rep = trellis::test::replay_gcode(trellis::read_file(in_work("m.gcode")));
  EXPECT_EQ(rep.extrusion_starts, 9u);
  // A height function directly.
  const CmdResult f =
      run("nonplanar --height-fn \"sqrt(100-x^2-y^2)-6\" --domain -8,-8,8,8 "
          "--machine " +
          prof + " --layers 2 --offset normal -o " + in_work("cap.gcode"));
  EXPECT_EQ(f.code, 0) << f.err;
  EXPECT_NE(f.out.find("0 travel moves within layers"), std::string::npos) << f.out;
}

TEST(Cli, NonplanarBadSurfacesExitTwoNamingWhere) {
  const std::string prof =
      std::string(TRELLIS_SOURCE_DIR) + "/profiles/fresh_nonplanar_2syringe.toml";
  // A closed cube is not a height field.
  const std::string cube = write("cube.obj",
                                 "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\n"
                                 "v 0 1 1\nf 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
                                 "f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n");
  CmdResult r = run("nonplanar " + cube + " --machine " + prof + " -o " + in_work("never.gcode"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("cube.obj"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not a height field"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("("), std::string::npos) << r.err;  // where
  EXPECT_FALSE(fs::exists(in_work("never.gcode")));
  r = run("nonplanar --height-fn \"x+*y\" --domain 0,0,1,1 --machine " + prof + " -o " +
          in_work("never.gcode"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("position 2"), std::string::npos) << r.err;
  r = run("nonplanar --height-fn x --machine " + prof + " -o " + in_work("never.gcode"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--domain"), std::string::npos) << r.err;
  r = run("nonplanar " + cube + " --layer-tools 3:x --machine " + prof + " -o " +
          in_work("never.gcode"));
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(fs::exists(in_work("never.gcode")));
  // Two surfaces at once is an error, not one of them silently.
  r = run("nonplanar " + cube + " --set surface.kind=miura --machine " + prof + " -o " +
          in_work("never.gcode"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("give one surface"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(in_work("never.gcode")));
  EXPECT_EQ(run("surface corrugation --periods 2.3 -o " + in_work("never.stl")).code, 2);
  EXPECT_FALSE(fs::exists(in_work("never.stl")));
}

TEST(Cli, AeroFoamThroughA3mfBeamLatticePlansTheFewestCollisionsTheGcodeHas) {
  // A foam written as a 3MF beam lattice, planned from the 3MF; the G-code replayed by `check`
  // has exactly the collisions the report plans, and the report proves them minimal.
  const std::string foam = in_work("foam.3mf"), tp = in_work("foam_path.json"),
                    rep = in_work("foam_report.json"), nc = in_work("foam.nc");
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/embedded_aero_410um.toml";
  CmdResult r = run("lattice3d --kind foam --box 20,20,20 --density 0.005 -o " + foam);
  ASSERT_EQ(r.code, 0) << r.err;
  r = run("plan aero " + foam + " -o " + tp + " --report " + rep);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string report = trellis::read_file(rep);
  auto number = [&](const std::string& key) {
    std::smatch m;
    const std::regex re("\"" + key + "\": ([0-9]+)");
    EXPECT_TRUE(std::regex_search(report, m, re)) << key;
    return m.size() > 1 ? std::stol(m[1]) : -1L;
  };
  const long planned = number("collisions_planned"), bound = number("collisions_lower_bound");
  EXPECT_GT(planned, 0);
  EXPECT_EQ(planned, bound);
  EXPECT_NE(report.find("\"collisions_proven_minimal\": true"), std::string::npos);
  EXPECT_EQ(number("collisions"), planned);
  r = run("gcode " + tp + " --machine " + prof + " -o " + nc);
  ASSERT_EQ(r.code, 0) << r.err;
  r = run("check " + foam + " " + nc + " --machine " + prof);
  EXPECT_EQ(r.code, 1) << r.err;  // collisions remain: not ok
  EXPECT_NE(r.out.find(", " + std::to_string(planned) + " collisions"), std::string::npos) << r.out;
  // --keep-graph keeps the AERO bunny's 1,091 struts (1,093 after T-junction splitting).
  const std::string bunny =
      std::string(TRELLIS_SOURCE_DIR) + "/tests/data/aero/stanford_bunny_edges.csv";
  r = run("plan aero " + bunny + " --keep-graph -o " + in_work("bunny.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("1091 struts"), std::string::npos) << r.out;
  r = run("plan aero " + bunny + " -o " + in_work("bunny.json"));
  EXPECT_NE(r.out.find("1093 struts"), std::string::npos) << r.out;
}

TEST(Cli, AnalyzeWithoutDesignCountsAndDrawsLayersAndAlignsPlacedPrints) {
  const std::string lat = in_work("al.json"), tp = in_work("al.tp.json"), gc = in_work("al.gcode");
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  // A sliced sphere: many layers.
  ASSERT_EQ(
      run("slice " + write("al.vcad", "sphere(3);\n") + " --machine " + prof + " -o " + gc).code,
      0);
  const std::string text = trellis::read_file(gc);
  int layers = 0;
  for (std::size_t at = text.find(";LAYER:"); at != std::string::npos;
       at = text.find(";LAYER:", at + 1))
    ++layers;
  ASSERT_GT(layers, 10);
  // Layers counted without --design, from the comments; and from Z alone when comments are gone.
  CmdResult r = run("analyze " + gc);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(": " + std::to_string(layers) + " layer(s)"), std::string::npos) << r.out;
  std::string bare;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind(";", 0) != 0) bare += line + "\n";
  r = run("analyze " + write("bare.gcode", bare));
  EXPECT_NE(r.out.find(": " + std::to_string(layers) + " layer(s)"), std::string::npos) << r.out;
  // --png without a design: a picture per layer, and it says so.
  r = run("analyze " + gc + " --png " + in_work("alpng"));
  ASSERT_EQ(r.code, 0) << r.err;
  for (int i = 0; i < layers; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "al_layer_%04d.png", i);
    EXPECT_TRUE(fs::exists(fs::path(in_work("alpng")) / name)) << name;
  }
  EXPECT_NE(r.out.find("wrote " + std::to_string(layers) + " layer picture(s)"), std::string::npos)
      << r.out;
  // A lattice printed on the bed centre, away from the design's place.
  ASSERT_EQ(run("lattice2d --pattern triangle --cell 1 --size 5,5 -o " + lat).code, 0);
  ASSERT_EQ(run("plan euler " + lat + " -o " + tp).code, 0);
  ASSERT_EQ(run("gcode " + tp + " --machine " + prof + " --center -o " + gc).code, 0);
  // Against the design without --align: aligned anyway, with a note naming --align.
  r = run("analyze " + gc + " --design " + lat);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("missing 0 of"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("--align"), std::string::npos) << r.err;
  // A print where the design is: no move, no note.
  const std::string here = in_work("al_here.gcode");
  ASSERT_EQ(run("gcode " + tp + " --machine " + prof + " --no-center -o " + here).code, 0);
  r = run("analyze " + here + " --design " + lat);
  EXPECT_NE(r.out.find("missing 0 of"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("--align"), std::string::npos) << r.err;
}

// gippo.worst: the lowest-score solution is written and drawn beside the best; read back it
// covers every strut of the lattice once and its Eq. 1 score is the report's lowest score.
TEST(Cli, GippoWritesAndDrawsItsWorstSolution) {
  const std::string lat = in_work("pw.json"), tp = in_work("pw.tp.json");
  ASSERT_EQ(run("lattice2d --pattern penrose --size 12,12 -o " + lat).code, 0);
  const CmdResult r = run("plan gippo " + lat + " -o " + tp + " --worst --iterations 40 --report " +
                          in_work("pw.report.json") + " --preview " + in_work("pw_png"));
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(std::filesystem::exists(in_work("pw.tp.worst.json")));
  EXPECT_TRUE(std::filesystem::exists(in_work("pw_png/worst_layer_0000.png")));
  const auto score = [](const trellis::Toolpath& t, std::size_t* struts) {
    double num = 0, total = 0;
    std::size_t paths = 0;
    *struts = 0;
    for (const auto& l : t.layers)
      for (const auto& p : l.paths) {
        num += p.length() * static_cast<double>(p.segments());
        total += p.length();
        *struts += p.segments();
        ++paths;
      }
    return num / (total * static_cast<double>(paths));
  };
  std::size_t best_struts = 0, worst_struts = 0;
  const double best = score(trellis::read_toolpath(tp), &best_struts);
  const double worst = score(trellis::read_toolpath(in_work("pw.tp.worst.json")), &worst_struts);
  EXPECT_EQ(worst_struts, best_struts);
  const auto rep = nlohmann::json::parse(trellis::read_file(in_work("pw.report.json")));
  const auto& layer = rep["layers"][0];
  EXPECT_NEAR(worst, layer["score_min"].get<double>(), 1e-9);
  EXPECT_NEAR(best, layer["score_max"].get<double>(), 1e-9);
  EXPECT_LT(worst, best);
}

// Library messages name setting keys (Python's keyword arguments); the command line shows each
// key that has a flag as `--flag (key)`, by one mapping built from the schema (with_flags).
TEST(Cli, WithFlagsShowsEveryKeysFlagOnce) {
  std::size_t flagged = 0;
  for (const trellis::Setting& s : trellis::all_settings()) {
    const std::string m = "raise " + s.key + " or lower it, (" + s.key + ")";
    const std::string shown = trellis::with_flags(m);
    EXPECT_EQ(trellis::with_flags(shown), shown) << s.key;  // a key shown so is left alone
    if (s.flag.empty()) {
      EXPECT_EQ(shown, m) << s.key;
      continue;
    }
    ++flagged;
    const std::string as = "--" + s.flag + " (" + s.key + ")";
    EXPECT_EQ(shown, "raise " + as + " or lower it, (" + as + ")") << s.key;
    // Not a key: part of a longer dotted name, a file name, or already "key (--flag)".
    for (const std::string& other :
         {s.key + ".x", "a/" + s.key, s.key + ".toml", s.key + " (--" + s.flag + ")", "x" + s.key})
      EXPECT_EQ(trellis::with_flags(other), other) << other;
  }
  EXPECT_GT(flagged, 50u);
  EXPECT_EQ(trellis::with_flags("no keys here: job.toml, a.b"), "no keys here: job.toml, a.b");
}

TEST(Cli, LibraryErrorShowsTheFlagAndTheKey) {
  // A pbf cell finer than 8 x pbf.resolution is refused by the library naming pbf.resolution.
  trellis::Job job;
  job.route = "pbf";
  job.output = in_work("fine.cli");
  job.settings.set("pbf.cell", 0.05, {"test"});
  trellis::Diagnostics diag;
  try {
    trellis::run_job(job, diag);
    ADD_FAILURE() << "a cell below the sampling grid planned";
  } catch (const trellis::SettingError& e) {
    EXPECT_NE(e.message().find("lower pbf.resolution"), std::string::npos) << e.what();
    EXPECT_EQ(e.message().find("--"), std::string::npos) << e.what();
  }
  const CmdResult r = run("pbf --cell 0.05 -o " + in_work("fine.cli"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("lower --resolution (pbf.resolution)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--cell (pbf.cell)"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(in_work("fine.cli")));
}
