#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/job/job.hpp"

namespace trellis::cli {

void add_run(CLI::App& app) {
  struct Opts {
    std::string job, out;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("run", "Run a job file: lattice -> plan -> G-code, report and PNGs");
  cmd->footer("Job files are TOML; see examples/*.toml and docs/jobs.md.");
  cmd->add_option("job", o->job, "job TOML")->required();
  cmd->add_option("-o,--output-dir", o->out, "output folder (overrides [job] output_dir)");
  cmd->callback([o] {
    Job job = load_job(o->job);
    if (!o->out.empty()) job.output_dir = o->out;
    Diagnostics diag;
    Progress progress;
    progress.report = progress_line;
    const JobOutputs out = run_job(job, diag, progress);
    print_warnings(diag);
    const auto& t = out.result.total;
    std::cout << job.name << ": " << out.result.toolpath.layers.size() << " layer(s), " << t.paths
              << " paths (lower bound " << t.lower_bound_paths << "), score " << num(t.score, 4)
              << ", LTS " << num(t.lts, 1) << "%, OE " << num(t.oe, 2) << "%, "
              << num(t.total_length, 1) << " mm of struts\n";
    std::cout << "  lattice:  " << out.lattice << "\n  toolpath: " << out.toolpath
              << "\n  report:   " << out.report << "\n";
    if (!out.gcode.empty())
      std::cout << "  gcode:    " << out.gcode << " (" << out.gcode_stats.bytes << " bytes, ~"
                << num(out.gcode_stats.print_time_s / 60, 1) << " min)\n";
    if (!out.pngs.empty())
      std::cout << "  previews: " << out.pngs.size() << " PNG(s), e.g. " << out.pngs.front()
                << "\n";
  });
}

}  // namespace trellis::cli
