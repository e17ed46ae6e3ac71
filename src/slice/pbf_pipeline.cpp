// The in-order pipeline PBF layers run through (tbb::parallel_pipeline): layer numbers handed
// out in order, layers computed in parallel with at most two per thread in flight (so memory
// stays bounded however many layers a run has), then collected in order.
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>

#include "pbf_internal.hpp"

namespace trellis::pbf_detail {

void run_layers_in_order(std::size_t first, std::size_t last,
                         const std::function<void(std::size_t)>& compute,
                         const std::function<void(std::size_t)>& collect) {
  const std::size_t tokens =
      2 * static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  std::size_t next = first;
  tbb::parallel_pipeline(
      tokens, tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                                  [&](tbb::flow_control& fc) -> std::size_t {
                                                    if (next >= last) {
                                                      fc.stop();
                                                      return 0;
                                                    }
                                                    return next++;
                                                  }) &
                  tbb::make_filter<std::size_t, std::size_t>(tbb::filter_mode::parallel,
                                                             [&](std::size_t i) {
                                                               compute(i);
                                                               return i;
                                                             }) &
                  tbb::make_filter<std::size_t, void>(tbb::filter_mode::serial_in_order,
                                                      [&](std::size_t i) { collect(i); }));
}

}  // namespace trellis::pbf_detail
