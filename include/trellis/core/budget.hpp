// Estimate before work: every route estimates the memory and time a run needs from its settings
// (layers × grid cells, lattice size, iterations × edges, image pixels, colours × material grid)
// and refuses above the run's budget before allocating anything, with the estimate and the
// setting to change in the message.
#pragma once
#include <functional>
#include <string>

namespace trellis {

struct Estimate {
  double bytes = 0;    // peak memory
  double seconds = 0;  // wall time with the run's threads (run.threads) on an ordinary machine
  std::string what;    // "GIPPO planning: 1e9 iterations × 1,200 edges"
  std::string change;  // the settings that shrink it, e.g. "--iterations (gippo.iterations)"
};

struct Budget {
  double memory = 0;     // bytes; 0 = half the memory available now (default_memory_budget)
  double seconds = 600;  // a generous bound on the estimated run time (10 minutes)
  bool force = false;    // run.force: go beyond the budget on purpose
  std::function<void(const Estimate&)> seen;  // told every estimate checked (Progress::estimate)
};

// Throws ResourceError (exit 2) when the estimate is beyond the budget and force is off.
void check_budget(const Estimate& estimate, const Budget& budget);

// Reading a mesh file (STL, OBJ, 3MF), from its size alone: nothing is read.
Estimate mesh_read_estimate(const std::string& path);

// MemAvailable from /proc/meminfo (bytes), 0 if unknown.
double available_memory_bytes();
// The memory budget when run.max_memory is not given: half of available_memory_bytes().
double default_memory_budget();

}  // namespace trellis
