// GIPPO planner (Fucile et al., Algorithm 1, Eq. 1): N randomized greedy solutions, best score
// kept. Per iteration: start a trail at a random incomplete node; at each step take, among the
// unused edges at both ends of the trail, the longest (`max`) or shortest (`min`); stop when
// neither end has an unused edge; repeat until every node is complete.
//
// Determinism, exactly (so an independent implementation reproduces it):
//  - iteration k draws from Rng::stream(seed, k);
//  - the start node is the r-th incomplete node in ascending id order, r = uniform_index(count);
//  - lengths are compared rounded to 1 nm (gippo_length_key), so a translated or rotated copy of
//    a lattice, whose equal struts differ by floating-point noise, is planned alike;
//  - the candidates are the unused edges of the best length at the front end (ascending edge
//    id), then those at the back end not already listed; with more than one, the pick is
//    candidates[uniform_index(count)] from the same stream (many lattices have struts of one
//    length, where this keeps the 500 iterations exploring instead of repeating one choice);
//  - the best solution is the highest score, the lowest iteration on ties.
// Results are identical for any thread count.
#pragma once
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/run_context.hpp"
#include "trellis/plan/paths.hpp"

namespace trellis {

enum class GippoMode { Max, Min };

// The value GIPPO compares for a strut of `length` mm: its length in nanometres, rounded.
inline std::int64_t gippo_length_key(double length) {
  return std::llround(length * 1e6);
}

struct GippoParams {
  GippoMode mode = GippoMode::Max;  // take the longest (max) or shortest (min) edge
  int iterations = 500;             // solutions generated (paper: 500)
  std::uint64_t seed = 1;           // reproducible for a seed
};

struct GippoResult {
  PathSet best;                // in generation order (not yet sorted)
  std::vector<double> scores;  // score of every iteration, in iteration order
  std::size_t best_iteration = 0;
  std::size_t worst_iteration = 0;
  PathSet worst;  // lowest-score solution (for OE comparison)
};

// `context` (core/run_context.hpp): progress "gippo", cancel per iteration, its threads.
GippoResult plan_gippo(const Graph& g, const GippoParams& params, const RunContext& context = {});

// Robustness (the paper's Fig. 2 v-vi): GIPPO run with `seeds` consecutive seeds from
// params.seed; the spread of the best score over the seeds.
struct GippoRobustness {
  std::vector<std::uint64_t> seeds;
  std::vector<double> best_scores;   // per seed
  std::vector<double> worst_scores;  // per seed
  std::vector<double> best_lts;      // per seed, Eq. 2 of the best solution (%)
  std::vector<double> worst_lts;     // per seed, Eq. 2 of the worst solution (%)
  double mean = 0, sd = 0;           // of the best scores (sample standard deviation, n - 1)
  double min = 0, max = 0;
  double cv_percent() const { return mean != 0 ? 100 * sd / std::abs(mean) : 0; }
};
// Throws SettingError for seeds < 1. `long_nodes`: a path of that many nodes is long for LTS.
GippoRobustness gippo_robustness(const Graph& g, const GippoParams& params, int seeds,
                                 std::size_t long_nodes = 5, const RunContext& context = {});

// One GIPPO iteration (exposed for tests and benchmarks).
PathSet gippo_iteration(const Graph& g, GippoMode mode, std::uint64_t seed, std::uint64_t k);

}  // namespace trellis
