// The JSON report of a planning run: the numbers that matter for GIPPO and Euler planning
// (paper Eq. 1-3, the lower bound, travel) per layer and in total, plus warnings.
#pragma once
#include <string>

#include "trellis/core/diagnostics.hpp"
#include "trellis/plan/plan.hpp"

namespace trellis {

// Reports hold no timings, so the same inputs and seed give byte-identical reports.
struct ReportContext {
  std::string input;  // lattice file or generator
  std::size_t nodes = 0, edges = 0;
};

std::string plan_report_json(const PlanResult& result, const PlanParams& params,
                             const Diagnostics& diag, const ReportContext& context);

}  // namespace trellis
