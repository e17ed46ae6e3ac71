// `check`: a print replayed against its design's nozzle model (job/print_check.hpp), its report
// and its picture with the collisions ringed.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

#include "routes.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/print_check.hpp"
#include "trellis/job/reports.hpp"

namespace trellis::routes {

namespace {

std::string check_summary(const CollisionCheck& c) {
  std::string out = fmt::format(
      "check: {} paths, {} segments, {}/{} struts printed once, {} missing, {} repeated, {} off "
      "the design, {} steep struts top-down, {} collisions\n",
      c.paths, c.segments, c.printed_once, c.struts, c.missing.size(), c.repeated.size(),
      c.off_design_segments, c.top_down.size(), c.collisions);
  for (std::size_t i = 0; i < std::min<std::size_t>(c.hits.size(), 10); ++i) {
    const auto& h = c.hits[i];
    out += fmt::format(
        "  collision: path {} segment {} (strut {}) hits strut {} at ({:.3f}, {:.3f}, {:.3f}), tip "
        "at ({:.3f}, {:.3f}, {:.3f})\n",
        h.path, h.segment, h.strut, h.hit_strut, h.point.x, h.point.y, h.point.z, h.tip.x, h.tip.y,
        h.tip.z);
  }
  return out;
}

}  // namespace

JobResult reader_check(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  PrintCheck run(job.settings, !job.machine.empty(), c.read.snap, context.budget);
  if (job.design_graph)
    run.set_design(*job.design_graph, diag);
  else
    run.read_design(job.design, diag);
  const bool commanded = c.read.gcode.commanded_mixtures;
  Toolpath tp;  // held whole for the preview only: the check streams a G-code
  CollisionCheck check;
  if (job.print) {
    check = run.check(*job.print);
  } else if (job.preview.empty()) {
    check = run.check_file(job.prints().at(0), diag, commanded);
  } else {
    tp = run.read(job.prints().at(0), diag, commanded);
    check = run.check(tp);
  }
  JobResult r;
  r.report_json = collision_check_json(check, run.options());
  if (!job.preview.empty()) {
    create_output_directories(job.preview);
    View3dOptions v;
    for (const auto& h : check.hits) v.marks.push_back(h.point);
    v.title = std::to_string(check.collisions) + " collisions";
    r.files.push_back((std::filesystem::path(job.preview) / "3d.png").string());
    render_3d_png(job.print ? *job.print : tp, r.files.back(), v);
  }
  r.summary = check_summary(check);
  r.exit_code = check.ok() ? 0 : 1;
  return r;
}

}  // namespace trellis::routes
