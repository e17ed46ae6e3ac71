// A job run whole and in n shards merged (issue 23's exactness checks): each shard is its own
// job, as a cluster runs it; the merged file lands beside the whole run's output, since paths in
// the embedded job are relative to it.
#pragma once
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/plate.hpp"

namespace trellis::test {

struct WholeAndMerged {
  std::string single, merged;  // the bytes of the whole run's file and of the merged shards
};

// Runs `job_file` in `n` shards into `dir`/shards-n and merges them beside the whole run's
// output in `dir`; returns the merged bytes. `file` picks the output (Job::output, or Job::gcode
// where a route writes more); `each_shard` may check every shard's result.
inline std::string merged_shards(
    const std::string& job_file, const std::filesystem::path& dir, int n,
    const std::vector<std::string>& sets = {}, std::string Job::*file = &Job::output,
    const std::function<void(const Job&, const JobResult&)>& each_shard = {}) {
  namespace fs = std::filesystem;
  Diagnostics diag;
  const fs::path sdir = dir / ("shards-" + std::to_string(n));
  std::vector<std::string> manifests;
  for (int k = 1; k <= n; ++k) {
    Job shard = load_job(job_file, sdir.string(), sets);
    shard.shard = k;
    shard.shards = n;
    const JobResult r = run_job(shard, diag);
    EXPECT_FALSE(fs::exists(shard.*file)) << job_file << ": a shard writes no whole output";
    if (each_shard) each_shard(shard, r);
    manifests.push_back(r.files.back());
  }
  const Job whole = load_job(job_file, dir.string(), sets);
  const std::string merged =
      (dir / ("merged-" + std::to_string(n) + fs::path(whole.*file).extension().string())).string();
  merge_shards(manifests, merged, diag);
  return read_file(merged);
}

// The job run whole into `dir` and merged from `n` shards (as merged_shards).
inline WholeAndMerged run_whole_and_shards(
    const std::string& job_file, const std::filesystem::path& dir, int n,
    const std::vector<std::string>& sets = {}, std::string Job::*file = &Job::output,
    const std::function<void(const Job&, const JobResult&)>& each_shard = {}) {
  Diagnostics diag;
  const Job whole = load_job(job_file, dir.string(), sets);
  run_job(whole, diag);
  WholeAndMerged out;
  out.single = read_file(whole.*file);
  out.merged = merged_shards(job_file, dir, n, sets, file, each_shard);
  return out;
}

}  // namespace trellis::test
