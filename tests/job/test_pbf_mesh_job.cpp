// `trellis pbf` on solid parts through the job layer (issue 44): a mesh input and a .vcad with a
// solid strategy take the solid route; streamed and whole runs write the same bytes; a
// strategy's settings are refused under another strategy, the TPMS-only ones with a mesh; a
// .vcad with the hybrid strategy stays the TPMS route.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/machine/cli.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;
const std::string kMesh = kRoot + "/examples/designs/concave_cylinder.obj";
const std::string kVcad = kRoot + "/examples/designs/csg_bracket.vcad";

JobResult run_pbf(const test::TempDir& dir, const std::string& name, const std::string& input,
                  std::vector<std::string> sets, bool keep, Diagnostics* diag = nullptr) {
  const fs::path job_file = dir / (name + ".toml");
  std::ofstream(job_file) << "[job]\nroute = \"pbf\"\nname = \"" << name << "\"\ninput = \""
                          << input << "\"\n";
  sets.push_back("output.png=false");
  Job job = load_job(job_file.string(), (dir / name).string(), sets);
  job.keep_toolpath = keep;
  Diagnostics d;
  return run_job(job, diag ? *diag : d);
}

std::string file_ending(const JobResult& r, const std::string& ext) {
  for (const auto& f : r.files)
    if (fs::path(f).extension() == ext) return f;
  return "";
}

}  // namespace

TEST(PbfMeshJob, MeshIslandsStreamedEqualsWhole) {
  const test::TempDir dir("trellis_pbf_mesh_job");
  const std::vector<std::string> sets = {"scan.layer=0.2", "pbf.strategy=island",
                                         "pbf.island_size=3", "pbf.island_shift=0.5",
                                         "pbf.contours=2"};
  const JobResult whole = run_pbf(dir, "whole", kMesh, sets, true);
  const JobResult streamed = run_pbf(dir, "streamed", kMesh, sets, false);
  EXPECT_TRUE(whole.toolpath);
  EXPECT_FALSE(streamed.toolpath);
  const std::string a = read_file(file_ending(whole, ".cli")),
                    b = read_file(file_ending(streamed, ".cli"));
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a, b);
  const Toolpath tp = read_cli_file(file_ending(streamed, ".cli"));
  ASSERT_GT(tp.layers.size(), 5u);
  for (const Layer& l : tp.layers) {
    std::size_t contours = 0, hatches = 0;
    for (const Path& p : l.paths) (p.role == PathRole::Contour ? contours : hatches)++;
    EXPECT_GE(contours, 2u);
    EXPECT_GT(hatches, 100u);
  }
}

TEST(PbfMeshJob, ReportSaysSolid) {
  const test::TempDir dir("trellis_pbf_mesh_job");
  const fs::path job_file = dir / "r.toml";
  std::ofstream(job_file) << "[job]\nroute = \"pbf\"\nname = \"r\"\ninput = \"" << kMesh
                          << "\"\nreport = \"r.json\"\n";
  Job job =
      load_job(job_file.string(), (dir / "r").string(), {"scan.layer=0.25", "output.png=false"});
  Diagnostics diag;
  const JobResult r = run_job(job, diag);
  const auto j = nlohmann::json::parse(read_file(file_ending(r, ".json")));
  EXPECT_EQ(j["route"], "solid");
  EXPECT_EQ(j["strategy"], "hybrid");  // a mesh has no sheet: meander inside the contours
  EXPECT_GT(j["hatch_vectors"].get<double>(), 0);
  EXPECT_EQ(j["per_layer"]["z_mm"].size(), j["layers"].get<std::size_t>());
}

TEST(PbfMeshJob, StrategySettingsRefusedUnderAnother) {
  const test::TempDir dir("trellis_pbf_mesh_job");
  EXPECT_THROW(run_pbf(dir, "a", kMesh, {"pbf.strategy=stripe", "pbf.island_size=3"}, false),
               SettingError);
  EXPECT_THROW(run_pbf(dir, "b", kMesh, {"pbf.strategy=island", "pbf.stripe_width=3"}, false),
               SettingError);
  EXPECT_THROW(run_pbf(dir, "c", kMesh, {"pbf.thin_multiple=2"}, false), SettingError);
  EXPECT_THROW(run_pbf(dir, "d", kVcad, {"pbf.contours=2"}, false), SettingError);
  EXPECT_FALSE(fs::exists(dir / "a"));  // nothing written
}

TEST(PbfMeshJob, VcadSolidStrategyScansTheSolid) {
  const test::TempDir dir("trellis_pbf_mesh_job");
  const JobResult r = run_pbf(
      dir, "v", kVcad, {"scan.layer=1", "pbf.strategy=meander", "pbf.resolution=0.1"}, false);
  const Toolpath tp = read_cli_file(file_ending(r, ".cli"));
  ASSERT_GT(tp.layers.size(), 5u);
  std::size_t contours = 0, hatches = 0;
  for (const Layer& l : tp.layers)
    for (const Path& p : l.paths) (p.role == PathRole::Contour ? contours : hatches)++;
  EXPECT_GE(contours, tp.layers.size());
  EXPECT_GT(hatches, 100 * tp.layers.size());
}
