// Progress of a run on stderr: on a terminal one line redrawn in place ("trellis pbf: layers
// 45%  ETA 12 s", at most ten redraws a second, shown once the run has lasted a second, cleared
// when the run ends); elsewhere nothing unless asked (run.progress, `--progress`), then one plain
// line per update for a log, at most one a second, plus each estimate made before the work.
#pragma once
#include <CLI/CLI.hpp>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>

#include "trellis/core/budget.hpp"
#include "trellis/core/run_context.hpp"
#include "trellis/settings/settings.hpp"

namespace trellis::cli {

enum class ProgressMode { Off, Terminal, Lines };

// Off when `asked` is false (--no-progress); Terminal when stderr is a terminal; Lines when it
// is not and `asked` is true; Off when not asked and not a terminal.
ProgressMode progress_mode(const Settings& settings);
ProgressMode progress_mode(int asked);  // -1 not given, 0 no, 1 yes

// --progress / --no-progress for the commands outside the routes (a route's comes from
// run.progress): `asked` becomes 1 or 0, and stays -1 when neither is given.
void add_progress_flag(CLI::App* cmd, int& asked);

class ProgressDisplay {
 public:
  ProgressDisplay(ProgressMode mode, std::string label);
  ~ProgressDisplay();  // clears the terminal line
  ProgressDisplay(const ProgressDisplay&) = delete;
  ProgressDisplay& operator=(const ProgressDisplay&) = delete;

  // A Progress (and the estimate hook) that report here; valid while this lives.
  Progress progress();
  // The command's one run context (core/run_context.hpp): this progress, warnings into `diag`;
  // run_job adds the threads and budget of the run settings.
  RunContext context(Diagnostics& diag);
  void report(const std::string& stage, double fraction);
  void estimate(const Estimate& e);
  void finish();  // clears the line (terminal); idempotent

 private:
  using Clock = std::chrono::steady_clock;
  void draw(double now_s, bool final);

  ProgressMode mode_;
  std::string label_;
  std::mutex mutex_;
  Clock::time_point start_ = Clock::now();
  std::string stage_;
  double stage_start_ = 0;           // seconds since start_
  double stage_start_fraction_ = 0;  // the stage's first reported fraction
  double fraction_ = -1;             // of the stage, as last reported (monotone within a stage)
  double drawn_at_ = -1e9;           // when the last line or redraw was made
  std::string shown_stage_;          // the stage of the last line drawn, and its fraction
  double shown_fraction_ = -1;
  bool line_open_ = false;  // a terminal line is on screen
};

}  // namespace trellis::cli
