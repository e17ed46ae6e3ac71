// The reports of the reader routes `analyze` / `compare` (analysis_json) and `check`
// (collision_check_json): the analysis and the collision replay return results, these turn them
// into documents, so src/analysis writes no JSON (docs/architecture.md).
#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>

#include "trellis/job/reports.hpp"

namespace trellis {

std::string analysis_json(const Analysis& a) {
  nlohmann::ordered_json j;
  j["name"] = a.name;
  j["layers"] = a.counts.layers;
  j["paths"] = a.paths;
  j["toolpath_paths"] = a.counts.toolpath_paths;
  j["extrusion_starts"] = a.counts.extrusion_starts;
  j["extruded_length_mm"] = a.extruded_length;
  j["travel_moves"] = a.counts.travel_moves;
  j["travel_length_mm"] = a.counts.travel_length;
  j["retractions"] = a.counts.retractions;
  j["filament_mm"] = a.counts.filament;
  j["print_time_s"] = a.counts.print_time_s;
  j["heating_s"] = a.counts.heating_s;
  j["prime_length_mm"] = a.counts.prime_length;
  j["prime_filament_mm"] = a.counts.prime_filament;
  if (!a.counts.parts.empty()) {
    auto& parts = j["parts"] = nlohmann::json::array();
    for (const auto& p : a.counts.parts)
      parts.push_back({{"label", p.label},
                       {"extruded_length_mm", p.extruded_length},
                       {"filament_mm", p.filament},
                       {"print_time_s", p.print_time_s}});
  }
  {
    // Per layer: starts, retractions, travel; with a design, the least number of paths.
    nlohmann::ordered_json per;
    per["z"] = nlohmann::json::array();
    per["starts"] = nlohmann::json::array();
    per["retractions"] = nlohmann::json::array();
    per["travel_moves"] = nlohmann::json::array();
    per["travel_mm"] = nlohmann::json::array();
    for (const auto& l : a.counts.per_layer) {
      per["z"].push_back(std::round(l.z * 1e4) / 1e4);
      per["starts"].push_back(l.starts);
      per["retractions"].push_back(l.retractions);
      per["travel_moves"].push_back(l.travel_moves);
      per["travel_mm"].push_back(std::round(l.travel_length * 1e3) / 1e3);
    }
    if (a.has_design) {
      per["starts_lower_bound"] = nlohmann::json::array();
      for (std::size_t i = 0; i < a.counts.per_layer.size(); ++i)
        per["starts_lower_bound"].push_back(i < a.layers.size() ? a.layers[i].lower_bound : 0);
    }
    j["per_layer"] = std::move(per);
  }
  j["segments"] = a.edges_real;
  j["score"] = a.score;
  j["lts"] = a.lts;
  j["oe"] = a.oe;
  if (a.has_design) {
    j["aligned_by_mm"] = {a.shift.x, a.shift.y};
    j["auto_aligned"] = a.auto_aligned;
    j["nominal_length_mm"] = a.nominal_length;
    j["extrusion_ratio"] = a.extrusion_ratio;
    j["double_length_mm"] = a.double_length;
    j["off_design_length_mm"] = a.off_design_length;
    j["design_edges"] = a.design_edges;
    j["missing_edges"] = a.missing_edges;
    j["score_corrected"] = a.score_corrected;
  }
  return j.dump(2) + "\n";
}

std::string collision_check_json(const CollisionCheck& c, const CheckOptions& options) {
  using nlohmann::ordered_json;
  ordered_json j;
  j["ok"] = c.ok();
  j["nozzle"] = {{"radius_mm", options.nozzle.radius},
                 {"tip_clearance_mm", options.nozzle.tip_clearance},
                 {"node_clearance_mm", options.nozzle.node_clearance},
                 {"cone_half_angle_deg", options.nozzle.cone_half_angle_deg},
                 {"snap_mm", options.snap}};
  j["paths"] = c.paths;
  j["segments"] = c.segments;
  j["struts"] = c.struts;
  j["struts_printed_once"] = c.printed_once;
  j["missing_struts"] = c.missing;
  j["repeated_struts"] = c.repeated;
  j["off_design_segments"] = c.off_design_segments;
  j["collisions"] = c.collisions;
  ordered_json hits = ordered_json::array();
  auto pt = [](Vec3 p) { return std::vector<double>{p.x, p.y, p.z}; };
  for (const auto& h : c.hits)
    hits.push_back({{"path", h.path},
                    {"segment", h.segment},
                    {"strut", h.strut},
                    {"hit_strut", h.hit_strut},
                    {"hit_path", h.hit_path},
                    {"tip", pt(h.tip)},
                    {"point", pt(h.point)}});
  j["collision_list"] = std::move(hits);
  ordered_json td = ordered_json::array();
  for (const auto& [path, strut] : c.top_down) td.push_back({{"path", path}, {"strut", strut}});
  j["steep_struts_printed_top_down"] = std::move(td);
  j["pairs_tested"] = c.pairs_tested;
  return j.dump(2) + "\n";
}

}  // namespace trellis
