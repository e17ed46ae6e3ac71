// One run context (issue 42): what a call of the library runs *with*, as opposed to what it
// makes (its options, params, settings). Every plan, slice, pbf, non-planar and meshing entry
// point takes it the same way, as its last argument `const RunContext& context = {}`, and so do
// the routes and readers (RouteSpec::run): run_job builds it from the run
// section of the settings (run.threads, run.max_memory, run.max_time, run.force).
//  - progress: report, cancel and the estimate hook (core/progress.hpp);
//  - diagnostics: where warnings go; null drops them (warn() is then a no-op);
//  - threads: the workers oneTBB work of the call may use (a task_arena), 0 = all cores; a
//    result is the same for any thread count;
//  - budget: memory and time an estimate before work may reach (core/budget.hpp).
// A default RunContext reports nothing, never cancels, drops warnings and uses every core.
#pragma once
#include <functional>
#include <string>

#include "trellis/core/budget.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/progress.hpp"

namespace trellis {

struct RunContext {
  Progress progress;
  Diagnostics* diagnostics = nullptr;
  int threads = 0;  // 0 = all cores
  Budget budget;

  // Throws Cancelled naming `what` if the run is cancelled.
  void check(const char* what) const { progress.check(what); }
  bool cancelled() const { return progress.cancelled(); }
  void report(const std::string& stage, double fraction) const { progress(stage, fraction); }
  // A warning of `kind` to the diagnostics, if there are any.
  void warn(const std::string& kind, const std::string& message) const {
    if (diagnostics) diagnostics->warn(kind, message);
  }
  // check_budget(estimate, budget), the estimate told to progress.estimate when the budget's own
  // hook is unset.
  void check_budget(const Estimate& estimate) const;
  // Runs `work` with at most `threads` oneTBB workers (an arena of that many; directly when
  // threads is 0).
  void run(const std::function<void()>& work) const;
  // This context with another progress (a sub-stage's), the rest shared.
  RunContext with_progress(Progress p) const {
    RunContext c = *this;
    c.progress = std::move(p);
    return c;
  }
};

}  // namespace trellis
