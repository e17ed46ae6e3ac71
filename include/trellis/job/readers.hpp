// The reader routes: check, analyze, compare, view and render read prints (anyone's G-code, .nc,
// .cli, toolpath JSON, 3MF toolpaths) back, with their design, instead of making one. Each is a
// row of reader_specs(): its name, the settings sections it reads (their flags, `--set` and
// Python keywords come from the schema, filtered by each setting's `route=` condition) and the
// one function that runs it. The CLI's commands and Python's check/analyze build a ReadJob and
// call run_reader, so the glue (settings → nozzle → design → print → check) exists once. A job
// file may name a reader as its route (`trellis run`, run_job): reader_job makes its ReadJob.
//
// A sibling of the route table (job.hpp RouteSpec), not rows of it: a route makes a lattice or a
// toolpath from at most one input, embeds its Job in every output (rerun, merge) and may shard or
// take build plates; a reader takes a design and any number of prints made by anyone, writes a
// report, pictures or a page that embed no job, and never shards. docs/architecture.md.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "trellis/job/job.hpp"

namespace trellis {

// One run of a reader route, as a value.
struct ReadJob {
  std::string route;                // a reader_specs() name
  std::vector<std::string> prints;  // the files read (check, analyze, render: one)
  std::string design;               // lattice (or .vcad for a laser build file); may be empty
  std::string machine;              // machine or laser profile: loaded below `settings`
  std::string output;               // view: the HTML; render: the PNG (render.layer) or prefix
  std::string report;               // report JSON
  std::string preview;              // folder of PNGs
  Settings settings;                // given: flags, --set, keywords (run_reader adds the profile)
  // In memory instead of files (Python): the design and the one print.
  std::shared_ptr<const Graph> design_graph;
  std::shared_ptr<const Toolpath> print;
};

struct ReaderSpec {
  std::string name;  // the CLI command, ReadJob::route
  // Its own settings sections: their flags are its options and Python keywords (those whose
  // `route=` conditions allow it: reader_reads).
  std::vector<std::string> sections;
  // The profile's sections it reads too (from --machine, or --set): no flags of their own.
  std::vector<std::string> profile_sections;
  // Writes what the job asks for; JobResult::summary is what the terminal shows (each line
  // ending in a newline), report_json the report whether written or not.
  JobResult (*run)(const ReadJob&, const Config&, const RunContext&) = nullptr;
  // Its files as errors name them (core/run_files.hpp); null: it has none of that kind.
  const char* print_role = "the print";
  const char* design_role = nullptr;
  const char* output_role = nullptr;
  // Without render.layer the output is the prefix of one file per layer, not a file.
  bool output_per_layer = false;
  // Run from a job file (`trellis run`, route = NAME): it writes a report JSON (the job's
  // default report, NAME.report.json), its output's default name (the job's name + this; null:
  // it has no output), and whether it writes previews.
  bool report = false;
  const char* output_suffix = nullptr;
  bool preview = false;  // it writes a folder of PNGs when asked (--preview)
  // The extensions its output (-o) may have (case-insensitive), each the format it is written in;
  // an output named otherwise, or a report not named .json, is refused before anything is read.
  std::vector<std::string> output_formats;
};

const std::vector<ReaderSpec>& reader_specs();
// Whether `route` names a reader (a job file's route may: `trellis run` runs it as its command).
bool is_reader(const std::string& route);
// The reader called `name`; SettingError naming those there are otherwise.
const ReaderSpec& reader_spec(const std::string& name);
// The settings a reader takes: those of its sections its `route=` conditions allow (flags,
// `--set`, Python keywords).
bool reader_reads(const ReaderSpec& reader, const Setting& setting);

// SettingError at `where` unless the reader takes `key`: a setting of its own sections that its
// `route=` conditions allow, or of the profile sections it reads.
void check_reader_setting(const ReaderSpec& reader, const std::string& key, const Where& where);

// A job file's reader run (route = a reader's name) as a ReadJob: its inputs are the prints (or
// its one input), its design, machine, output, report and preview as they are, its settings
// those of the file and --set (checked when the job was read).
ReadJob reader_job(const Job& job);

// Checks the settings given to the job (one the reader does not read is refused, naming it) and
// its files (core/run_files.hpp), loads its profile below them, then runs the reader.
// With `context` as run_job (job.hpp).
JobResult run_reader(const ReadJob& job, const RunContext& context);
JobResult run_reader(const ReadJob& job, Diagnostics& diag, const Progress& progress = {});

// A laser build file (.cli, or a 3MF toolpath of a laser build): `analyze` measures it against a
// .vcad design (analyze_build_file).
bool is_laser_build_file(const std::string& path);

}  // namespace trellis
