// The pbf route writes its build file layer by layer when only files are wanted (the command
// line: Job::keep_toolpath = false) and keeps the whole toolpath otherwise (Python): same bytes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support/temp_dir.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

TEST(PbfStreamJob, StreamedBuildFileIsTheWholeToolpathsFile) {
  const test::TempDir tmp("trellis_pbf_stream_job");
  const fs::path dir = tmp.path();
  const fs::path job_file = dir / "g.toml";
  std::ofstream(job_file)
      << "[job]\nroute = \"pbf\"\nname = \"g\"\n[pbf]\nsize = [2.5, 2.5, 0.4]\n";
  for (const bool binary : {false, true}) {
    std::string bytes[2];
    for (const bool keep : {true, false}) {
      const fs::path out = dir / (keep ? "keep" : "stream");
      // No previews (they need the whole toolpath).
      Job job = load_job(job_file.string(), out.string(),
                         {binary ? "pbf.binary=true" : "pbf.binary=false", "output.png=false"});
      job.keep_toolpath = keep;
      Diagnostics diag;
      const JobResult r = run_job(job, diag);
      EXPECT_EQ(static_cast<bool>(r.toolpath), keep);
      ASSERT_FALSE(r.files.empty());
      ASSERT_EQ(fs::path(r.files.front()).extension(), ".cli");
      bytes[keep ? 0 : 1] = read_file(r.files.front());
    }
    EXPECT_GT(bytes[0].size(), 5000u);
    EXPECT_EQ(bytes[0], bytes[1]) << (binary ? "binary" : "ascii");
  }
  fs::remove_all(dir);
}

}  // namespace
