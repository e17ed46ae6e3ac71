#include "trellis/plan/report.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <numeric>

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

}  // namespace trellis
