// Fuzzes the job file reader (the file is written to a temporary path first).
#include <unistd.h>

#include <fstream>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/job/job.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  static const std::string path = "/tmp/trellis_fuzz_job_" + std::to_string(::getpid()) + ".toml";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data), size);
  try {
    trellis::load_job(path);
  } catch (const trellis::Error&) {
  }
  return 0;
}
