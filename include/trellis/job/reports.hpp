// The JSON reports of the routes: what a planner or slicer did, in the numbers that matter for it
// (GIPPO and Euler: paper Eq. 1-3 and the lower bound per layer; AERO: groups, trails and
// collisions; the slicers: layers, lengths, travel, the graded and process passes; the readers
// analyze, compare and check: the print measured, the collision replay), plus warnings.
// Algorithms return results; these turn them into documents, so no planner, slicer or analysis
// writes JSON (docs/architecture.md).
#pragma once
#include <string>

#include "trellis/analysis/collisions.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/plan/aero.hpp"
#include "trellis/plan/gippo.hpp"
#include "trellis/plan/plan.hpp"
#include "trellis/slice/nonplanar.hpp"
#include "trellis/slice/pipeline.hpp"

namespace trellis {

struct GcodeStats;

// Reports hold no timings, so the same inputs and seed give byte-identical reports.
struct ReportContext {
  std::string input;  // lattice file or generator
  std::size_t nodes = 0, edges = 0;
};

std::string plan_report_json(const PlanResult& result, const PlanParams& params,
                             const Diagnostics& diag, const ReportContext& context);

// GIPPO's robustness run (gippo_robustness): the spread of the best score over the seeds.
std::string gippo_robustness_json(const GippoRobustness& r, const GippoParams& params);

struct AeroReportInput {
  std::string lattice;
  std::size_t nodes = 0, edges = 0;
  double seconds = 0;
  long long checked_collisions = -1;  // from the independent checker, -1 = not checked
  bool checked_once = false;          // the checker found every strut printed exactly once
};
std::string aero_report_json(const AeroResult& r, const AeroParams& p, const Diagnostics& diag,
                             const AeroReportInput& in);

// The slice route's report: layers, paths, lengths, travel, print time (from the writer's stats if
// given), the linking stage, the graded (FGM) and process passes.
std::string slice_report_json(const SliceJob& job, const SliceResult& result,
                              const GcodeStats* gcode);

// The non-planar route's report: layers, path length, travel moves per layer, tool changes,
// deviation from the surface; with the writer's stats if given (tool changes made, travel, print
// time).
std::string nonplanar_report_json(const NonplanarResult& result, const NonplanarParams& params,
                                  const HeightField& surface, const SurfaceDeviation& deviation,
                                  const GcodeStats* gcode = nullptr);

// `analyze`'s report of one print (`compare`'s: one per print, in a JSON array): its counts, per
// layer starts, retractions and travel, and with a design the comparison with it.
std::string analysis_json(const Analysis& a);

// `check`'s report: the nozzle it replayed, struts printed once, missing or repeated, and every
// collision.
std::string collision_check_json(const CollisionCheck& c, const CheckOptions& options);

}  // namespace trellis
