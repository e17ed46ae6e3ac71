#include "trellis/core/budget.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

double available_memory_bytes() {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  double kb = 0;
  while (in >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024;
  return 0;  // unknown: no memory budget
}

namespace {

std::string bytes_text(double b) {
  if (!std::isfinite(b)) return "an unbounded amount of memory";
  if (b >= 1e12) return fmt::format("{:.3g} TB", b / 1e12);
  if (b >= 1e9) return fmt::format("{:.3g} GB", b / 1e9);
  return fmt::format("{:.0f} MB", std::ceil(b / 1e6));
}

std::string seconds_text(double s) {
  if (!std::isfinite(s)) return "forever";
  if (s >= 86400 * 365.0) return fmt::format("{:.3g} years", s / (86400 * 365.0));
  if (s >= 86400) return fmt::format("{:.3g} days", s / 86400);
  if (s >= 3600) return fmt::format("{:.3g} h", s / 3600);
  if (s >= 60) return fmt::format("{:.3g} minutes", s / 60);
  return fmt::format("{:.3g} s", s);
}

}  // namespace

// The default memory budget: half of what the machine has available when the run starts. The
// estimates are orders of magnitude, the page cache and the other programs on the machine need
// room too, and a run that goes past the whole of it ends in the out-of-memory killer, not in a
// message (an estimate of 15 GB on a 24 GB machine is refused).
constexpr double kAvailableShare = 0.5;

double default_memory_budget() {
  return kAvailableShare * available_memory_bytes();
}

void check_budget(const Estimate& e, const Budget& b) {
  if (b.seen) b.seen(e);
  if (b.force) return;
  arm_watchdog(b.seconds);
  const double memory = b.memory > 0 ? b.memory : default_memory_budget();
  const bool too_big = !(e.bytes <= memory) && memory > 0;  // NaN estimates are refused too
  const bool too_long = !(e.seconds <= b.seconds);
  if (!too_big && !too_long) return;
  std::string msg = "refused before starting: " + e.what + " needs about " +
                    (e.bytes > 0 ? bytes_text(e.bytes) + " of memory and " : "") +
                    seconds_text(e.seconds) + " (estimate), beyond the ";
  if (too_big)
    msg += "memory budget of " + bytes_text(memory) +
           (b.memory > 0 ? " (run.max_memory)" : " (half the memory available; run.max_memory)");
  if (too_big && too_long) msg += " and the ";
  if (too_long) msg += "time budget of " + seconds_text(b.seconds) + " (run.max_time)";
  msg += ". Change " + e.change +
         ", or raise the budget (run.max_memory in MB, run.max_time in s) or set run.force to run "
         "it anyway";
  throw ResourceError(msg, {"", 0, too_big ? "run.max_memory" : "run.max_time"});
}

// Reading a mesh file, from its size. Derived from the in-memory layout, rounded up: a binary
// STL's 50 bytes a triangle become three soup vertices (72 B), the welded copy and its hash
// (about 150 B), so about 8 times the file; a 3MF is a ZIP of XML, about 40 times.
Estimate mesh_read_estimate(const std::string& path) {
  std::error_code ec;
  const double size = static_cast<double>(std::filesystem::file_size(path, ec));
  Estimate e;
  if (ec) return e;  // the reader says what is wrong with the file
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return std::tolower(ch); });
  const bool zip = ext == ".3mf";
  e.bytes = size * (zip ? 40 : 8);
  e.seconds = size * (zip ? 2e-7 : 5e-8);
  e.what = fmt::format("reading a {:.3g} MB mesh file", size / 1e6);
  e.change = "the mesh (decimate it)";
  return e;
}

}  // namespace trellis
