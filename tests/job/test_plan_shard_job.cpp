// Lattice plan shards (issue 23): the plan route with the euler or gippo planner shards by layer.
// `trellis merge` of 1, 2 and 5 shards writes the single run's G-code byte for byte: GIPPO
// layers (longest-first and travel order, whose start crosses layers), Euler with travel order,
// layers laid on a surface, and two materials per layer. AERO and a plan without G-code refuse
// --shard with exit 2, writing nothing.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "support/cli_run.hpp"
#include "support/shard_run.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/plate.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;

const fs::path& work() {
  static const test::TempDir dir("trellis_plan_shard");
  return dir.path();
}

test::CliRun cli(const std::string& args) {
  return test::run_cli(args, work());
}

// The single run's G-code and the merges of 1, 2 and 5 shards of it, each shard a separate job.
void expect_shards_merge_to_single(const std::string& job_file, const std::string& tag,
                                   const std::vector<std::string>& sets = {}) {
  Diagnostics diag;
  const fs::path dir = work() / tag;
  const Job whole = load_job(job_file, dir.string(), sets);
  ASSERT_FALSE(whole.gcode.empty()) << tag;
  run_job(whole, diag);
  const std::string single = read_file(whole.gcode);
  for (int n : {1, 2, 5}) {
    const std::string merged = test::merged_shards(
        job_file, dir, n, sets, &Job::gcode, [&](const Job& shard, const JobResult& r) {
          if (!shard.lattice.empty()) {
            EXPECT_FALSE(fs::exists(shard.lattice)) << tag;
          }
          ASSERT_EQ(r.files.size(), 2u) << tag;
          EXPECT_EQ(r.files[0], shard.gcode + ".shard-" + std::to_string(shard.shard) + "-of-" +
                                    std::to_string(n));
        });
    EXPECT_TRUE(single == merged) << tag << ", " << n << " shards: merged G-code differs";
  }
}

}  // namespace

// 28 GIPPO layers of a honeycomb cropped to a concave cylinder (the paper's Fig. 7 ii-iii).
TEST(PlanShardJob, GippoLayersMergeExactlyFrom1_2_5Shards) {
  const std::string job = kRoot + "/examples/concave_cylinder_honeycomb.toml";
  expect_shards_merge_to_single(job, "cyl");
  // Travel order: each layer starts where the layer below ended, finished by the merge.
  expect_shards_merge_to_single(job, "cyl_travel", {"plan.order=travel"});
}

// The Ø48 mm Voronoi disc in travel order, planned by Euler and by GIPPO (the example's planner).
TEST(PlanShardJob, EulerTravelOrderMergesExactlyFrom1_2_5Shards) {
  const std::string job = kRoot + "/examples/voronoi_disc_travel.toml";
  expect_shards_merge_to_single(job, "voronoi", {"plan.planner=euler"});
  expect_shards_merge_to_single(job, "voronoi_gippo");
}

// Layers laid on a sphere: layer k is offset by its index, from the whole plan's first layer.
TEST(PlanShardJob, LayersOnASurfaceMergeExactlyFrom1_2_5Shards) {
  const std::string job = kRoot + "/examples/honeycomb_on_sphere.toml";
  expect_shards_merge_to_single(job, "sphere", {"layers.count=9"});
  expect_shards_merge_to_single(job, "sphere_travel", {"layers.count=9", "plan.order=travel"});
}

// Two materials in every layer: each layer's parts (one per material) in material order, the
// travel order handed on from part to part and layer to layer.
TEST(PlanShardJob, TwoMaterialsPerLayerMergeExactlyFrom1_2_5Shards) {
  const fs::path dir = work() / "materials_job";
  fs::create_directories(dir);
  {
    std::ofstream csv(dir / "grid.csv");
    csv << "x1,y1,z1,x2,y2,z2,material\n";
    for (int l = 0; l < 6; ++l)
      for (int j = 0; j <= 8; ++j)
        for (int i = 0; i <= 8; ++i) {
          const double z = 0.2 * l, x = 2.0 * i + 0.3 * l, y = 2.0 * j;
          if (i < 8 && (i + j + l) % 5 != 1)
            csv << x << "," << y << "," << z << "," << x + 2 << "," << y << "," << z << ","
                << (i + l) % 2 << "\n";
          if (j < 8 && (i * j + l) % 4 != 3)
            csv << x << "," << y << "," << z << "," << x << "," << y + 2 << "," << z << ","
                << (j / 3) % 2 << "\n";
        }
  }
  {
    std::ofstream toml(dir / "materials.toml");
    toml
        << "[job]\nroute = \"plan\"\nname = \"materials\"\ninput = \"grid.csv\"\nmachine = \""
        << kRoot
        << "/profiles/prusa_xl_5tools.toml\"\n\n[plan]\nplanner = \"gippo\"\norder = \"travel\"\n\n"
           "[gippo]\niterations = 30\n\n[output]\npng = false\n";
  }
  expect_shards_merge_to_single((dir / "materials.toml").string(), "materials");
  expect_shards_merge_to_single((dir / "materials.toml").string(), "materials_euler",
                                {"plan.planner=euler"});
}

// What does not shard says why: exit 2, nothing written.
TEST(PlanShardJob, AeroAndPlansWithoutGcodeRefuseShards) {
  const fs::path out = work() / "refused";
  auto r =
      cli("run " + kRoot + "/examples/jobs/octet_aero.toml -o " + out.string() + " --shard 2/2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("does not shard with the aero planner"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("neither its layers nor its connected parts"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  r = cli("run " + kRoot + "/examples/jobs/tiny_plan.toml -o " + out.string() + " --shard 1/2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("needs a machine"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  r = cli("run " + kRoot + "/examples/voronoi_disc_travel.toml -o " + out.string() +
          " --shard 3/2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--shard"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}
