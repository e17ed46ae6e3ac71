// `trellis run JOB.toml`, `trellis rerun OUTPUT` and `trellis settings`.
#include <filesystem>
#include <iostream>
#include <tuple>

#include "commands.hpp"
#include "progress_display.hpp"
#include "trellis/core/error.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/plate.hpp"

namespace trellis::cli {

void add_run(CLI::App& app) {
  struct Opts {
    std::string job, out, shard;
    std::vector<std::string> sets;
    bool follow = false;
    int progress = -1;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "run", "Run a job file (any route): design, plan, write, report, previews");
  cmd->footer(
      "A job file is TOML: [job] route = \"plan\" | \"lattice2d\" | \"lattice3d\" | \"gcode\" | "
      "\"slice\" |\n"
      "\"pbf\" | \"nonplanar\" | \"surface\", input, machine, output_dir, outputs; then any "
      "settings\n"
      "as [section] tables. Paths are relative to the job file. See docs/jobs.md and examples/.\n"
      "A reader (route = \"check\" | \"analyze\" | \"compare\" | \"view\" | \"render\") takes "
      "inputs = [files]\n"
      "and design = \"file\", and prints and writes what its command does.\n"
      "Precedence: defaults < the job's machine profile < the job's settings < --set.");
  cmd->add_option("job", o->job, "job TOML")->required()->check(path_value());
  cmd->add_option("-o,--output-dir", o->out, "output folder (replaces [job] output_dir)")
      ->check(path_value());
  add_follow_symlinks(cmd, o->follow);
  add_progress_flag(cmd, o->progress);
  cmd->add_option("--set", o->sets,
                  "override a setting of the job: section.key=value (repeatable)");
  cmd->add_option("--shard", o->shard,
                  "K/N: compute shard K of N (layer ranges balanced by work; pbf, slice (planar "
                  "and graded) and its plates, nonplanar, plan with euler or gippo) "
                  "and write OUTPUT.shard-K-of-N + its .json manifest for `trellis merge`");
  cmd->callback([o] {
    Job job = load_job(o->job, o->out, o->sets);
    if (o->follow) job.settings.set("run.follow_symlinks", true, {"--follow-symlinks"});
    if (o->progress >= 0)
      job.settings.set("run.progress", o->progress == 1,
                       {o->progress ? "--progress" : "--no-progress"});
    const bool reader = route_spec(job.route).reads;
    if (!o->shard.empty()) {
      std::tie(job.shard, job.shards) = parse_shard(o->shard);
      // The plan route says itself what of it shards (planner, plan.order, plan.layer_start).
      require_shards(route_spec(job.route), {"", 0, "--shard"});
    }
    job.keep_toolpath = false;  // only the files are used here
    Diagnostics diag;
    ProgressDisplay display(progress_mode(job.settings), "trellis run " + job.name);
    const JobResult r = run_job(job, display.context(diag));
    display.finish();
    print_warnings(diag);
    if (reader) {  // what its command shows, and its exit status
      std::cout << r.summary;
      if (r.exit_code) set_exit_code(r.exit_code);
      return;
    }
    std::cout << job.name << " (" << job.route << "): " << r.summary << "\n";
    for (const auto& f : r.files) {
      // Paths under the working folder are shown relative to it.
      const auto rel = std::filesystem::path(f).lexically_relative(std::filesystem::current_path());
      std::cout << "  " << (rel.empty() || *rel.begin() == ".." ? f : rel.string()) << "\n";
    }
    if (r.exit_code) set_exit_code(r.exit_code);
  });
}

void add_merge(CLI::App& app) {
  struct Opts {
    std::vector<std::string> manifests;
    std::string out;
    bool follow = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "merge", "Join the shards of `trellis run --shard K/N` into the single-process output");
  cmd->footer(
      "Give every shard's manifest (OUTPUT.shard-K-of-N.json). The merged file is byte for byte\n"
      "the file `trellis run` writes without --shard. Shards of different jobs, a shard missing\n"
      "or given twice: exit 2, nothing written.\nExample (each shard may run on another machine):\n"
      "  trellis run examples/jobs/gyroid_plate_pbf.toml -o out/plate --shard 1/2\n"
      "  trellis run examples/jobs/gyroid_plate_pbf.toml -o out/plate --shard 2/2\n"
      "  trellis merge out/plate/gyroid_plate.cli.shard-*-of-2.json -o out/plate/gyroid_plate.cli");
  cmd->add_option("manifests", o->manifests, "the shards' manifests")
      ->required()
      ->check(path_value());
  cmd->add_option("-o,--output", o->out, "the merged output")->required()->check(path_value());
  add_follow_symlinks(cmd, o->follow);
  cmd->callback([o] {
    Diagnostics diag;
    print_result(merge_shards(o->manifests, o->out, diag, o->follow), diag);
  });
}

void add_rerun(CLI::App& app) {
  struct Opts {
    std::string input, out;
    bool follow = false;
    int progress = -1;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "rerun", "Regenerate an output from the job recorded in its header (byte for byte)");
  cmd->footer(
      "Every G-code, .nc, .cli and toolpath JSON that Trellis writes carries the job that made "
      "it,\n"
      "and so do the reports of check, analyze and compare and the page of view (not PNGs):\n"
      "the route, its inputs and every setting in force. rerun reads that job and writes the\n"
      "same kind of output again (to -o, default: over the file itself).\nExample:\n"
      "  trellis rerun part.gcode -o part_again.gcode && cmp part.gcode part_again.gcode");
  cmd->add_option("output", o->input, "a file written by Trellis")->required()->check(path_value());
  cmd->add_option("-o,--output", o->out, "where to write (default: the file itself)")
      ->check(path_value());
  add_follow_symlinks(cmd, o->follow);
  add_progress_flag(cmd, o->progress);
  cmd->callback([o] {
    Job job = rerun_job(o->input, o->out);
    if (o->follow) job.settings.set("run.follow_symlinks", true, {"--follow-symlinks"});
    job.keep_toolpath = false;
    Diagnostics diag;
    ProgressDisplay display(progress_mode(o->progress), "trellis rerun");
    JobResult r = run_job(job, display.context(diag));
    display.finish();
    print_result(r, diag);
  });
}

void add_settings(CLI::App& app) {
  struct Opts {
    std::vector<std::string> what;
    bool markdown = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("settings", "List every setting (unit, default, range, flag, doc)");
  cmd->footer("Give sections (e.g. extrusion slice) or routes (e.g. pbf) to list only those.");
  cmd->add_option("what", o->what, "sections or routes");
  cmd->add_flag("--markdown", o->markdown, "write docs/settings.md's text");
  cmd->callback([o] {
    if (o->markdown) {
      std::cout << settings_markdown();
      return;
    }
    std::vector<std::string> sections;
    for (const auto& w : o->what) {
      if (std::find(route_names().begin(), route_names().end(), w) != route_names().end()) {
        const auto s = route_sections(w);
        sections.insert(sections.end(), s.begin(), s.end());
        continue;
      }
      bool known = false;
      for (const auto& [sec, _] : setting_sections()) known |= sec == w;
      if (!known) {
        std::string all;
        for (const auto& [sec, _] : setting_sections()) all += " " + sec;
        throw SettingError("unknown section or route '" + w + "' (sections:" + all + ")");
      }
      sections.push_back(w);
    }
    std::cout << settings_reference(sections);
  });
}

}  // namespace trellis::cli
