// GIPPO planner (Fucile et al., Algorithm 1, Eq. 1): N randomized greedy solutions, best score
// kept. Per iteration: start a trail at a random incomplete node; at each step take, among the
// unused edges at both ends of the trail, the longest (`max`) or shortest (`min`); stop when
// neither end has an unused edge; repeat until every node is complete.
//
// Determinism, exactly (so an independent implementation reproduces it):
//  - iteration k draws from Rng::stream(seed, k);
//  - the start node is the r-th incomplete node in ascending id order, r = uniform_index(count);
//  - ties in length go to the trail's front end, then to the lower edge id;
//  - the best solution is the highest score, the lowest iteration on ties.
// Results are identical for any thread count.
#pragma once
#include <cstdint>
#include <vector>

#include "trellis/core/progress.hpp"
#include "trellis/plan/paths.hpp"

namespace trellis {

enum class GippoMode { Max, Min };

struct GippoParams {
  GippoMode mode = GippoMode::Max;  // take the longest (max) or shortest (min) edge
  int iterations = 500;             // solutions generated (paper: 500)
  std::uint64_t seed = 1;           // reproducible for a seed
  int threads = 0;                  // 0 = all cores
  Progress progress;                // optional
};

struct GippoResult {
  PathSet best;                // in generation order (not yet sorted)
  std::vector<double> scores;  // score of every iteration, in iteration order
  std::size_t best_iteration = 0;
  std::size_t worst_iteration = 0;
  PathSet worst;  // lowest-score solution (for OE comparison)
};

GippoResult plan_gippo(const Graph& g, const GippoParams& params);

// One GIPPO iteration (exposed for tests and benchmarks).
PathSet gippo_iteration(const Graph& g, GippoMode mode, std::uint64_t seed, std::uint64_t k);

}  // namespace trellis
