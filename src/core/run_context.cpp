#include "trellis/core/run_context.hpp"

#include <tbb/task_arena.h>

namespace trellis {

void RunContext::check_budget(const Estimate& estimate) const {
  if (budget.seen || !progress.estimate) {
    trellis::check_budget(estimate, budget);
    return;
  }
  Budget b = budget;
  b.seen = progress.estimate;
  trellis::check_budget(estimate, b);
}

void RunContext::run(const std::function<void()>& work) const {
  // Already no wider (an arena of the context's own, or fewer cores): no arena of its own.
  if (threads <= 0 || tbb::this_task_arena::max_concurrency() <= threads) {
    work();
    return;
  }
  tbb::task_arena arena(threads);
  arena.execute(work);
}

}  // namespace trellis
