// The reader routes' table (job/readers.hpp) and what every reader run does first: its files and
// the settings given to it checked.
#include "trellis/job/readers.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "routes.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/run_files.hpp"
#include "trellis/machine/toolpath_3mf.hpp"

namespace trellis {

namespace {

// A setting the caller gave (a flag, --set, a Python keyword), not one of the profile's.
bool given(const Settings::Entry& e) {
  return e.origin.source.rfind("--", 0) == 0 || e.origin.source.rfind("keyword", 0) == 0;
}

void check_given(const ReaderSpec& spec, const Settings& settings) {
  for (const auto& [key, e] : settings.entries())
    if (given(e))
      check_reader_setting(spec, key,
                           {"", 0, e.origin.source == "--set" ? "--set " + key : e.origin.source});
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

// The output and the report are named for what is written in them (RouteSpec::formats).
void check_names(const ReaderSpec& spec, const ReadJob& job, const Config& c) {
  const auto require = [&](const std::string& path, const std::vector<std::string>& formats,
                           const char* what, const char* flag) {
    if (path.empty() || formats.empty() || is_stream_output(path)) return;
    const std::string ext = lower_extension(path);
    std::string list;
    for (std::size_t i = 0; i < formats.size(); ++i) {
      if (ext == formats[i]) return;
      list += (i == 0 ? "" : i + 1 == formats.size() ? " or " : ", ") + formats[i];
    }
    throw SettingError("'" + path + "' is named " + (ext.empty() ? "without an extension" : ext) +
                           ", but `trellis " + spec.name + "` writes " + what + " as " + list +
                           ": name it so",
                       {"", 0, flag});
  };
  if (!(spec.output_per_layer && c.read.layer < 0))
    require(job.output, spec.output_formats, "its output", "--output");
  require(job.report, {".json"}, "the report (JSON)", "--report");
}

// The job's files, checked before anything is read (core/run_files.hpp).
void check_files(const ReaderSpec& spec, const ReadJob& job, const Config& c) {
  RunFiles files(c.follow_symlinks);
  for (const auto& f : job.prints) files.input(spec.print_role, f);
  if (spec.design_role) files.input(spec.design_role, job.design);
  files.input("the machine profile (--machine)", job.machine);
  if (spec.output_role && !(spec.output_per_layer && c.read.layer < 0))
    files.output(spec.output_role, job.output);
  files.output("the report (--report)", job.report);
  files.output_folder("the preview folder (--preview)", job.preview);
  files.check();
  check_names(spec, job, c);
}

}  // namespace

const std::vector<ReaderSpec>& reader_specs() {
  // The machine sections: G-code is read with the profile's valve commands, tool offsets and node
  // overlap (check, view), the valves alone (render); a laser profile times a build file
  // (analyze).
  const std::vector<std::string>& machine = machine_sections();
  static const std::vector<ReaderSpec> table = {
      {.name = "check",
       .sections = {"check", "read", "nozzle", "lattice", "run"},
       .profile_sections = machine,
       .run = &routes::reader_check,
       .print_role = "the print",
       .design_role = "the lattice",
       .report = true,
       .preview = true},
      {.name = "analyze",
       .sections = {"analyze", "read", "run"},
       .profile_sections = {"laser", "lasers", "scan", "timing"},
       .run = &routes::reader_analyze,
       .print_role = "the G-code",
       .design_role = "the design",
       .report = true,
       .preview = true},
      {.name = "compare",
       .sections = {"analyze", "read", "run"},
       .profile_sections = {},
       .run = &routes::reader_compare,
       .print_role = "the G-code",
       .design_role = "the design",
       .report = true,
       .preview = true},
      {.name = "view",
       .sections = {"view", "check", "read", "nozzle", "lattice", "run"},
       .profile_sections = machine,
       .run = &routes::reader_view,
       .print_role = "the file to show",
       .design_role = "the design (--design)",
       .output_role = "the HTML (-o)",
       .output_suffix = ".html",
       .output_formats = {".html", ".htm"}},
      {.name = "render",
       .sections = {"render", "read", "run"},
       .profile_sections = machine,
       .run = &routes::reader_render,
       .print_role = "the toolpath",
       .output_role = "the PNG (-o)",
       .output_per_layer = true,
       .output_suffix = ".png",
       .output_formats = {".png"}},
  };
  return table;
}

const ReaderSpec& reader_spec(const std::string& name) {
  std::string all;
  for (const ReaderSpec& r : reader_specs()) {
    if (r.name == name) return r;
    all += (all.empty() ? "" : ", ") + r.name;
  }
  throw SettingError("unknown reader '" + name + "' (expected one of " + all + ")",
                     {"", 0, "route"});
}

bool is_reader(const std::string& route) {
  const auto& table = reader_specs();
  return std::any_of(table.begin(), table.end(),
                     [&](const ReaderSpec& r) { return r.name == route; });
}

void check_reader_setting(const ReaderSpec& spec, const std::string& key, const Where& where) {
  const Setting* s = find_setting(key);
  const std::string sec = key.substr(0, key.find('.'));
  const auto& profile = spec.profile_sections;
  if (std::find(profile.begin(), profile.end(), sec) != profile.end()) return;
  if (std::find(spec.sections.begin(), spec.sections.end(), sec) == spec.sections.end())
    throw SettingError("`trellis " + spec.name + "` does not read [" + sec + "] settings", where);
  if (s && !reader_reads(spec, *s)) {
    UseContext use;
    use.route = spec.name;
    throw SettingError(
        "`trellis " + spec.name + "` does not use " + key + ": " + unused_reason(*s, use), where);
  }
}

ReadJob reader_job(const Job& job) {
  ReadJob r;
  r.route = job.route;
  r.prints = job.inputs;
  if (!job.input.empty()) r.prints.insert(r.prints.begin(), job.input);
  r.design = job.design;
  r.machine = job.machine;
  r.output = job.output;
  r.report = job.report;
  r.preview = job.preview;
  r.settings = job.settings;
  return r;
}

bool reader_reads(const ReaderSpec& reader, const Setting& setting) {
  return std::find(reader.sections.begin(), reader.sections.end(), setting.section()) !=
             reader.sections.end() &&
         route_uses(setting, reader.name);
}

JobResult run_reader(const ReadJob& job, const RunContext& given) {
  const ReaderSpec& spec = reader_spec(job.route);
  check_given(spec, job.settings);
  check_files(spec, job, job.settings.config());
  ReadJob full = job;
  if (!job.machine.empty()) {
    full.settings = Settings();
    full.settings.load_toml_file(job.machine);
    for (const auto& [key, e] : job.settings.entries()) full.settings.set(key, e.value, e.origin);
  }
  const Config c = full.settings.config();
  Diagnostics dropped;  // a context without diagnostics drops the warnings
  RunContext context = routes::run_context(full.settings, c, given);
  if (!context.diagnostics) context.diagnostics = &dropped;
  return spec.run(full, c, context);
}

JobResult run_reader(const ReadJob& job, Diagnostics& diag, const Progress& progress) {
  RunContext context;
  context.progress = progress;
  context.diagnostics = &diag;
  return run_reader(job, context);
}

bool is_laser_build_file(const std::string& path) {
  if (path.size() > 4 && (path.ends_with(".3mf") || path.ends_with(".3MF")))
    return toolpath_3mf_kind(path) == Toolpath3mfKind::Laser;
  return path.size() > 4 && (path.ends_with(".cli") || path.ends_with(".CLI"));
}

}  // namespace trellis
