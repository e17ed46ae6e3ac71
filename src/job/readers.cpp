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
  for (const auto& [key, e] : settings.entries()) {
    if (!given(e)) continue;
    const Setting* s = find_setting(key);
    const std::string sec = key.substr(0, key.find('.'));
    const Where where{"", 0, e.origin.source == "--set" ? "--set " + key : e.origin.source};
    const auto& profile = spec.profile_sections;
    if (std::find(profile.begin(), profile.end(), sec) != profile.end()) continue;
    if (std::find(spec.sections.begin(), spec.sections.end(), sec) == spec.sections.end())
      throw SettingError("`trellis " + spec.name + "` does not read [" + sec + "] settings", where);
    if (s && !reader_reads(spec, *s)) {
      UseContext use;
      use.route = spec.name;
      throw SettingError(
          "`trellis " + spec.name + "` does not use " + key + ": " + unused_reason(*s, use), where);
    }
  }
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
      {"check",
       {"check", "read", "nozzle", "lattice", "run"},
       machine,
       &routes::reader_check,
       "the print",
       "the lattice"},
      {"analyze",
       {"analyze", "read", "run"},
       {"laser", "lasers", "scan", "timing"},
       &routes::reader_analyze,
       "the G-code",
       "the design"},
      {"compare",
       {"analyze", "read", "run"},
       {},
       &routes::reader_compare,
       "the G-code",
       "the design"},
      {"view",
       {"view", "check", "read", "nozzle", "lattice", "run"},
       machine,
       &routes::reader_view,
       "the file to show",
       "the design (--design)",
       "the HTML (-o)",
       false,
       {".html", ".htm"}},
      {"render",
       {"render", "read", "run"},
       machine,
       &routes::reader_render,
       "the toolpath",
       nullptr,
       "the PNG (-o)",
       true,
       {".png"}},
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

bool reader_reads(const ReaderSpec& reader, const Setting& setting) {
  return std::find(reader.sections.begin(), reader.sections.end(), setting.section()) !=
             reader.sections.end() &&
         route_uses(setting, reader.name);
}

JobResult run_reader(const ReadJob& job, Diagnostics& diag, const Progress& progress) {
  const ReaderSpec& spec = reader_spec(job.route);
  check_given(spec, job.settings);
  check_files(spec, job, job.settings.config());
  ReadJob full = job;
  if (!job.machine.empty()) {
    full.settings = Settings();
    full.settings.load_toml_file(job.machine);
    for (const auto& [key, e] : job.settings.entries()) full.settings.set(key, e.value, e.origin);
  }
  return spec.run(full, full.settings.config(), diag, progress);
}

bool is_laser_build_file(const std::string& path) {
  if (path.size() > 4 && (path.ends_with(".3mf") || path.ends_with(".3MF")))
    return toolpath_3mf_kind(path) == Toolpath3mfKind::Laser;
  return path.size() > 4 && (path.ends_with(".cli") || path.ends_with(".CLI"));
}

}  // namespace trellis
