// The planners' reports: GIPPO and Euler (plan_report_json), AERO (aero_report_json), GIPPO's
// robustness over seeds (gippo_robustness_json).
#include <algorithm>
#include <nlohmann/json.hpp>
#include <numeric>

#include "trellis/job/reports.hpp"
#include "trellis/plan/periodic.hpp"

namespace trellis {

using nlohmann::ordered_json;

namespace {

void put_metrics(ordered_json& j, const PathMetrics& m) {
  j["paths"] = m.paths;
  j["lower_bound_paths"] = m.lower_bound_paths;
  j["score"] = m.score;
  j["lts"] = m.lts;
  j["oe"] = m.oe;
  j["total_length_mm"] = m.total_length;
  j["edges"] = m.total_edges;
  j["long_paths"] = m.long_paths;
  j["medium_paths"] = m.medium_paths;
  j["short_paths"] = m.short_paths;
}

}  // namespace

std::string plan_report_json(const PlanResult& r, const PlanParams& p, const Diagnostics& diag,
                             const ReportContext& ctx) {
  const bool gippo = p.planner == Planner::Gippo;
  ordered_json j;
  j["planner"] = to_string(p.planner);
  j["mode"] = gippo ? (p.gippo.mode == GippoMode::Max ? "max" : "min") : "euler";
  j["iterations"] = gippo ? p.gippo.iterations : 1;
  j["seed"] = p.gippo.seed;
  j["order"] = to_string(p.order);
  j["layer_height_mm"] = p.layer_height;
  j["long_path_nodes"] = p.long_path_nodes;
  j["merge_ends"] = p.merge_ends;
  j["input"] = ctx.input;
  j["nodes"] = ctx.nodes;
  j["lattice_edges"] = ctx.edges;
  put_metrics(j, r.total);
  j["travel_moves"] = r.travel.moves;
  j["travel_length_mm"] = r.travel.length;
  j["layers_count"] = r.toolpath.layers.size();
  ordered_json layers = ordered_json::array();
  for (const auto& l : r.layers) {
    ordered_json jl;
    jl["z"] = l.z;
    jl["material"] = l.material;
    put_metrics(jl, l.metrics);
    if (p.merge_ends) jl["merged_paths"] = l.merged;
    if (!l.scores.empty()) {
      const auto [mn, mx] = std::minmax_element(l.scores.begin(), l.scores.end());
      jl["best_iteration"] = l.best_iteration;
      jl["score_min"] = *mn;
      jl["score_max"] = *mx;
      jl["score_mean"] = std::accumulate(l.scores.begin(), l.scores.end(), 0.0) / l.scores.size();
      jl["oe_worst"] = l.worst.oe;
      jl["lts_worst"] = l.worst.lts;
      jl["scores"] = l.scores;
    }
    layers.push_back(std::move(jl));
  }
  j["layers"] = std::move(layers);
  ordered_json w;
  w["count"] = diag.total();
  w["by_kind"] = diag.counts();
  ordered_json messages = ordered_json::array();
  for (const auto& m : diag.messages()) messages.push_back(m.kind + ": " + m.text);
  w["messages"] = std::move(messages);
  j["warnings"] = std::move(w);
  return j.dump(2) + "\n";
}

std::string aero_report_json(const AeroResult& r, const AeroParams& p, const Diagnostics& diag,
                             const AeroReportInput& in) {
  nlohmann::ordered_json j;
  j["planner"] = "aero";
  j["method"] = to_string(p.method);
  if (p.method == AeroMethod::Periodic)
    j["cell_path"] = {{"cell_type", to_string(p.periodic.cell)},
                      {"cell_mm", p.periodic.size},
                      {"print_path", p.periodic.print_path},
                      {"cell_steps", periodic_cell_steps(p.periodic.cell, p.periodic.print_path)}};
  j["strategy"] = r.strategy;
  j["runs"] = r.runs;
  j["collision_model"] = p.collisions;
  j["nozzle"] = {{"radius_mm", p.nozzle.radius},
                 {"tip_clearance_mm", p.nozzle.tip_clearance},
                 {"node_clearance_mm", p.nozzle.node_clearance},
                 {"cone_half_angle_deg", p.nozzle.cone_half_angle_deg},
                 {"end_overlap_mm", p.nozzle.end_overlap}};
  j["input"] = in.lattice;
  j["nodes"] = in.nodes;
  j["struts"] = in.edges;
  j["groups"] = r.groups;
  j["group_sizes"] = r.group_sizes;
  j["trails"] = r.trails.trails.size();
  j["lower_bound_trails"] = r.lower_bound_trails;
  j["travel_moves"] = r.travel_moves;
  j["travel_length_mm"] = r.travel_length;
  j["max_trail_edges"] = r.max_trail_edges;
  j["print_length_mm"] = r.trails.total_length();
  j["steep_struts_bottom_up"] = r.steep_struts;
  j["blocking_relations"] = r.blocking_relations;
  j["pairs_tested"] = r.pairs_tested;
  if (in.checked_collisions >= 0) j["collisions"] = in.checked_collisions;
  j["struts_printed_once"] = in.checked_once;
  nlohmann::ordered_json v = nlohmann::ordered_json::array();
  for (const auto& x : r.violations) v.push_back({{"strut", x.edge}, {"obstructs", x.obstructs}});
  j["violations"] = std::move(v);
  j["unavoidable_collisions"] = r.mutual_pairs;
  j["fewest_collisions"] = p.fewest_collisions;
  j["collisions_planned"] = r.collisions_planned;
  j["collisions_lower_bound"] = r.collisions_lower_bound;
  j["collisions_proven_minimal"] = r.collisions_proven_minimal();
  {
    // Strongly connected parts of the obstruction relation (only these can cost collisions).
    std::size_t exact = 0, proven = 0, largest = 0;
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const auto& part : r.collision_parts) {
      exact += part.exact;
      proven += part.proven();
      largest = std::max(largest, part.struts);
      if (list.size() < 50)
        list.push_back({{"struts", part.struts},
                        {"relations", part.relations},
                        {"planned", part.planned},
                        {"lower_bound", part.lower_bound},
                        {"proven_minimal", part.proven()},
                        {"solved_exactly", part.exact}});
    }
    j["collision_parts"] = {{"count", r.collision_parts.size()},
                            {"largest_struts", largest},
                            {"proven_minimal", proven},
                            {"solved_exactly", exact},
                            {"largest_50", std::move(list)}};
  }
  j["seconds"] = {{"collision_model", r.seconds_blocking},
                  {"fewest_collisions", r.seconds_order},
                  {"planning", r.seconds_planning},
                  {"total", in.seconds}};
  nlohmann::ordered_json w;
  w["count"] = diag.total();
  w["by_kind"] = diag.counts();
  std::vector<std::string> messages;
  for (const auto& m : diag.messages()) messages.push_back(m.kind + ": " + m.text);
  w["messages"] = messages;
  j["warnings"] = std::move(w);
  return j.dump(2) + "\n";
}

std::string gippo_robustness_json(const GippoRobustness& r, const GippoParams& params) {
  ordered_json j;
  j["planner"] = "gippo";
  j["mode"] = params.mode == GippoMode::Max ? "max" : "min";
  j["iterations"] = params.iterations;
  j["seeds"] = r.seeds.size();
  j["first_seed"] = params.seed;
  j["best_score"] = {{"mean", r.mean},
                     {"sd", r.sd},
                     {"cv_percent", r.cv_percent()},
                     {"min", r.min},
                     {"max", r.max}};
  j["best_score_per_seed"] = r.best_scores;
  j["worst_score_per_seed"] = r.worst_scores;
  j["best_lts_per_seed"] = r.best_lts;
  j["worst_lts_per_seed"] = r.worst_lts;
  return j.dump(2) + "\n";
}

}  // namespace trellis
