// One call from a lattice graph to a toolpath: split the graph into planar layers (edges at one
// height) and materials, plan each part with gippo or euler, order the trails, and emit the
// toolpath IR with metrics for the report.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/plan/gippo.hpp"
#include "trellis/plan/order.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

enum class Planner { Gippo, Euler };
std::string to_string(Planner p);

struct PlanParams {
  Planner planner = Planner::Gippo;
  GippoParams gippo;  // used by the gippo planner
  PathOrder order = PathOrder::LongestFirst;
  double layer_height = 0.148;      // bead height (mm); nozzle z = design z + this
  std::size_t long_path_nodes = 5;  // LTS/OE threshold (paper: 5 nodes)
  double level_tolerance = 1e-6;    // edges within this z span are planar (mm)
  bool merge_ends = false;          // join paths that end at the same node (merge_shared_ends)
  bool keep_worst = false;          // gippo: also build the lowest-score solution's toolpath
  // A shard's layers (toolpath layers, one per planar level): only [first_layer, end_layer) are
  // planned, every other layer stays empty at its z.
  std::size_t first_layer = 0, end_layer = SIZE_MAX;
  // A shard of a travel-ordered plan (layers_carry_start): the travel order of a layer starts
  // where the layer below ended, so only layer 0 is ordered here (from the lattice's corner);
  // every other layer keeps its parts' trails in plan order, and all points stay at the
  // design's z, for order_deferred_layers (the merge) to finish.
  bool defer_order = false;
};

struct LayerReport {
  double z = 0;
  int material = 0;
  std::size_t edges = 0;
  PathMetrics metrics;
  PathMetrics worst;           // gippo: lowest-score iteration
  std::vector<double> scores;  // gippo: every iteration
  std::size_t best_iteration = 0;
  std::size_t merged = 0;  // joins made by merge_ends
};

struct PlanResult {
  Toolpath toolpath;
  Toolpath worst;  // gippo with keep_worst: the lowest-score iteration, ordered and placed alike
  std::vector<LayerReport> layers;
  PathMetrics total;  // summed over layers (score and percentages length-weighted)
  TravelStats travel;
};

// `context` (core/run_context.hpp): cancel checked per part (layer and material) and, for GIPPO,
// per iteration; GIPPO runs on its threads.
PlanResult plan_lattice(const Graph& g, const PlanParams& params, Diagnostics& diag,
                        const RunContext& context = {});

// The toolpath layers plan_lattice makes from `g` (one per planar level, one for a non-planar
// lattice), each as its number of edges: the estimated work that balances shards.
std::vector<double> plan_layer_work(const Graph& g, const PlanParams& params);

// Whether a layer of plan_lattice depends on the layer below. Only the travel order's start
// point crosses layers (the end of the layer below); a layer's trails (GIPPO, Euler) do not
// depend on it, and longest-first ignores it.
inline bool layers_carry_start(const PlanParams& p) {
  return p.order == PathOrder::Travel;
}

// The rest of a plan made with defer_order (its shards' layers joined): every layer after the
// first ordered from where the layer below ended, each part (a run of paths of one tool) from
// where the part before it ended, then every point lifted by the layer height. The toolpath
// plan_lattice makes without defer_order, to the bit.
void order_deferred_layers(Toolpath& tp, const PlanParams& params);

}  // namespace trellis
