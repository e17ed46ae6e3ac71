// `trellis analyze part.cli --design sheet.vcad`: a laser build file (any tool's) against its
// design — vectors outside the part, FR_a per layer, scan time.
#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/machine/toolpath_3mf.hpp"

namespace trellis::cli {

bool is_laser_build_file(const std::string& path) {
  if (path.size() > 4 && (path.ends_with(".3mf") || path.ends_with(".3MF")))
    return toolpath_3mf_kind(path) == Toolpath3mfKind::Laser;
  return path.size() > 4 && (path.ends_with(".cli") || path.ends_with(".CLI"));
}

void analyze_laser_file(const std::string& path, const std::string& design,
                        const std::string& machine, const std::string& report) {
  Diagnostics diag;
  const LaserProfile prof =
      machine.empty() ? LaserProfile{} : command_settings(machine, {}).config().laser;
  std::string json;
  const JobResult r =
      analyze_build_file(path, design, prof, report.empty() ? nullptr : &json, diag);
  std::cout << r.summary << "\n";
  print_warnings(diag);
  if (!report.empty()) write_file_atomic(report, json);
}

}  // namespace trellis::cli
