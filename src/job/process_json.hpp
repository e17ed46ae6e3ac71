// The report's "process" object (docs/process-fields.md): what the process pass wrote per
// parameter against the field, and the G-code's command counts when `gcode` is given. One
// construction for the slice report and each part of a plate report.
#pragma once
#include <nlohmann/json.hpp>

#include "trellis/slice/fgm_process.hpp"

namespace trellis {

struct GcodeStats;
nlohmann::ordered_json process_json(const ProcessStats& stats, const ProcessOptions& options,
                                    const GcodeStats* gcode = nullptr);

}  // namespace trellis
