// Fuzzes the job runner end to end: a job file is read and run (any route) with small limits —
// run.max_memory 256 MB, run.max_time 0.1 s estimated (the estimates are for release builds; the
// sanitized fuzz build runs 10-50x slower), previews off, one thread — into a private
// output folder. Any input runs or throws trellis::Error; nothing is written outside the
// folder, and a failed job leaves it empty.
#include <stdlib.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/job/job.hpp"

namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  static const fs::path dir = [] {
    std::string t = (fs::temp_directory_path() / "trellis_fuzz_run_XXXXXX").string();
    if (!::mkdtemp(t.data())) std::abort();
    return fs::path(t);
  }();
  const fs::path job = dir / "job.toml", out = dir / "out";
  std::ofstream(job, std::ios::binary).write(reinterpret_cast<const char*>(data), size);
  std::error_code ec;
  fs::remove_all(out, ec);
  bool failed = false;
  try {
    trellis::Diagnostics diag;
    trellis::Job j = trellis::load_job(job.string(), out.string());
    for (const auto& [key, value] : {std::pair<const char*, const char*>{"run.max_memory", "256"},
                                     {"run.max_time", "0.1"},
                                     {"run.threads", "1"},
                                     {"output.png", "false"},
                                     {"output.preview_layers", "0"},
                                     {"output.frames", "0"}})
      j.settings.set_text(key, value, {"fuzz"});
    j.preview.clear();
    (void)trellis::run_job(j, diag);
  } catch (const trellis::Error&) {
    failed = true;
  }
  // Only the job file and the output folder; after a failure, no output either.
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path() != job && e.path() != out) std::abort();
  if (failed && fs::exists(out) && !fs::is_empty(out)) std::abort();
  return 0;
}
