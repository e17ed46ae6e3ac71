// `trellis analyze part.cli --design sheet.vcad`: a laser build file (any tool's) against its
// design — vectors outside the part, FR_a per layer, scan time — as a report and a summary.
#include <fmt/format.h>

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <tuple>

#include "routes.hpp"
#include "trellis/field/implicit_3mf.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/slice/pbf_analysis.hpp"
#include "trellis/slice/pbf_lasers.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis {

namespace {

nlohmann::ordered_json parameter_sets(const Toolpath& tp, const ScanTiming& timing) {
  struct Sum {
    std::size_t vectors = 0;
    double length = 0, seconds = 0;
  };
  std::map<std::tuple<bool, double, double>, Sum> sums;
  for (const auto& l : tp.layers) {
    const std::vector<double> t = path_scan_seconds(l, timing);
    for (std::size_t k = 0; k < l.paths.size(); ++k) {
      const Path& p = l.paths[k];
      const bool hatch = p.role == PathRole::Hatch || p.role == PathRole::Infill;
      Sum& s = sums[{hatch, p.power, p.speed}];
      ++s.vectors;
      s.length += p.length();
      s.seconds += t[k];
    }
  }
  nlohmann::ordered_json out = nlohmann::json::array();
  for (const auto& [key, s] : sums) {
    // The set's name where the file names it (CLI labels, 3MF profiles).
    const auto [hatch, power, speed] = key;
    const int named =
        parameter_set_of(tp, hatch ? PathRole::Hatch : PathRole::Contour, power, speed);
    out.push_back(
        {{"kind", hatch ? "hatch" : "contour"},
         {"name", named < 0 ? "" : tp.parameter_sets[static_cast<std::size_t>(named)].name},
         {"power_w", power},
         {"speed_mm_s", speed},
         {"vectors", s.vectors},
         {"length_mm", s.length},
         {"scan_time_s", s.seconds}});
  }
  return out;
}

}  // namespace

bool is_laser_toolpath(const Toolpath& tp) {
  if (!tp.lasers.empty()) return true;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths)
      if (p.power > 0) return true;
  return false;
}

JobResult analyze_build_file(const std::string& path, const std::string& design,
                             const LaserProfile& prof, std::string* report_json,
                             Diagnostics& diag) {
  // A .cli, a 3MF package with the Toolpath Extension or a toolpath JSON: the same IR, the same
  // measures.
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  const Toolpath tp = ext == ".3mf"    ? read_toolpath_3mf_file(path, &diag)
                      : ext == ".json" ? read_toolpath(path)
                                       : read_cli_file(path, &diag);
  return analyze_build_toolpath(tp, path, design, prof, report_json);
}

JobResult analyze_build_toolpath(const Toolpath& tp, const std::string& path,
                                 const std::string& design, const LaserProfile& prof,
                                 std::string* report_json) {
  std::size_t vectors = 0;
  for (const auto& l : tp.layers) vectors += l.paths.size();
  nlohmann::ordered_json j;
  j["format"] = "trellis.laser_analysis";
  j["version"] = 1;
  j["file"] = path;
  j["layers"] = tp.layers.size();
  j["vectors"] = vectors;
  // Read back as written, with or without a design: what `trellis.analyze` of the toolpath
  // that made the file gives (paths, scanned length).
  j["paths"] = vectors;
  j["scan_length_mm"] = tp.extrusion_length();
  // Scan time as the profile's scanner runs it (marks, jumps, delays), with or without a design.
  const ScanTiming timing = scan_timing(prof);
  double mark_s = 0, jump_s = 0, delay_s = 0;
  std::size_t jumps = 0, corners = 0;
  nlohmann::ordered_json layer_times = nlohmann::json::array();
  for (const auto& l : tp.layers) {
    const ScanClock c = layer_scan_clock(l, timing);
    mark_s += c.mark_seconds();
    jump_s += c.jump_seconds();
    delay_s += c.delay_seconds();
    jumps += c.jumps();
    corners += c.corners();
    layer_times.push_back(c.seconds());
  }
  j["scan_time"] = {{"total_s", mark_s + jump_s + delay_s},
                    {"mark_s", mark_s},
                    {"jump_s", jump_s},
                    {"delay_s", delay_s},
                    {"jumps", jumps},
                    {"corners", corners},
                    {"per_layer_s", layer_times}};
  // Per laser parameter set (a path's role, power and speed: a .cli id's CLI+ block, a 3MF
  // profile): vectors, length and scan time (each path's jump in, marking and delays).
  j["parameter_sets"] = parameter_sets(tp, timing);
  // Several lasers (the paths' laser ids): each one's scan time, and the build time.
  // Each laser with its own speeds and delays where they differ: the profile's, else the file's.
  std::vector<ScanTiming> each =
      lasers_differ(prof) ? laser_timings(prof) : std::vector<ScanTiming>{};
  if (each.empty())
    for (const LaserParameters& l : tp.lasers) each.push_back(l.timing);
  const LaserTimes lt = each.empty() ? laser_times(tp, scan_timing(prof)) : laser_times(tp, each);
  const std::vector<double> totals = lt.totals();
  std::string lasers_said;
  if (totals.size() > 1) {
    nlohmann::ordered_json per = nlohmann::ordered_json::array();
    for (const auto& l : lt.per_layer) per.push_back(l);
    j["lasers"] = {{"count", totals.size()},
                   {"scan_time_s", totals},
                   {"build_time_s", lt.build_seconds()},
                   {"per_layer", {{"scan_time_s", per}}}};
    std::string each;
    for (double s : totals) each += (each.empty() ? "" : " + ") + routes::fixed(s, 1);
    lasers_said = fmt::format("; {} lasers scan {} s, build time {} s", totals.size(), each,
                              routes::fixed(lt.build_seconds(), 1));
  }
  JobResult out;
  out.toolpath = std::make_shared<Toolpath>(tp);
  if (design.empty()) {
    out.summary = fmt::format(
        "{}: {} layers, {} vectors ({} mm); scan time {} s (marking {} s, jumps {} s, "
        "delays {} s); no --design: nothing to measure against",
        path, tp.layers.size(), vectors, routes::fixed(tp.extrusion_length(), 1),
        routes::fixed(mark_s + jump_s + delay_s, 1), routes::fixed(mark_s, 1),
        routes::fixed(jump_s, 1), routes::fixed(delay_s, 1));
  } else {
    LaserAnalysisOptions lo;
    lo.melt_pool = prof.melt_pool_width;
    lo.timing = scan_timing(prof);
    const LaserAnalysis a = analyze_laser_toolpath(tp, read_field_design(design).field, lo);
    j["design"] = design;
    j["outside_vectors"] = a.outside_vectors;
    j["outside_length_mm"] = a.outside_length;
    j["max_outside_mm"] = a.max_outside;
    j["scan_length_mm"] = a.scan_length;  // contours and hatches: the same length as above
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
    out.summary = fmt::format(
        "{}: {} layers, {} vectors ({} mm); outside the design: {} vectors ({} mm, farthest {} "
        "µm); "
        "FR_a mean {} cv {}; scan time {} s",
        path, tp.layers.size(), a.vectors, routes::fixed(a.scan_length, 1), a.outside_vectors,
        routes::fixed(a.outside_length, 3), routes::fixed(a.max_outside * 1e3, 1),
        routes::fixed(a.fr_mean, 3), routes::fixed(a.fr_cv, 3), routes::fixed(a.scan_time, 1));
  }
  out.summary += lasers_said;
  if (report_json) *report_json = j.dump(2) + "\n";
  return out;
}

}  // namespace trellis
