// `trellis analyze part.cli --design sheet.vcad`: a laser build file (any tool's) against its
// design — vectors outside the part, FR_a per layer, scan time.
#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/slice/pbf_analysis.hpp"

namespace trellis::cli {

bool is_laser_build_file(const std::string& path) {
  return path.size() > 4 && (path.ends_with(".cli") || path.ends_with(".CLI"));
}

void analyze_laser_file(const std::string& path, const std::string& design,
                        const std::string& machine, const std::string& report) {
  Diagnostics diag;
  const Toolpath tp = read_cli_file(path, &diag);
  const LaserProfile prof = machine.empty() ? LaserProfile{} : load_laser_profile(machine);
  std::size_t vectors = 0;
  for (const auto& l : tp.layers) vectors += l.paths.size();
  nlohmann::ordered_json j;
  j["format"] = "trellis.laser_analysis";
  j["version"] = 1;
  j["file"] = path;
  j["layers"] = tp.layers.size();
  j["vectors"] = vectors;
  if (design.empty()) {
    std::cout << path << ": " << tp.layers.size() << " layers, " << vectors
              << " vectors (no --design: nothing to measure against)\n";
  } else {
    LaserAnalysisOptions lo;
    lo.melt_pool = prof.melt_pool_width;
    lo.timing = scan_timing(prof);
    const LaserAnalysis a = analyze_laser_toolpath(tp, read_vcad(design).field, lo);
    j["design"] = design;
    j["outside_vectors"] = a.outside_vectors;
    j["outside_length_mm"] = a.outside_length;
    j["max_outside_mm"] = a.max_outside;
    j["scan_length_mm"] = a.scan_length;
    j["scan_time_s"] = a.scan_time;
    j["fr_a"] = {{"mean", a.fr_mean}, {"cv", a.fr_cv}};
    nlohmann::ordered_json s;
    for (const char* k : {"z_mm", "design_z_mm", "area_mm2", "fr_a", "contour_mm", "hatch_mm",
                          "outside_vectors", "outside_mm", "scan_time_s"})
      s[k] = nlohmann::json::array();
    for (const auto& L : a.layers) {
      s["z_mm"].push_back(L.z);
      s["design_z_mm"].push_back(L.design_z);
      s["area_mm2"].push_back(L.area);
      s["fr_a"].push_back(L.fr);
      s["contour_mm"].push_back(L.contour_length);
      s["hatch_mm"].push_back(L.hatch_length);
      s["outside_vectors"].push_back(L.outside_vectors);
      s["outside_mm"].push_back(L.outside_length);
      s["scan_time_s"].push_back(L.scan_time);
    }
    j["per_layer"] = s;
    std::cout << path << ": " << tp.layers.size() << " layers, " << a.vectors << " vectors ("
              << num(a.scan_length, 1) << " mm); outside the design: " << a.outside_vectors
              << " vectors (" << num(a.outside_length, 3) << " mm, farthest "
              << num(a.max_outside * 1e3, 1) << " µm); FR_a mean " << num(a.fr_mean, 3) << " cv "
              << num(a.fr_cv, 3) << "; scan time " << num(a.scan_time, 1) << " s\n";
  }
  print_warnings(diag);
  if (!report.empty()) write_file_atomic(report, j.dump(2) + "\n");
}

}  // namespace trellis::cli
