// Build plates and exact sharding (issue 23): a plate of 16 gyroid parts (PBF) and one of nine
// lattice tiles (FDM) merged from 1, 2 and 5 shards are byte for byte the single-process file;
// plates that do not fit, overlapping parts, shard indices out of range, a missing shard and
// shards of different jobs exit 2 and write nothing.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <set>

#include "support/cli_run.hpp"
#include "support/shard_run.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/plate.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_reader.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;

const fs::path& plate_work() {
  static const test::TempDir dir("trellis_plate_test");
  return dir.path();
}

test::CliRun cli(const std::string& args) {
  return test::run_cli(args, plate_work());
}

}  // namespace

TEST(Plate, PbfPlateOf16GyroidPartsMergesExactlyFrom1_2_5Shards) {
  const std::string job = kRoot + "/examples/jobs/gyroid_plate_pbf.toml";
  const fs::path dir = plate_work() / "pbf";
  for (int n : {1, 2, 5}) {
    const auto [single, merged] = test::run_whole_and_shards(job, dir, n);
    ASSERT_GT(single.size(), 1000u);
    EXPECT_TRUE(single == merged) << n << " shards: merged file differs from the single run";
  }
  // One build file with every part: 16 labelled contour and hatch ids, each used.
  const std::string cli_text = read_file((dir / "gyroid_plate.cli").string());
  for (int k = 1; k <= 16; ++k) {
    char label[16];
    std::snprintf(label, sizeof label, "g%02d", k);
    EXPECT_NE(cli_text.find("$$LABEL/" + std::to_string(2 * k - 1) + "," + label + " contour\n"),
              std::string::npos)
        << label;
    EXPECT_NE(cli_text.find("$$LABEL/" + std::to_string(2 * k) + "," + label + " hatch\n"),
              std::string::npos)
        << label;
    EXPECT_NE(cli_text.find("$$POLYLINE/" + std::to_string(2 * k - 1) + ","), std::string::npos)
        << label << " has no contour vectors";
    // The 1 mm cells of every fourth part are all thin wall (contours only).
    if (k % 4 != 0)
      EXPECT_NE(cli_text.find("$$HATCHES/" + std::to_string(2 * k) + ","), std::string::npos)
          << label << " has no hatch vectors";
  }
  // Read back: every vector inside the build area, parts where the job placed them.
  const Toolpath tp = read_cli(cli_text, "plate.cli");
  BBox3 box;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths)
      for (const auto& q : p.points) box.add(q);
  EXPECT_GT(box.min.x, 18.0);
  EXPECT_LT(box.max.x, 40.5);
  EXPECT_GT(box.min.y, 18.0);
  EXPECT_LT(box.max.y, 40.5);
}

TEST(Plate, FdmPlateOfNineLatticePartsMergesExactlyFrom1_2_5Shards) {
  const std::string job = kRoot + "/examples/jobs/lattice_plate_fdm.toml";
  const fs::path dir = plate_work() / "fdm";
  for (int n : {1, 2, 5}) {
    const auto [single, merged] = test::run_whole_and_shards(job, dir, n);
    ASSERT_GT(single.size(), 1000u);
    EXPECT_TRUE(single == merged) << n << " shards: merged G-code differs from the single run";
  }
  // The nine parts are printed in every layer: extrusion moves near each part's centre.
  const std::string g = read_file((dir / "lattice_plate.gcode").string());
  const std::regex move(R"(G1 X([0-9.]+) Y([0-9.]+) E)");
  std::set<int> parts;
  for (auto it = std::sregex_iterator(g.begin(), g.end(), move); it != std::sregex_iterator();
       ++it) {
    const double x = std::stod((*it)[1]), y = std::stod((*it)[2]);
    const int i = static_cast<int>(std::lround((x - 90) / 12)),
              j = static_cast<int>(std::lround((y - 90) / 12));
    ASSERT_TRUE(i >= 0 && i < 3 && j >= 0 && j < 3) << x << "," << y << " is on no part";
    ASSERT_LT(std::hypot(x - 90 - 12 * i, y - 90 - 12 * j), 4.3) << x << "," << y;
    parts.insert(3 * j + i);
  }
  EXPECT_EQ(parts.size(), 9u);
}

// Non-planar slicing shards by layer: each shard slices the layers up to its end (a layer's
// serpentine starts where the one before ended) and keeps its own.
TEST(Plate, NonplanarMergesExactlyFrom1_2_5Shards) {
  const std::string job = kRoot + "/examples/jobs/corrugation_nonplanar.toml";
  const fs::path dir = plate_work() / "nonplanar";
  for (int n : {1, 2, 5}) {
    const auto [single, merged] = test::run_whole_and_shards(job, dir, n);
    ASSERT_GT(single.size(), 1000u);
    EXPECT_TRUE(single == merged) << n << " shards: merged G-code differs from the single run";
  }
  // Bad shard input: exit 2, nothing written.
  const fs::path out = plate_work() / "nonplanar_refused";
  for (const char* bad : {"7/5", "0/3", "x/2"}) {
    const auto r = cli("run " + job + " -o " + out.string() + " --shard " + bad);
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.err.find("--shard"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << bad;
  }
  // A shard missing from the merge: exit 2, no merged file.
  const fs::path s3 = plate_work() / "nonplanar_s3";
  for (int k : {1, 3})
    ASSERT_EQ(
        cli("run " + job + " -o " + s3.string() + " --shard " + std::to_string(k) + "/3").code, 0);
  const std::string merged = (s3 / "merged.gcode").string();
  const auto r = cli("merge " + (s3 / "corrugation.gcode.shard-1-of-3.json").string() + " " +
                     (s3 / "corrugation.gcode.shard-3-of-3.json").string() + " -o " + merged);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("shards 2 of 3 are missing"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(merged));
}

// The lattice plan route shards with euler and gippo (tests/job/test_plan_shard_job.cpp); AERO
// plans the whole lattice at once and a plan without G-code has nothing to shard: --shard is
// refused saying why, exit 2, nothing written.
TEST(Plate, LatticePlansRefuseShardsSayingWhy) {
  const fs::path out = plate_work() / "plan_refused";
  auto r =
      cli("run " + kRoot + "/examples/jobs/tiny_plan.toml -o " + out.string() + " --shard 1/2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("holds layers of its G-code"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  r = cli("run " + kRoot + "/examples/jobs/octet_aero.toml -o " + out.string() + " --shard 2/2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("AERO plans the whole 3D lattice as one problem"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// The nine parts are named in the G-code (M486, the profile being Marlin-flavoured): read back,
// every extrusion lies in exactly one labelled part, inside that part's footprint (within 4.3 mm
// of its place on the plate), and every part prints in every layer.
TEST(Plate, FdmPlatePartsAreLabelledAndEachExtrusionIsInsideItsPart) {
  const std::string job = kRoot + "/examples/jobs/lattice_plate_fdm.toml";
  const fs::path dir = plate_work() / "fdm_labels";
  Diagnostics diag;
  const Job whole = load_job(job, dir.string());
  run_job(whole, diag);
  const std::string g = read_file(whole.output);
  EXPECT_NE(g.find("M486 T9\n"), std::string::npos);
  const Toolpath tp = read_gcode(g, {}, diag, whole.output);
  std::vector<std::string> labels;
  for (int k = 1; k <= 9; ++k) labels.push_back("tile" + std::to_string(k));
  ASSERT_EQ(tp.part_labels, labels);
  std::size_t layers_with_all = 0;
  for (const auto& l : tp.layers) {
    std::set<int> in_layer;
    for (const auto& p : l.paths) {
      ASSERT_GE(p.part, 1) << "a path at z " << l.z << " is in no labelled part";
      const int k = p.part - 1;  // tile k+1 sits at (90 + 12 (k % 3), 90 + 12 (k / 3))
      for (const Vec3& q : p.points)
        ASSERT_LT(std::hypot(q.x - 90 - 12 * (k % 3), q.y - 90 - 12 * (k / 3)), 4.3)
            << q.x << "," << q.y << " is outside " << tp.part_labels[static_cast<std::size_t>(k)];
      in_layer.insert(p.part);
    }
    layers_with_all += in_layer.size() == 9;
  }
  EXPECT_EQ(layers_with_all, tp.layers.size());
}

TEST(Plate, ShardRangesAreContiguousAndBalancedByWork) {
  std::vector<double> work(100, 1.0);
  for (int i = 0; i < 50; ++i) work[static_cast<std::size_t>(i)] = 3.0;  // heavy lower half
  for (int n : {1, 2, 3, 5, 7, 150}) {
    std::size_t next = 0;
    double most = 0;
    for (int k = 1; k <= n; ++k) {
      const auto [a, b] = shard_range(work, k, n);
      EXPECT_EQ(a, next) << k << "/" << n;
      EXPECT_LE(a, b);
      double w = 0;
      for (std::size_t i = a; i < b; ++i) w += work[i];
      most = std::max(most, w);
      next = b;
    }
    EXPECT_EQ(next, work.size()) << n;
    // No shard carries more than its share plus one layer's work.
    EXPECT_LE(most, 200.0 / n + 3.0 + 1e-9) << n;
  }
  // Equal layer counts would give the heavy half's shard 3× the work of the other.
  const auto [a, b] = shard_range(work, 1, 2);
  EXPECT_EQ(a, 0u);
  EXPECT_EQ(b, 34u);
}

// A 3MF build item places a part's design where its paths are (issue 43): the item's transform
// maps every design point as place_point does, z moved by the drop; a rotation keeps lengths.
TEST(Plate, BuildItemTransformPlacesPointsAsThePlate) {
  std::mt19937 rng(43);
  std::uniform_real_distribution<double> u(-50, 50), turn(-360, 360);
  for (int trial = 0; trial < 200; ++trial) {
    PlatePart part;
    part.x = u(rng), part.y = u(rng);
    part.rotation = trial % 4 == 0 ? 90.0 * (trial % 7) : turn(rng);
    const Vec3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)};
    const BBox3 box{{std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)},
                    {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}};
    const double dz = u(rng);
    const Transform3mf m = place_transform(part, box, dz);
    for (int k = 0; k < 20; ++k) {
      const Vec3 p{u(rng), u(rng), u(rng)}, q{u(rng), u(rng), u(rng)};
      const Vec3 placed = place_point(part, box, p), moved = apply_transform(m, p);
      EXPECT_NEAR(moved.x, placed.x, 1e-9) << trial;
      EXPECT_NEAR(moved.y, placed.y, 1e-9) << trial;
      EXPECT_NEAR(moved.z, placed.z + dz, 1e-9) << trial;
      EXPECT_NEAR(distance(moved, apply_transform(m, q)), distance(p, q), 1e-9) << trial;
    }
  }
  EXPECT_EQ(place_transform(PlatePart{}, BBox3{{0, 0, 0}, {0, 0, 0}}), kIdentity3mf);
}

TEST(Plate, ShardFilesRoundTripExactly) {
  std::vector<Layer> layers(2);
  layers[0].z = 0.1 + 0.2;
  Path p;
  p.points = {{1.0 / 3, 2.0 / 7, 0.3}, {1e-17, -5.5, 0.3}};
  p.role = PathRole::Infill;
  p.part = 3;
  p.tool = 1;
  p.mixture = {0.25, 0.75};
  p.speed = 800.125;
  p.power = 99.5;
  p.flow = 0.85, p.fan = 35, p.joined = true, p.temperature = 212.5;  // process fields
  layers[1].paths.push_back(p);
  const std::string bytes = shard_bytes(layers);
  const auto back = layers_from_shard_bytes(bytes, "x");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].z, layers[0].z);
  ASSERT_EQ(back[1].paths.size(), 1u);
  const Path& q = back[1].paths[0];
  EXPECT_EQ(q.points, p.points);
  EXPECT_EQ(q.part, 3);
  EXPECT_EQ(q.tool, 1);
  EXPECT_EQ(q.role, PathRole::Infill);
  EXPECT_EQ(q.mixture, p.mixture);
  EXPECT_EQ(q.speed, p.speed);
  EXPECT_EQ(q.power, p.power);
  EXPECT_EQ(q.flow, p.flow);
  EXPECT_EQ(q.fan, p.fan);
  EXPECT_EQ(q.joined, p.joined);
  EXPECT_EQ(q.temperature, p.temperature);
  EXPECT_EQ(shard_bytes(back), bytes);
  EXPECT_THROW(layers_from_shard_bytes(bytes.substr(0, bytes.size() - 3), "x"), ParseError);
}

TEST(Plate, FootprintsOutsideTheAreaOrTooCloseAreRefused) {
  PlatePart a;
  a.label = "a";
  a.x = 10, a.y = 10;
  BBox3 box;
  box.add({-2, -2, 0});
  box.add({2, 2, 1});
  PlatePart b = a;
  b.label = "b";
  b.x = 15.5;  // 1.5 mm gap
  const BBox2 area{{0, 0}, {100, 100}};
  EXPECT_NO_THROW(check_plate({place_footprint(a, box), place_footprint(b, box)}, area, 1.0, "j"));
  EXPECT_THROW(check_plate({place_footprint(a, box), place_footprint(b, box)}, area, 2.0, "j"),
               SettingError);
  // Turned 45°, b's corner reaches 2.83 mm towards a: 0.67 mm apart.
  b.rotation = 45;
  EXPECT_THROW(check_plate({place_footprint(a, box), place_footprint(b, box)}, area, 1.0, "j"),
               SettingError);
  b.rotation = 0;
  b.x = 11;  // overlapping
  try {
    check_plate({place_footprint(a, box), place_footprint(b, box)}, area, 0.0, "j");
    ADD_FAILURE() << "overlap not refused";
  } catch (const SettingError& e) {
    EXPECT_NE(std::string(e.what()).find("'a'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'b'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("overlap"), std::string::npos) << e.what();
  }
  a.x = 1;  // sticks out over x = 0
  EXPECT_THROW(check_plate({place_footprint(a, box)}, area, 0.0, "j"), SettingError);
}

TEST(Plate, BadPlatesAndBadShardsExit2AndWriteNothing) {
  const std::string job = read_file(kRoot + "/examples/jobs/gyroid_plate_pbf.toml");
  auto variant = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string text =
        std::regex_replace(job, std::regex(R"(\.\./\.\./profiles)"), kRoot + "/profiles");
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    const std::string path = (plate_work() / name).string();
    std::ofstream(path) << text;
    return path;
  };
  const fs::path out = plate_work() / "refused";
  // g02 moved onto g01.
  auto r = cli("run " + variant("overlap.toml", "x = 26\n", "x = 21\n") + " -o " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'g01'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'g02'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("overlap"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // g04 off the 100 mm plate.
  r = cli("run " + variant("outside.toml", "x = 38\n", "x = 99\n") + " -o " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'g04' does not fit the build area"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // A part whose cells the sampling grid cannot resolve: refused like a single part.
  r = cli("run " + variant("fine.toml", "cell = 1.0\n", "cell = 0.2\n") + " -o " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("part 'g04': pbf.cell"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  const std::string good = kRoot + "/examples/jobs/gyroid_plate_pbf.toml";
  for (const char* bad : {"6/5", "0/5", "2", "a/b", "1/0"}) {
    r = cli("run " + good + " -o " + out.string() + " --shard " + bad);
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.err.find("--shard"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << bad;
  }
  // Shards: one missing, one of another split, one given twice.
  const fs::path s3 = plate_work() / "s3", s2 = plate_work() / "s2";
  for (int k = 1; k <= 3; ++k)
    ASSERT_EQ(
        cli("run " + good + " -o " + s3.string() + " --shard " + std::to_string(k) + "/3").code, 0);
  ASSERT_EQ(cli("run " + good + " -o " + s2.string() + " --shard 2/2").code, 0);
  const std::string m1 = (s3 / "gyroid_plate.cli.shard-1-of-3.json").string();
  const std::string m2 = (s3 / "gyroid_plate.cli.shard-2-of-3.json").string();
  const std::string m3 = (s3 / "gyroid_plate.cli.shard-3-of-3.json").string();
  const std::string merged = (s3 / "merged.cli").string();
  r = cli("merge " + m1 + " " + m3 + " -o " + merged);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("shards 2 of 3 are missing"), std::string::npos) << r.err;
  r = cli("merge " + m1 + " " + m2 + " " + (s2 / "gyroid_plate.cli.shard-2-of-2.json").string() +
          " -o " + merged);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("another job"), std::string::npos) << r.err;
  r = cli("merge " + m1 + " " + m2 + " " + m2 + " " + m3 + " -o " + merged);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("given twice"), std::string::npos) << r.err;
  // The same split of another job (a setting changed): refused too.
  const std::string other = variant("other.toml", "cell = 2.0", "cell = 2.5");
  ASSERT_EQ(cli("run " + other + " -o " + (plate_work() / "o3").string() + " --shard 2/3").code, 0);
  r = cli("merge " + m1 + " " +
          (plate_work() / "o3" / "gyroid_plate.cli.shard-2-of-3.json").string() + " " + m3 +
          " -o " + merged);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("another job"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(merged));
  // All three: the merge is written.
  r = cli("merge " + m3 + " " + m1 + " " + m2 + " -o " + merged);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(merged));
}

// examples/slurm without a Slurm: the array script run locally with SLURM_ARRAY_TASK_ID set by
// hand, then the merge script, merge to the bytes of the single run. submit.sh (array, afterok
// dependency, merge) runs on a real Slurm in tests/cluster/slurm_test.py.
TEST(Plate, SlurmScriptsRunLocallyMergeToTheSingleRun) {
  const std::string job = kRoot + "/examples/jobs/lattice_plate_fdm.toml";
  const fs::path dir = plate_work() / "slurm";
  Diagnostics diag;
  const Job whole = load_job(job, (dir / "single").string());
  run_job(whole, diag);
  const std::string single = read_file(whole.output);
  const std::string env = "JOB='" + job + "' OUT='" + (dir / "array").string() +
                          "' SHARDS=3 TRELLIS='" + TRELLIS_CLI + "' ";
  for (int k = 1; k <= 3; ++k)
    ASSERT_EQ(std::system((env + "SLURM_ARRAY_TASK_ID=" + std::to_string(k) + " bash " + kRoot +
                           "/examples/slurm/shard.sbatch >/dev/null")
                              .c_str()),
              0);
  ASSERT_EQ(
      std::system((env + "bash " + kRoot + "/examples/slurm/merge.sbatch >/dev/null").c_str()), 0);
  EXPECT_TRUE(read_file((dir / "array" / "lattice_plate.gcode").string()) == single);
}

// A plate whose parts carry process fields (fprocess): the plate report lists, per part, what
// was written against that part's field (the same object as a single part's report), and the
// plate's command counts; a part without fields has none. Whole and streamed runs agree.
TEST(Plate, FdmPlateReportsEachPartsProcessFields) {
  const fs::path dir = plate_work() / "process";
  fs::create_directories(dir);
  std::ofstream(dir / "warm.vcad")
      << "fprocess([\"200 + 2*(z+5)\", \"20 + 0.5*(x+6)\"], [\"temperature\", \"speed\"]) {\n"
         "  cylinder(6, 10);\n}\n";
  std::ofstream(dir / "plain.vcad") << "cylinder(6, 10);\n";
  std::ofstream(dir / "plate.toml")
      << "[job]\nroute = \"slice\"\nname = \"proc_plate\"\nmachine = \"" << kRoot
      << "/profiles/prusa_mk4s_lwpla.toml\"\n\n[extrusion]\nlayer_height = 0.3\n\n"
         "[[part]]\nlabel = \"warm\"\ninput = \"warm.vcad\"\nx = 90\ny = 100\n\n"
         "[[part]]\nlabel = \"plain\"\ninput = \"plain.vcad\"\nx = 120\ny = 100\n";
  std::string reports[2];
  for (const bool keep : {true, false}) {
    Job job = load_job((dir / "plate.toml").string(), (dir / (keep ? "whole" : "stream")).string(),
                       {"output.png=false"});
    job.keep_toolpath = keep;
    Diagnostics diag;
    run_job(job, diag);
    reports[keep ? 0 : 1] = read_file(job.report);
  }
  const auto rep = nlohmann::json::parse(reports[0]);
  ASSERT_EQ(rep.at("parts").size(), 2u);
  const auto& warm = rep["parts"][0];
  ASSERT_TRUE(warm.contains("process")) << reports[0];
  // 33 layers of 0.3 mm from z = -5: the field gives 200 ... 220 °C at the planes, written
  // rounded to 1 °C.
  EXPECT_GE(warm["process"]["temperature"]["min"].get<double>(), 200.0);
  EXPECT_LE(warm["process"]["temperature"]["max"].get<double>(), 220.0);
  EXPECT_GE(warm["process"]["temperature"]["changes"].get<int>(), 15);
  EXPECT_LE(warm["process"]["temperature"]["max_deviation"].get<double>(), 0.5 + 1e-9);
  EXPECT_TRUE(warm["process"].contains("speed"));
  EXPECT_FALSE(rep["parts"][1].contains("process")) << "the plain part has no fields";
  EXPECT_GE(rep.at("process").at("temperature_commands").get<int>(), 15);
  EXPECT_EQ(nlohmann::json::parse(reports[1]), rep) << "streamed plate report differs";
}
