// Subcommands of the `trellis` CLI: each registers its options and a callback that does the work
// through the library. Errors are trellis::Error, turned into exit code 2 by main.
#pragma once
#include <CLI/CLI.hpp>
#include <map>

#include "trellis/core/budget.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/run_files.hpp"
#include "trellis/job/job.hpp"
#include "trellis/lattice/collision.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/toolpath.hpp"
#include "trellis/view/view.hpp"

namespace trellis::cli {

// lattice2d, lattice3d, plan, gcode, slice, pbf, nonplanar, surface: flags from the schema.
void add_routes(CLI::App& app, int argc, char** argv);
void add_run(CLI::App& app);
void add_rerun(CLI::App& app);
void add_merge(CLI::App& app);
void add_settings(CLI::App& app);
void add_walls(CLI::App& app);
// A reader command (check, analyze, compare, view, render; RouteSpec::reads): flags from the
// schema.
void add_reader(CLI::App& app, const std::string& name);

// Exit status of the run when no error was thrown (e.g. 1 when a check found problems).
void set_exit_code(int code);
int exit_code();

// Prints the warnings of a run on stderr.
void print_warnings(const Diagnostics& diag);
// An error as the command line prints it: where (as the library says it), then the message with
// the flags of the setting keys it names (with_flags, settings/settings.hpp), except for an error
// at a line of a file (job file, profile), which names keys as the file does.
std::string error_text(const Error& e);

// The words of the command line (main sets them before the commands are made): the flags made
// from the settings schema are added to a command only when its name is one of them, as only a
// command named can run or print its --help. Making them for every command was a fifth of the
// instructions of a small `trellis slice`.
void set_command_words(int argc, char** argv);

// Flags generated from the settings schema for the given sections (`--name VALUE`; booleans
// `--name` / `--no-name`); `apply` sets what was given, each naming its flag as its origin.
struct SettingFlags {
  std::map<std::string, std::string> values;
  std::map<std::string, int> bools;
  std::vector<std::pair<std::string, CLI::Option*>> options;
  // `reader`: only the settings that reader route uses (Setting::when's `route=` terms). Nothing
  // is added to a command not named on the command line (set_command_words).
  void add(CLI::App* cmd, const std::vector<std::string>& sections, const std::string& reader = "");
  void apply(Settings& settings) const;
};

// Checks a number option while parsing: finite and within lo..hi (above lo when `above_lo`), so
// that `inf`, `nan` and 1e308 are refused (exit 2) as CLI::PositiveNumber lets them through.
CLI::Validator number_value(double lo, double hi, bool above_lo = false);
// Checks a path option while parsing: an empty path (`-o ''`) is refused (exit 2).
const CLI::Validator& path_value();
// --follow-symlinks for the commands outside the routes (a route's comes from
// run.follow_symlinks): outputs that are symbolic links are written through, not refused
// (core/run_files.hpp).
void add_follow_symlinks(CLI::App* cmd, bool& follow);

// --max-time, --max-memory and --force for the commands outside the routes (a route's come from
// run.max_time, run.max_memory and run.force): the budget their estimates are checked against.
struct BudgetFlags {
  double max_time = Budget{}.seconds, max_memory_mb = 0;
  bool force = false;
  Budget budget() const;
};
void add_budget_flags(CLI::App* cmd, BudgetFlags& flags);

// Settings of a command: the machine profile (if any), then --set assignments.
Settings command_settings(const std::string& machine, const std::vector<std::string>& sets);
// The command line's settings over `st`: its flags, --progress / --no-progress (`progress` 1 / 0;
// -1 not given) as run.progress, then --set assignments, each naming where it came from.
void apply_command_line(Settings& st, const SettingFlags& flags, int progress,
                        const std::vector<std::string>& sets);
// Prints a route's warnings, summary and written files; sets the exit code.
void print_result(const JobResult& result, const Diagnostics& diag);

// The candidate nearest to `word` by edit distance, or "" when none is close.
std::string nearest(const std::string& word, const std::vector<std::string>& candidates);

// Fixed-point text of v for messages.
std::string num(double v, int decimals);

}  // namespace trellis::cli
