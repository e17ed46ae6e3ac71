// What every reader run (RouteSpec::reads: check, analyze, compare, view, render) does around its
// function: the settings given to it and its files checked, its machine profile loaded below the
// settings, and its report or page written with the job embedded (rerun).
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <nlohmann/json.hpp>

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

void check_given(const RouteSpec& spec, const Settings& settings) {
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
void check_names(const RouteSpec& spec, const Job& job, const Config& c) {
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
    require(job.output, spec.formats, "its output", "--output");
  require(job.report, {".json"}, "the report (JSON)", "--report");
}

// The job's files, checked before anything is read (core/run_files.hpp).
void check_files(const RouteSpec& spec, const Job& job, const Config& c) {
  RunFiles files(c.follow_symlinks);
  for (const auto& f : job.prints()) files.input(spec.print_role, f);
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

void check_reader_setting(const RouteSpec& spec, const std::string& key, const Where& where) {
  const Setting* s = find_setting(key);
  const std::string sec = key.substr(0, key.find('.'));
  const auto& profile = spec.profile_sections;
  if (std::find(profile.begin(), profile.end(), sec) != profile.end()) return;
  if (std::find(spec.sections.begin(), spec.sections.end(), sec) == spec.sections.end())
    throw SettingError("`trellis " + spec.name + "` does not read [" + sec + "] settings", where);
  if (s && !route_reads(spec, *s)) {
    UseContext use;
    use.route = spec.name;
    throw SettingError(
        "`trellis " + spec.name + "` does not use " + key + ": " + unused_reason(*s, use), where);
  }
}

std::vector<std::string> Job::prints() const {
  std::vector<std::string> all;
  if (!input.empty()) all.push_back(input);
  all.insert(all.end(), inputs.begin(), inputs.end());
  return all;
}

namespace routes {

std::string with_page_job(const std::string& html, const Job& job, const std::string& path) {
  const std::string text = nlohmann::json(embedded_job(job, path)).dump();
  std::string escaped;
  escaped.reserve(text.size() + 16);
  for (char ch : text) escaped += ch == '<' ? std::string("\\u003c") : std::string(1, ch);
  const std::string block = std::string(kPageJobOpen) + escaped + "</script>\n";
  const std::size_t end = html.rfind("</body>");
  if (end == std::string::npos) return html + block;
  return html.substr(0, end) + block + html.substr(end);
}

std::string with_report_job(const std::string& report, const std::string& job) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(report);
  if (j.is_array()) {
    // compare: one analysis per print, each carrying the job as a lone report does (so a reader
    // of the array sees only analyses: `ours, theirs = json.load(f)`).
    for (auto& a : j) a["job"] = job;
  } else {
    j["job"] = job;
  }
  // The reports are nlohmann's dump(2) (compare's: its analyses' one below the other): dumped
  // again, they keep their bytes but for the job.
  if (!j.is_array()) return j.dump(2) + "\n";
  std::string out = "[\n";
  for (std::size_t i = 0; i < j.size(); ++i) out += (i ? ",\n" : "") + j[i].dump(2) + "\n";
  return out + "]\n";
}

JobResult run_reader(const RouteSpec& spec, const Job& job, const RunContext& given) {
  if (job.shards > 0) require_shards(spec, {"", 0, "shard"});
  if (!job.embedded) check_given(spec, job.settings);
  check_files(spec, job, job.settings.config());
  Job full = job;
  // The profile below the settings given; an embedded job carries the profile's settings.
  if (!job.machine.empty() && !job.embedded) {
    full.settings = Settings();
    full.settings.load_toml_file(job.machine);
    for (const auto& [key, e] : job.settings.entries()) full.settings.set(key, e.value, e.origin);
  }
  const Config c = full.settings.config();
  Diagnostics dropped;  // a context without diagnostics drops the warnings
  RunContext context = run_context(full.settings, c, given);
  if (!context.diagnostics) context.diagnostics = &dropped;
  JobResult r = spec.run(full, c, context);
  // The report, or the page, with the job that made it: `trellis rerun` of it writes it again.
  // A job with a design or print in memory (Python) has no file to name: not embedded.
  const bool in_memory = job.design_graph || job.print;
  if (!job.report.empty()) {
    write_file_atomic(
        job.report,
        in_memory ? r.report_json : with_report_job(r.report_json, embedded_job(full, job.report)));
    r.files.push_back(job.report);
  }
  return r;
}

}  // namespace routes

bool is_laser_build_file(const std::string& path) {
  if (path.size() > 4 && (path.ends_with(".3mf") || path.ends_with(".3MF")))
    return toolpath_3mf_kind(path) == Toolpath3mfKind::Laser;
  return path.size() > 4 && (path.ends_with(".cli") || path.ends_with(".CLI"));
}

}  // namespace trellis
