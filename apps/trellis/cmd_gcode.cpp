#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

void add_gcode(CLI::App& app) {
  struct Opts {
    std::string input, machine, output;
    std::vector<std::string> sets;
    bool help_settings = false;
    bool center = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "gcode", "Write G-code (or pneumatic / embedded .nc) from a toolpath and a machine profile");
  cmd->footer(
      "Profiles are TOML files (see profiles/); every setting is listed by --help-settings.\n"
      "Settings merge: defaults < profile < --set.");
  cmd->add_option("toolpath", o->input, "toolpath JSON");
  cmd->add_option("--machine", o->machine, "machine profile (TOML)");
  cmd->add_option("-o,--output", o->output, "G-code file to write");
  cmd->add_flag("--center", o->center, "print at the bed centre (same as --set placement.center=true)");
  cmd->add_option("--set", o->sets, "override a setting: section.key=value (repeatable)");
  cmd->add_flag("--help-settings", o->help_settings, "list every machine setting and exit");
  cmd->callback([o] {
    if (o->help_settings) {
      std::cout << settings_help();
      return;
    }
    if (o->input.empty() || o->machine.empty() || o->output.empty())
      throw SettingError("gcode needs TOOLPATH, --machine PROFILE and -o OUT (see --help)");
    MachineProfile profile = load_profile(o->machine);
    if (o->center) profile.center = true;
    for (const auto& s : o->sets) apply_override(profile, s);
    const Toolpath tp = read_toolpath(o->input);
    const GcodeStats s = write_gcode_file(o->output, tp, profile);
    std::cout << profile.flavor << ": " << s.paths << " paths, " << num(s.print_length, 1)
              << " mm printed, " << s.travel_moves << " travel moves (" << num(s.travel_length, 1)
              << " mm), " << s.retractions << " retractions, "
              << (s.tool_changes ? std::to_string(s.tool_changes) + " tool changes, " : "")
              << num(s.filament, 2)
              << " mm filament, ~" << num(s.print_time_s / 60, 1) << " min, " << s.bytes
              << " bytes -> " << o->output << "\n";
  });
}

}  // namespace trellis::cli
