// Runs the trellis CLI (TRELLIS_CLI) in a shell and returns its exit code and output, for tests
// that check what a user sees. Each test binary gets its own scratch folder per process.
#pragma once
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "trellis/core/file.hpp"

namespace trellis::test {

struct CliRun {
  int code = -1;
  std::string out, err;
};

// A scratch folder for `name`, emptied once per process.
inline std::filesystem::path scratch(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(getpid()));
  static bool fresh = [&] {
    std::filesystem::remove_all(p);
    return true;
  }();
  (void)fresh;
  std::filesystem::create_directories(p);
  return p;
}

inline CliRun run_cli(const std::string& args, const std::filesystem::path& dir) {
  const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
  const int status =
      std::system((std::string(TRELLIS_CLI) + " " + args + " >" + out + " 2>" + err).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(out), read_file(err)};
}

}  // namespace trellis::test
