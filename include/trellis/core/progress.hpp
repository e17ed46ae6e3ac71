// Progress and cancel: the one contract of every one-call route function (GIPPO/Euler planning
// via plan_lattice, plan_gippo, plan_aero, run_slice for planar and graded slicing, plan_pbf,
// slice_nonplanar). Each takes it in its run context (core/run_context.hpp: `context.progress`).
//  - `report(stage, fraction)` may be called from worker threads, possibly several at once for
//    parallel work (calls for one stage are serialised by the route only where it says so): make
//    it thread-safe and cheap. Fractions are in [0,1] and reach 1 when a stage ends.
//  - `cancel`, if set, is read by the work once per layer or iteration (and between stages); when
//    it is true the call stops and throws trellis::Cancelled, returning nothing partial. It may be
//    set from any thread, including from inside `report`.
//  - `estimate`, if set, sees each estimate a route makes before its work (core/budget.hpp), as
//    it is checked against the budget: the command line prints them with --progress.
// All are optional; a default Progress does nothing and costs one branch per layer.
#pragma once
#include <atomic>
#include <functional>
#include <string>

#include "trellis/core/budget.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

struct Progress {
  std::function<void(const std::string& stage, double fraction)> report;
  const std::atomic<bool>* cancel = nullptr;
  std::function<void(const Estimate&)> estimate;

  void operator()(const std::string& stage, double fraction) const {
    if (report) report(stage, fraction);
  }
  bool cancelled() const { return cancel && cancel->load(std::memory_order_relaxed); }
  // Throws Cancelled naming `what` (e.g. "GIPPO planning") if cancel is set.
  void check(const char* what) const {
    if (cancelled()) throw Cancelled(std::string(what) + " cancelled");
  }
};

}  // namespace trellis
