// Subcommands of the `trellis` CLI: each registers its options and a callback that does the work
// through the library. Errors are trellis::Error, turned into exit code 2 by main.
#pragma once
#include <CLI/CLI.hpp>

#include "trellis/core/diagnostics.hpp"
#include "trellis/lattice/collision.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis::cli {

void add_lattice2d(CLI::App& app);
void add_plan(CLI::App& app);
void add_gcode(CLI::App& app);
void add_render(CLI::App& app);
void add_run(CLI::App& app);
void add_analyze(CLI::App& app);
void add_compare(CLI::App& app);
void add_walls(CLI::App& app);
void add_slice(CLI::App& app);
void add_pbf(CLI::App& app);
void add_lattice3d(CLI::App& app);
void add_check(CLI::App& app);
void add_nonplanar(CLI::App& app);
void add_surface(CLI::App& app);

// Laser build files (.cli) for `analyze`: measured against a .vcad design (cmd_analyze_laser.cpp).
bool is_laser_build_file(const std::string& path);
void analyze_laser_file(const std::string& path, const std::string& design,
                        const std::string& machine, const std::string& report);

// Exit status of the run when no error was thrown (e.g. 1 when a check found problems).
void set_exit_code(int code);
int exit_code();

// Progress on stderr when it is a terminal (carriage-return updates), silent otherwise.
void progress_line(const std::string& stage, double fraction);
// Prints the warnings of a run on stderr.
void print_warnings(const Diagnostics& diag);
// PNGs of `count` layers spread over the toolpath, named DIR/layer_N.png; returns the paths.
std::vector<std::string> render_previews(const Toolpath& toolpath, const std::string& dir,
                                         std::size_t count, const RenderOptions& options = {});
// The nozzle-collision model's options (--nozzle-radius, --tip-clearance, --node-clearance,
// --cone), shared by `plan aero` and `check`, in an option group.
void add_nozzle_options(CLI::App* cmd, NozzleModel& nozzle, const std::string& group);

// Fixed-point text of v for messages.
std::string num(double v, int decimals);

}  // namespace trellis::cli
