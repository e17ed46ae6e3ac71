// The slice route writes G-code layer by layer when only files are wanted (the command line:
// Job::keep_toolpath = false) and holds the whole toolpath otherwise (Python, --toolpath,
// previews): the same bytes either way, for every kind of machine (Marlin with thumbnails and
// M73, Klipper, RepRapFirmware tool changer, pneumatic, embedded bath), for the field and the mesh
// route, and for the FDM plate, whose streamed file is also the merge of its shards. A machine
// error found while streaming leaves no file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/plate.hpp"
#include "trellis/machine/machine_check.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;

fs::path work(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("trellis_slice_stream_job_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The job's G-code whole (kept toolpath) and streamed; the streamed run keeps no toolpath.
std::pair<std::string, std::string> whole_and_streamed(const std::string& job_file,
                                                       const fs::path& dir,
                                                       const std::vector<std::string>& set = {}) {
  std::string bytes[2];
  for (const bool keep : {true, false}) {
    std::vector<std::string> s = set;
    s.push_back("output.png=false");  // previews need the whole toolpath
    Job job = load_job(job_file, (dir / (keep ? "whole" : "stream")).string(), s);
    job.keep_toolpath = keep;
    Diagnostics diag;
    const JobResult r = run_job(job, diag);
    EXPECT_EQ(static_cast<bool>(r.toolpath), keep) << "streamed runs hold no toolpath";
    bytes[keep ? 0 : 1] = read_file(job.output);
  }
  return {bytes[0], bytes[1]};
}

std::string slice_job(const fs::path& dir, const std::string& input, const std::string& machine,
                      const std::string& extra = "") {
  const fs::path f = dir / "job.toml";
  std::ofstream(f) << "[job]\nroute = \"slice\"\nname = \"part\"\ninput = \"" << input
                   << "\"\nmachine = \"" << kRoot << "/profiles/" << machine << ".toml\"\n"
                   << "[slice]\nresolution = 0.2\n"
                   << extra;
  return f.string();
}

TEST(SliceStreamJob, StreamedGcodeIsTheWholeToolpathsOnEveryKindOfMachine) {
  const std::string bracket = kRoot + "/examples/designs/csg_bracket.vcad";
  for (const char* machine : {"prusa_mk4s_lwpla", "voron_klipper", "e3d_toolchanger_rrf",
                              "pneumatic_pcl_27g", "embedded_aero_410um", "prusa_xl_5tools"}) {
    const fs::path dir = work(machine);
    const auto [whole, streamed] = whole_and_streamed(slice_job(dir, bracket, machine), dir);
    ASSERT_GT(whole.size(), 10000u) << machine;
    EXPECT_TRUE(whole == streamed) << machine << ": streamed G-code differs from the whole run";
    fs::remove_all(dir);
  }
}

// A design with process fields (temperature, speed, flow and fan per piece of path; the print
// starts at the first path's temperature): the streamed file is the whole run's.
TEST(SliceStreamJob, ProcessFieldsComeOutAsWhole) {
  const fs::path dir = work("process");
  const auto [whole, streamed] =
      whole_and_streamed(slice_job(dir, kRoot + "/examples/designs/foam_column_graded_process.vcad",
                                   "prusa_mk4s_lwpla"),
                         dir);
  ASSERT_NE(whole.find("\nM106 S"), std::string::npos) << "the fan field is written";
  ASSERT_NE(whole.find("\nG4 P"), std::string::npos) << "temperature changes settle";
  EXPECT_TRUE(whole == streamed)
      << "streamed G-code of a process design differs from the whole run";
  fs::remove_all(dir);
}

TEST(SliceStreamJob, ThumbnailsAndProgressComeOutAsWhole) {
  const fs::path dir = work("thumbs");
  const std::string job = slice_job(dir, kRoot + "/examples/designs/csg_bracket.vcad",
                                    "prusa_mk4s_lwpla", "[gcode]\nthumbnails = \"16x16,64x48\"\n");
  const auto [whole, streamed] = whole_and_streamed(job, dir);
  EXPECT_NE(streamed.find("; thumbnail begin 64x48"), std::string::npos);
  std::size_t progress = 0;
  for (auto at = streamed.find("\nM73 P"); at != std::string::npos;
       at = streamed.find("\nM73 P", at + 1))
    ++progress;
  EXPECT_GT(progress, 20u) << "M73 at every layer";
  EXPECT_TRUE(whole == streamed);
  fs::remove_all(dir);
}

TEST(SliceStreamJob, MeshRouteAndBedCentreAsWhole) {
  const fs::path dir = work("mesh");
  for (const char* center : {"true", "false"}) {
    const std::string job = slice_job(
        dir, kRoot + "/examples/designs/concave_cylinder.obj", "voron_klipper",
        std::string("[placement]\ncenter = ") + center + "\noffset_x = 100\noffset_y = 100\n");
    const auto [whole, streamed] = whole_and_streamed(job, dir);
    ASSERT_GT(whole.size(), 10000u);
    EXPECT_TRUE(whole == streamed) << "center = " << center;
  }
  fs::remove_all(dir);
}

TEST(SliceStreamJob, FdmPlateStreamedIsWholeAndTheMergeOfItsShards) {
  const std::string job_file = kRoot + "/examples/jobs/lattice_plate_fdm.toml";
  const fs::path dir = work("plate");
  const auto [whole, streamed] = whole_and_streamed(job_file, dir);
  ASSERT_GT(whole.size(), 10000u);
  EXPECT_TRUE(whole == streamed) << "streamed plate differs from the whole run";
  for (int n : {1, 2, 5}) {
    std::vector<std::string> manifests;
    Diagnostics diag;
    for (int k = 1; k <= n; ++k) {
      Job shard = load_job(job_file, (dir / ("shards-" + std::to_string(n))).string(),
                           {"output.png=false"});
      shard.shard = k;
      shard.shards = n;
      shard.keep_toolpath = false;
      manifests.push_back(run_job(shard, diag).files.back());
    }
    // Beside the streamed output: the embedded job's paths are relative to the file's folder.
    const std::string merged =
        (dir / "stream" / ("merged-" + std::to_string(n) + ".gcode")).string();
    merge_shards(manifests, merged, diag);
    EXPECT_TRUE(read_file(merged) == streamed)
        << n << " shards merged differ from the streamed run";
  }
  fs::remove_all(dir);
}

TEST(SliceStreamJob, MachineErrorWhileStreamingLeavesNoFile) {
  const fs::path dir = work("error");
  // Off the bed: found once every layer is planned, before the file is committed.
  const std::string job_file =
      slice_job(dir, kRoot + "/examples/designs/csg_bracket.vcad", "prusa_mk4s_lwpla",
                "[placement]\ncenter = false\noffset_x = 1000\n[output]\npng = false\n");
  Job job = load_job(job_file, (dir / "out").string());
  job.keep_toolpath = false;
  Diagnostics diag;
  EXPECT_THROW(run_job(job, diag), MachineError);
  EXPECT_FALSE(fs::exists(job.output));
  if (fs::exists(dir / "out")) {
    EXPECT_TRUE(fs::is_empty(dir / "out")) << "temporaries left behind";
  }
  fs::remove_all(dir);
}

}  // namespace
