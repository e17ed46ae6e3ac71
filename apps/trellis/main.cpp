// trellis: a thin command line over libtrellis.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/version.hpp"

namespace trellis::cli {

void print_warnings(const Diagnostics& diag) {
  for (const auto& [kind, n] : diag.counts()) {
    std::cerr << "warning: " << kind << " (" << n << ")\n";
    for (const auto& m : diag.messages())
      if (m.kind == kind) std::cerr << "  " << with_flags(m.text) << "\n";
  }
}

std::string error_text(const Error& e) {
  // Where it happened as the library says it (a file, a line, the key); the message with the
  // flags of the keys it names, unless it is about a line of a file (a job file, a profile: the
  // user wrote keys there, and a key is what to write).
  const std::string at = format_where(e.where());
  const std::string message = e.where().line > 0 ? e.message() : with_flags(e.message());
  return at.empty() ? message : at + ": " + message;
}

namespace {
int g_exit_code = 0;
}
void set_exit_code(int code) {
  g_exit_code = code;
}
int exit_code() {
  return g_exit_code;
}

std::string nearest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const auto& c : candidates) {
    std::vector<std::size_t> row(c.size() + 1);
    for (std::size_t j = 0; j <= c.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= word.size(); ++i) {
      std::size_t diag = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= c.size(); ++j) {
        const std::size_t up = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (word[i - 1] == c[j - 1] ? 0 : 1)});
        diag = up;
      }
    }
    if (row[c.size()] < best_d) best_d = row[c.size()], best = c;
  }
  return best;
}

CLI::Validator number_value(double lo, double hi, bool above_lo) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0;
        const char* begin = text.c_str();
        char* end = nullptr;
        v = std::strtod(begin, &end);
        const bool in = std::isfinite(v) && (above_lo ? v > lo : v >= lo) && v <= hi;
        if (end == begin || *end != '\0' || !in)
          return "'" + text + "' is not a finite number " + (above_lo ? "above " : "from ") +
                 num(lo, 0) + (above_lo ? " up to " : " to ") + num(hi, 0);
        return std::string();
      },
      "");
}

const CLI::Validator& path_value() {
  static const CLI::Validator v(
      [](std::string& path) { return path.empty() ? std::string("an empty path") : std::string(); },
      "");
  return v;
}

void add_follow_symlinks(CLI::App* cmd, bool& follow) {
  cmd->add_flag("--follow-symlinks", follow,
                "write an output whose path is a symbolic link to the file it points to (the "
                "link kept); without it such an output is refused");
}

Budget BudgetFlags::budget() const {
  Budget b;
  b.seconds = max_time;
  b.memory = max_memory_mb * 1e6;
  b.force = force;
  return b;
}

void add_budget_flags(CLI::App* cmd, BudgetFlags& flags) {
  cmd->add_option("--max-time", flags.max_time,
                  "refuse when the estimated time is longer than this (s; run.max_time)")
      ->check(number_value(0, 1e9, true))
      ->capture_default_str();
  cmd->add_option("--max-memory", flags.max_memory_mb,
                  "refuse when the estimate needs more memory than this (MB; run.max_memory; "
                  "default: half the memory available)")
      ->check(number_value(0, 1e9, true));
  cmd->add_flag("--force", flags.force, "run even when the estimate is beyond the budget");
}

std::string num(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace trellis::cli

int main(int argc, char** argv) {
  CLI::App app{
      "Trellis: toolpaths for architected materials.\n"
      "Design a lattice, plan continuous print paths (GIPPO, Euler, AERO for 3D lattices in a\n"
      "support bath), write G-code and check it for nozzle collisions; slice\n"
      "implicit designs (.vcad) and meshes; make laser powder-bed paths for TPMS lattices.\n"
      "Typical use:\n"
      "  trellis lattice2d --pattern honeycomb --cell 1 -o lattice.json\n"
      "  trellis plan gippo lattice.json -o toolpath.json --report report.json\n"
      "  trellis gcode toolpath.json --machine profiles/ender3_s1_pro_tpu.toml -o part.gcode\n"
      "  trellis run examples/honeycomb_tensile.toml\n"
      "  trellis slice examples/designs/csg_bracket.vcad --machine profiles/ender3_s1_pro_tpu.toml "
      "-o bracket.gcode\n"
      "  trellis pbf --cell-type gyroid --cell 2.5 --size 10,10,10 -o lattice.cli\n"
      "  trellis lattice3d --cell-type octet --cell 7 --count 3,3,3 -o octet.json\n"
      "  trellis plan aero octet.json -o octet_path.json --report octet_report.json\n"
      "  trellis gcode octet_path.json --machine profiles/embedded_aero_410um.toml -o octet.nc\n"
      "  trellis check octet.json octet.nc --machine profiles/embedded_aero_410um.toml"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("trellis ") + trellis::version());
  trellis::cli::set_command_words(argc, argv);
  trellis::cli::add_routes(app, argc, argv);
  trellis::cli::add_reader(app, "render");
  trellis::cli::add_run(app);
  trellis::cli::add_rerun(app);
  trellis::cli::add_merge(app);
  trellis::cli::add_settings(app);
  trellis::cli::add_reader(app, "analyze");
  trellis::cli::add_reader(app, "check");
  trellis::cli::add_reader(app, "compare");
  trellis::cli::add_walls(app);
  trellis::cli::add_reader(app, "view");
  // A misspelt command: name the nearest one instead of CLI11's "a subcommand is required".
  CLI::App* level = &app;
  for (int i = 1; i < argc && argv[i][0] != '-' && !level->get_subcommands({}).empty(); ++i) {
    std::vector<std::string> names;
    for (const auto* sub : level->get_subcommands({})) names.push_back(sub->get_name());
    if (std::find(names.begin(), names.end(), argv[i]) != names.end()) {
      level = level->get_subcommand(argv[i]);
      continue;
    }
    {
      std::cerr << "trellis: error: unknown command '" << argv[i] << "'";
      const std::string near = trellis::cli::nearest(argv[i], names);
      if (!near.empty()) std::cerr << " (did you mean '" << near << "'?)";
      std::cerr << "; `trellis " << (level == &app ? "" : level->get_name() + " ")
                << "--help` lists the commands\n";
      return 2;
    }
  }
  // Interrupted runs leave no temporaries (exit 130 / 143); the outputs of a command are
  // committed together when it succeeds and removed when it fails (core/file.hpp).
  trellis::install_signal_cleanup();
  if (argc > 1) trellis::set_interrupt_label(std::string("trellis ") + argv[1]);  // "trellis pbf"
  try {
    trellis::OutputBatch outputs;
    app.parse(argc, argv);
    outputs.commit();
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ExtrasError& e) {
    // A misspelt flag: suggest the nearest flag of the command.
    std::string msg = e.what();
    std::vector<const CLI::App*> chosen;
    for (const auto* sub : app.get_subcommands()) {
      chosen.push_back(sub);
      for (const auto* inner : sub->get_subcommands()) chosen.push_back(inner);
    }
    for (const auto* sub : chosen) {
      if (!sub->get_subcommands().empty()) continue;
      std::vector<std::string> flags;
      for (const auto* opt : sub->get_options())
        for (const auto& n : opt->get_lnames()) flags.push_back("--" + n);
      for (int i = 2; i < argc; ++i) {
        const std::string a = argv[i];
        if (a.rfind("--", 0) != 0) continue;
        const std::string name = a.substr(0, a.find('='));
        if (std::find(flags.begin(), flags.end(), name) != flags.end()) continue;
        const std::string near = trellis::cli::nearest(name, flags);
        msg = "unknown option " + name + (near.empty() ? "" : " (did you mean " + near + "?)") +
              "; `trellis " +
              (sub->get_parent() && sub->get_parent()->get_parent()
                   ? sub->get_parent()->get_name() + " "
                   : "") +
              sub->get_name() + " --help` lists them";
        break;
      }
    }
    std::cerr << "trellis: error: " << msg << "\n";
    return 2;
  } catch (const CLI::ParseError& e) {
    // A flag's value out of range or missing: one error line like every other.
    std::cerr << "trellis: error: " << e.what() << "; `trellis --help` lists the commands\n";
    return 2;
  } catch (const trellis::Error& e) {
    trellis::disarm_watchdog();  // the refusal is said whole
    std::cerr << "trellis: error: " << trellis::cli::error_text(e) << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    trellis::disarm_watchdog();
    // Beyond what the estimate before the run foresaw: the same refusal, nothing written.
    std::cerr << "trellis: error: run.max_memory: ran out of memory (the estimate before the "
                 "run was too low): lower the resolution or the size of the job, or free memory; "
                 "nothing was written\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "trellis: internal error: " << e.what() << "\n";
    return 3;
  }
  return trellis::cli::exit_code();
}
