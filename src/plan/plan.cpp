#include "trellis/plan/plan.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "trellis/core/error.hpp"
#include "trellis/plan/euler.hpp"

namespace trellis {

std::string to_string(Planner p) {
  return p == Planner::Gippo ? "gippo" : "euler";
}

namespace {

struct Part {
  std::size_t level = 0;  // the toolpath layer it goes into
  double z = 0;
  int material = 0;
  std::vector<EdgeId> edges;
};

// Groups edges into planar levels (both ends at one z) and materials. A lattice with struts
// spanning heights is planned as one part.
std::vector<Part> split_parts(const Graph& g, double tol, Diagnostics& diag) {
  bool planar = true;
  for (const auto& e : g.edges) planar &= std::abs(g.nodes[e.a].z - g.nodes[e.b].z) <= tol;
  std::vector<double> levels;
  if (planar) {
    for (const auto& e : g.edges) levels.push_back(g.nodes[e.a].z);
    std::sort(levels.begin(), levels.end());
    std::vector<double> uniq;
    for (double z : levels)
      if (uniq.empty() || z - uniq.back() > tol) uniq.push_back(z);
    levels = std::move(uniq);
  } else {
    diag.warn("non_planar_lattice",
              "struts span several heights: planned as one 3D part without nozzle-collision "
              "checks (collision-aware 3D planning is the AERO planner)");
    levels = {g.bbox().min.z};
  }
  std::map<std::pair<std::size_t, int>, Part> parts;
  for (EdgeId i = 0; i < g.edges.size(); ++i) {
    const auto& e = g.edges[i];
    std::size_t level = 0;
    if (planar)
      level = std::lower_bound(levels.begin(), levels.end(), g.nodes[e.a].z - tol) - levels.begin();
    Part& p = parts[{level, e.material}];
    p.level = level;
    p.z = levels[level];
    p.material = e.material;
    p.edges.push_back(i);
  }
  std::vector<Part> out;
  for (auto& [key, p] : parts) out.push_back(std::move(p));
  return out;
}

Graph subgraph(const Graph& g, const std::vector<EdgeId>& edges, std::vector<NodeId>& node_map) {
  Graph sub;
  std::vector<NodeId> local(g.nodes.size(), UINT32_MAX);
  node_map.clear();
  for (EdgeId i : edges) {
    Edge e = g.edges[i];
    for (NodeId* n : {&e.a, &e.b}) {
      if (local[*n] == UINT32_MAX) {
        local[*n] = static_cast<NodeId>(sub.nodes.size());
        sub.nodes.push_back(g.nodes[*n]);
        node_map.push_back(*n);
      }
      *n = local[*n];
    }
    sub.edges.push_back(e);
  }
  return sub;
}

PathMetrics pooled(const std::vector<LayerReport>& layers, std::size_t long_nodes,
                   const std::vector<PathSet>& sets) {
  PathSet all;
  PathMetrics m;
  for (const auto& s : sets) all.trails.insert(all.trails.end(), s.trails.begin(), s.trails.end());
  Graph empty;
  m = path_metrics(empty, all, long_nodes);
  m.lower_bound_paths = 0;
  for (const auto& l : layers) m.lower_bound_paths += l.metrics.lower_bound_paths;
  return m;
}

// The trails of one part as paths on the toolpath's layer at the part's z (the last layer when
// it is at the same z).
void append_layer(Toolpath& tp, const Graph& sub, const PathSet& set, const Part& part,
                  const PlanParams& params, bool lift = true) {
  Layer* layer = nullptr;
  const double z = part.z + params.layer_height;
  if (!tp.layers.empty() && std::abs(tp.layers.back().z - z) <= params.level_tolerance)
    layer = &tp.layers.back();
  else
    layer = &tp.layers.emplace_back(Layer{z, {}});
  for (const auto& t : set.trails) {
    Path p;
    p.role = PathRole::Strut;
    p.tool = part.material;
    p.height = params.layer_height;
    p.points.reserve(t.nodes.size());
    for (NodeId n : t.nodes) {
      const Vec3 q = sub.nodes[n];
      p.points.push_back({q.x, q.y, lift ? q.z + params.layer_height : q.z});
    }
    layer->paths.push_back(std::move(p));
  }
}

}  // namespace

PlanResult plan_lattice(const Graph& g, const PlanParams& params, Diagnostics& diag,
                        const RunContext& context) {
  const Progress& progress = context.progress;
  if (g.edges.empty()) throw GeometryError("the lattice has no edges to plan");
  if (!(params.layer_height > 0)) throw SettingError("layer height must be > 0 mm");
  std::size_t directed = 0;
  for (const auto& e : g.edges) directed += e.directed;
  if (directed)
    diag.warn("directed_ignored", std::to_string(directed) +
                                      " directed strut(s) planned as undirected (direction is "
                                      "honoured by the AERO planner)");
  PlanResult result;
  result.toolpath.source = to_string(params.planner);
  std::vector<PathSet> sets;
  // The only state that crosses layers: where the travel order starts (the last trail's end).
  Vec3 at = g.bbox().min;
  const auto parts = split_parts(g, params.level_tolerance, diag);
  for (std::size_t pi = 0; pi < parts.size(); ++pi) {
    progress.check("planning");
    const Part& part = parts[pi];
    if (part.level < params.first_layer || part.level >= params.end_layer) {
      // Not this shard's: the layer is kept, empty, at its z.
      append_layer(result.toolpath, Graph{}, PathSet{}, part, params);
      LayerReport skipped;
      skipped.z = part.z;
      skipped.material = part.material;
      skipped.edges = part.edges.size();
      result.layers.push_back(std::move(skipped));
      continue;
    }
    std::vector<NodeId> node_map;
    const Graph sub = subgraph(g, part.edges, node_map);
    LayerReport report;
    report.z = part.z;
    report.material = part.material;
    report.edges = sub.edges.size();
    PathSet set, worst;
    if (params.planner == Planner::Gippo) {
      Progress part_progress;
      part_progress.cancel = progress.cancel;
      if (progress.report)
        part_progress.report = [&](const std::string& stage, double f) {
          progress(stage, (static_cast<double>(pi) + f) / static_cast<double>(parts.size()));
        };
      auto r = plan_gippo(sub, params.gippo, context.with_progress(std::move(part_progress)));
      set = std::move(r.best);
      report.scores = std::move(r.scores);
      report.best_iteration = r.best_iteration;
      report.worst = path_metrics(sub, r.worst, params.long_path_nodes);
      if (params.keep_worst) worst = std::move(r.worst);
    } else {
      set = plan_euler(sub);
      progress("euler", static_cast<double>(pi + 1) / static_cast<double>(parts.size()));
    }
    if (params.merge_ends) report.merged = merge_shared_ends(set);
    report.metrics = path_metrics(sub, set, params.long_path_nodes);
    // Order in the sub-graph, starting where the previous part ended.
    Vec3 worst_at = at;
    if (params.defer_order) {
      // Layer 0 starts at the corner, known here; the others start at the layer below's end.
      if (part.level == 0) order_paths(sub, set, params.order, at);
      append_layer(result.toolpath, sub, set, part, params, false);
      if (!set.trails.empty()) at = sub.nodes[set.trails.back().nodes.back()];
      result.layers.push_back(std::move(report));
      sets.push_back(std::move(set));
      continue;
    }
    order_paths(sub, set, params.order, at);
    append_layer(result.toolpath, sub, set, part, params);
    if (params.keep_worst && !worst.trails.empty()) {
      order_paths(sub, worst, params.order, worst_at);
      append_layer(result.worst, sub, worst, part, params);
    }
    if (!set.trails.empty()) at = sub.nodes[set.trails.back().nodes.back()];
    result.layers.push_back(std::move(report));
    sets.push_back(std::move(set));
  }
  result.total = pooled(result.layers, params.long_path_nodes, sets);
  result.travel = travel_stats(result.toolpath);
  return result;
}

void order_deferred_layers(Toolpath& tp, const PlanParams& params) {
  Vec3 at{};
  for (std::size_t li = 0; li < tp.layers.size(); ++li) {
    auto& paths = tp.layers[li].paths;
    // Each part's paths are a run of one tool (parts of a level are planned in material order).
    for (std::size_t i = 0; i < paths.size();) {
      std::size_t j = i;
      while (j < paths.size() && paths[j].tool == paths[i].tool) ++j;
      if (li > 0) {
        // The part's trails as they came out of the planner, over their own points.
        Graph pts;
        PathSet set;
        for (std::size_t k = i; k < j; ++k) {
          Trail t;
          for (const Vec3& q : paths[k].points) {
            t.nodes.push_back(static_cast<NodeId>(pts.nodes.size()));
            pts.nodes.push_back(q);
          }
          t.edges.assign(t.nodes.size() - 1, 0);
          set.trails.push_back(std::move(t));
        }
        order_paths(pts, set, params.order, at);
        for (std::size_t k = i; k < j; ++k) {
          const Trail& t = set.trails[k - i];
          std::vector<Vec3> points;
          points.reserve(t.nodes.size());
          for (NodeId n : t.nodes) points.push_back(pts.nodes[n]);
          paths[k].points = std::move(points);
        }
      }
      at = paths[j - 1].points.back();
      i = j;
    }
    for (auto& p : paths)
      for (auto& q : p.points) q.z += params.layer_height;
  }
}

std::vector<double> plan_layer_work(const Graph& g, const PlanParams& params) {
  Diagnostics quiet;  // plan_lattice gives the warnings
  std::vector<double> work;
  for (const Part& p : split_parts(g, params.level_tolerance, quiet)) {
    if (work.size() <= p.level) work.resize(p.level + 1, 0.0);
    work[p.level] += static_cast<double>(p.edges.size());
  }
  return work;
}

}  // namespace trellis
