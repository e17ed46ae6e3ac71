// Exact sharding of graded slicing (issue 23, docs/plates.md "Graded slicing"): a shard plans
// its layers' colour pieces (Strategy 1) or fills (Strategy 2), the merge places and prints the
// prime tower over all layers and the writer runs the look-ahead over the whole print. The merged
// G-code of 1, 2 and 5 shards is byte for byte the single run's, for Strategy 1 with a tower on a
// mixing hotend, Strategy 2 with the 960 mm look-ahead, both on a five-tool changer and both with
// process fields; planar designs with process fields and graded plates are refused (exit 2,
// nothing written).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "support/cli_run.hpp"
#include "support/shard_run.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/plate.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;

const fs::path& work() {
  static const test::TempDir dir("trellis_graded_shards");
  return dir.path();
}

test::CliRun cli(const std::string& args) {
  return test::run_cli(args, work());
}

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// A cylinder 16 mm across and 8.4 mm tall (42 layers: the boundaries of 2 and 5 shards fall
// after odd and even layers, so a layer's alternation must not restart in a shard) graded across
// X and up Z: every layer has several colours (changes inside a layer) and its colours move up
// the layers (a layer's first piece differs from the layer below's last), so purges and the
// look-ahead cross shard boundaries.
std::string graded_design() {
  const fs::path p = work() / "designs" / "graded_xz.vcad";
  if (!fs::exists(p))
    write(p,
          "fgrade([\"(x+8)/32 + z/16.8\", \"1 - (x+8)/32 - z/16.8\"], [\"blue\", \"yellow\"]) {\n"
          "  cylinder(8, 8.4);\n}\n");
  return p.string();
}

std::string job_file(const std::string& name, int strategy, const std::string& profile,
                     const std::string& extra = {}) {
  const fs::path p = work() / (name + ".toml");
  write(p, "[job]\nroute = \"slice\"\nname = \"" + name + "\"\ninput = \"" + graded_design() +
               "\"\nmachine = \"" + kRoot + "/profiles/" + profile +
               "\"\n\n[slice]\nstrategy = " + std::to_string(strategy) + "\n" + extra);
  return p.string();
}

// The job run whole into `dir`, then in `n` shards merged beside it; each shard's manifest says
// it is graded.
test::WholeAndMerged single_and_merged(const std::string& job_file, const fs::path& dir, int n) {
  return test::run_whole_and_shards(
      job_file, dir, n, {}, &Job::output, [](const Job&, const JobResult& r) {
        EXPECT_NE(read_file(r.files.back()).find("\"graded\""), std::string::npos)
            << "a graded shard's manifest says so";
      });
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// Layer index of each occurrence of `what` (";LAYER:" lines before it).
std::vector<int> layers_of(const std::string& g, const std::string& what) {
  std::vector<int> out;
  int layer = -1;
  std::size_t line = 0;
  while (line < g.size()) {
    const std::size_t end = std::min(g.find('\n', line), g.size());
    const std::string_view l(g.data() + line, end - line);
    if (l.rfind(";LAYER:", 0) == 0) ++layer;
    if (l.find(what) != std::string_view::npos) out.push_back(layer);
    line = end + 1;
  }
  return out;
}

void expect_merges_exactly(const std::string& job, const std::string& name) {
  const fs::path dir = work() / name;
  for (int n : {1, 2, 5}) {
    const auto [single, merged] = single_and_merged(job, dir, n);
    ASSERT_GT(single.size(), 10000u);
    EXPECT_TRUE(single == merged) << name << ", " << n
                                  << " shards: merged G-code differs from the single run";
  }
}

}  // namespace

// Strategy 1 in face order on the Mizar M mixing hotend (purge on in its profile): the prime
// tower stands on every layer up to the last purge, and purges sit in the upper shards' layers
// too.
TEST(GradedShards, Strategy1WithPrimeTowerMergesExactlyFrom1_2_5Shards) {
  const std::string job =
      job_file("s1_mixing", 1, "geeetech_mizar_m_mixing.toml", "\n[fgm]\norder = \"faces\"\n");
  expect_merges_exactly(job, "s1_mixing");
  const std::string g = read_file((work() / "s1_mixing" / "s1_mixing.gcode").string());
  const auto tower = layers_of(g, ";TYPE:Wipe tower");
  ASSERT_FALSE(tower.empty()) << "no prime tower";
  EXPECT_GT(tower.back(), 20) << "the tower reaches into the upper shards' layers";
  EXPECT_GT(count(g, "M165"), 40u);
}

// Strategy 1 in path order (the default) on the mixing hotend: no tower; the planar paths cut
// into joined pieces whose mixture changes the look-ahead writes 960 mm of path early, across
// layers and so across shard boundaries.
TEST(GradedShards, Strategy1InPathOrderMergesExactlyFrom1_2_5Shards) {
  const std::string job = job_file("s1_paths", 1, "geeetech_mizar_m_mixing.toml");
  expect_merges_exactly(job, "s1_paths");
  const std::string g = read_file((work() / "s1_paths" / "s1_paths.gcode").string());
  EXPECT_TRUE(layers_of(g, ";TYPE:Wipe tower").empty()) << "path order prints no tower";
  EXPECT_GT(count(g, "M165"), 40u);
}

// Strategy 2 on the mixing hotend: each mixture change written 960 mm of path early (the
// profile's gradient.lookahead), across layers and so across shard boundaries.
TEST(GradedShards, Strategy2WithLookaheadMergesExactlyFrom1_2_5Shards) {
  const std::string job = job_file("s2_lookahead", 2, "geeetech_mizar_m_mixing.toml");
  Diagnostics diag;
  const JobResult r = run_job(load_job(job, (work() / "s2_summary").string()), diag);
  EXPECT_NE(r.summary.find("look-ahead 960 mm"), std::string::npos) << r.summary;
  expect_merges_exactly(job, "s2_lookahead");
  const std::string g = read_file((work() / "s2_lookahead" / "s2_lookahead.gcode").string());
  EXPECT_GT(count(g, "M165"), 40u);
}

// A five-tool changer (Prusa XL): Strategy 1 and 2 prime each tool on the tower; mixtures are
// the tools' (made so after the tower, in the merge as in the single run).
TEST(GradedShards, ToolChangerMergesExactlyFrom1_2_5Shards) {
  for (int strategy : {1, 2}) {
    const std::string name = "xl_s" + std::to_string(strategy);
    const std::string job =
        job_file(name, strategy, "prusa_xl_5tools.toml", "\n[fgm]\ncolors = 5\n");
    expect_merges_exactly(job, name);
    const std::string g = read_file((work() / name / (name + ".gcode")).string());
    EXPECT_FALSE(layers_of(g, ";TYPE:Wipe tower").empty()) << name;
    EXPECT_GE(count(g, "\nT"), 4u) << name;
  }
}

// Process fields (fprocess) on a graded design: the process pass runs in the merge, after the
// tower, over every path (the tower's too) with the shards' outline planes; exact as well.
TEST(GradedShards, ProcessFieldsOnAGradedDesignMergeExactly) {
  const fs::path design = work() / "designs" / "graded_process.vcad";
  write(design,
        "fprocess([\"200 + 2*z\", \"20 + 0.5*(x+8)\"], [\"temperature\", \"speed\"]) {\n"
        "  fgrade([\"(x+8)/32 + z/16.8\", \"1 - (x+8)/32 - z/16.8\"], [\"blue\", \"yellow\"]) {\n"
        "    cylinder(8, 8.4);\n  }\n}\n");
  for (int strategy : {1, 2}) {
    const std::string name = "process_s" + std::to_string(strategy);
    const fs::path job = work() / (name + ".toml");
    write(job, "[job]\nroute = \"slice\"\nname = \"" + name + "\"\ninput = \"" + design.string() +
                   "\"\nmachine = \"" + kRoot +
                   "/profiles/geeetech_mizar_m_mixing.toml\"\n\n[slice]\nstrategy = " +
                   std::to_string(strategy) + "\n");
    expect_merges_exactly(job.string(), name);
    const std::string g = read_file((work() / name / (name + ".gcode")).string());
    EXPECT_GT(count(g, "M104 S"), 10u) << name << ": temperature changes written";
  }
}

// What does not shard says so: a planar design with process fields (its shard files do not
// carry the values) and a graded part on a plate; exit 2, no shard file or manifest written.
TEST(GradedShards, PlanarProcessFieldsAndGradedPlatesRefuseShardsAndWriteNothing) {
  const fs::path design = work() / "designs" / "planar_process.vcad";
  write(design, "fprocess([\"200 + 2*z\"], [\"temperature\"]) {\n  cylinder(8, 8.4);\n}\n");
  const fs::path job = work() / "planar_process.toml";
  write(job, "[job]\nroute = \"slice\"\nname = \"planar_process\"\ninput = \"" + design.string() +
                 "\"\nmachine = \"" + kRoot + "/profiles/geeetech_mizar_m_mixing.toml\"\n");
  const fs::path out = work() / "refused_process";
  auto r = cli("run " + job.string() + " -o " + out.string() + " --shard 1/2");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("process fields"), std::string::npos) << r.err;
  EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out)) << "nothing written";

  const fs::path plate = work() / "graded_plate.toml";
  write(plate, "[job]\nroute = \"slice\"\nname = \"graded_plate\"\nmachine = \"" + kRoot +
                   "/profiles/geeetech_mizar_m_mixing.toml\"\n\n[slice]\nstrategy = 1\n\n"
                   "[[part]]\nlabel = \"a\"\nx = 0\ny = 0\ninput = \"" +
                   graded_design() + "\"\n\n[[part]]\nlabel = \"b\"\nx = 40\ny = 0\ninput = \"" +
                   graded_design() + "\"\n");
  const fs::path out2 = work() / "refused_plate";
  r = cli("run " + plate.string() + " -o " + out2.string() + " --shard 1/2");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("plates"), std::string::npos) << r.err;
  EXPECT_TRUE(!fs::exists(out2) || fs::is_empty(out2)) << "nothing written";
}

// A graded shard whose mixtures are not the design's (a shard file of another job, or altered):
// the merge refuses it (exit-2 error) and writes nothing, rather than place a tower by them.
TEST(GradedShards, MergeRefusesMixturesThatAreNotShares) {
  const std::string job = job_file("s1_tampered", 1, "geeetech_mizar_m_mixing.toml");
  const fs::path dir = work() / "s1_tampered";
  Diagnostics diag;
  std::vector<std::string> manifests;
  for (int k = 1; k <= 2; ++k) {
    Job shard = load_job(job, dir.string());
    shard.shard = k;
    shard.shards = 2;
    manifests.push_back(run_job(shard, diag).files.back());
  }
  const std::string data = manifests[1].substr(0, manifests[1].size() - 5);
  std::vector<Layer> layers = layers_from_shard_bytes(read_file(data), data);
  ASSERT_FALSE(layers.empty());
  ASSERT_FALSE(layers.back().paths.empty());
  ASSERT_EQ(layers.back().paths.front().mixture.size(), 2u);
  layers.back().paths.front().mixture = {1.5, -0.5};  // same size: the manifest still matches
  write_file_atomic(data, shard_bytes(layers));
  const std::string merged = (dir / "merged.gcode").string();
  EXPECT_THROW(merge_shards(manifests, merged, diag), ParseError);
  EXPECT_FALSE(fs::exists(merged));
}
