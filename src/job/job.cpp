#include "trellis/job/job.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "routes.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/bgcode.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/toolpath_3mf.hpp"

namespace trellis {

namespace fs = std::filesystem;

namespace {

std::string resolve(const std::string& base, const std::string& p) {
  if (p.empty() || fs::path(p).is_absolute()) return p;
  return (fs::path(base) / p).lexically_normal().string();
}

std::string relative_to(const std::string& p, const std::string& base) {
  if (p.empty()) return p;
  const fs::path a = fs::absolute(p).lexically_normal();
  const fs::path b = fs::absolute(base.empty() ? "." : base).lexically_normal();
  const fs::path r = a.lexically_relative(b);
  return r.empty() ? a.string() : r.generic_string();
}

// Path settings of a job are relative to its file: make them relative to the process.
void resolve_path_settings(Settings& st, const std::string& base) {
  std::vector<std::pair<std::string, Settings::Entry>> fix;
  for (const auto& [key, e] : st.entries()) {
    const Setting* s = find_setting(key);
    if (s && s->unit == "path" && !std::get<std::string>(e.value).empty()) fix.emplace_back(key, e);
  }
  for (auto& [key, e] : fix) st.set(key, resolve(base, std::get<std::string>(e.value)), e.origin);
}

// An output named in a job file: a relative path inside the output folder.
void check_output_name(const std::string& v, const Where& where) {
  const fs::path p(v);
  if (v.empty()) throw SettingError("an output name inside the output folder, not empty", where);
  if (p.is_absolute() || p.has_root_name() || p.has_root_directory())
    throw SettingError("'" + v +
                           "' is an absolute path: outputs are named inside the output "
                           "folder (set output_dir or `trellis run -o DIR` to choose the folder)",
                       where);
  for (const auto& part : p)
    if (part == "..")
      throw SettingError("'" + v +
                             "' leaves the output folder ('..'): outputs are named inside "
                             "it (set output_dir or `trellis run -o DIR` to choose the folder)",
                         where);
  if (std::any_of(v.begin(), v.end(),
                  [](char ch) { return static_cast<unsigned char>(ch) < 0x20; }))
    throw SettingError("control characters in an output name", where);
}

// `path` (lexically inside `dir`) must stay inside it once symbolic links are followed.
void check_inside(const std::string& path, const std::string& dir, const std::string& origin) {
  std::error_code ec;
  const fs::path d = fs::weakly_canonical(fs::absolute(dir), ec);
  const fs::path p = fs::weakly_canonical(fs::absolute(path), ec);
  const fs::path rel = p.lexically_relative(d);
  const bool inside = !ec && !rel.empty() && *rel.begin() != ".." && rel.is_relative();
  if (!inside)
    throw SettingError("output '" + path + "' leads outside the output folder '" + dir +
                           "' (through a symbolic link?): outputs stay inside it",
                       {origin, 0, "job.output_dir"});
}

std::string quoted(const std::string& s) {
  std::ostringstream os;
  os << toml::value<std::string>(s);
  return os.str();
}

// [[part]] tables: a build plate (job/plate.hpp). Each part's own [part.SECTION] tables are kept
// as TOML and checked now against the job's settings.
std::vector<PlatePart> parse_plate_parts(const toml::table& root, const std::string& origin,
                                         const std::string& base, const Job& job,
                                         const std::vector<std::string>& sections) {
  std::vector<PlatePart> parts;
  const toml::node* node = root.get("part");
  if (!node) return parts;
  const toml::array* arr = node->as_array();
  if (!arr || !arr->is_array_of_tables())
    throw SettingError("parts of a plate are [[part]] tables",
                       {origin, static_cast<long>(node->source().begin.line), "part"});
  if (!route_spec(job.route).plates)
    throw SettingError("build plates ([[part]]) are for the pbf and slice routes, not " + job.route,
                       {origin, static_cast<long>(node->source().begin.line), "part"});
  std::set<std::string> labels;
  for (const auto& el : *arr) {
    const toml::table& t = *el.as_table();
    PlatePart p;
    p.line = static_cast<long>(t.source().begin.line);
    p.label = "part" + std::to_string(parts.size() + 1);
    for (const auto& [k, n] : t) {
      const std::string key(k.str());
      const Where where{origin, static_cast<long>(n.source().begin.line), "part." + key};
      if (const toml::table* sub = n.as_table()) {
        if (std::find(sections.begin(), sections.end(), key) == sections.end())
          throw SettingError("the " + job.route + " route does not read [" + key + "]", where);
        // One machine, one plate, one run: a part's own [part.machine] was silently ignored.
        if (key == "machine" || key == "plate" || key == "run")
          throw SettingError("[" + key + "] is the whole plate's: set it in the job's own [" + key +
                                 "] table, not in a part",
                             where);
        std::ostringstream os;
        os << *sub;
        p.settings_toml += "[" + key + "]\n" + os.str() + "\n";
      } else if (key == "label" || key == "input") {
        if (!n.is_string()) throw SettingError("expected a string", where);
        const std::string v = *n.value<std::string>();
        if (key == "label") {
          if (v.empty() || std::any_of(v.begin(), v.end(), [](char ch) {
                return static_cast<unsigned char>(ch) < 0x20 || ch == ',' || ch == '/';
              }))
            throw SettingError("a label without commas, slashes or control characters", where);
          p.label = v;
        } else {
          p.input = resolve(base, v);
        }
      } else if (key == "x" || key == "y" || key == "rotation") {
        if (!n.is_number())
          throw SettingError("expected a number (mm, or degrees for rotation)", where);
        const double v = *n.value<double>();
        if (!std::isfinite(v)) throw SettingError("expected a finite number", where);
        (key == "x" ? p.x : key == "y" ? p.y : p.rotation) = v;
      } else {
        throw SettingError(
            "unknown key of a part (expected label, input, x, y, rotation or "
            "[part.SECTION] settings)",
            where);
      }
    }
    if (!labels.insert(p.label).second)
      throw SettingError("two parts are labelled '" + p.label + "'",
                         {origin, p.line, "part.label"});
    // The part's settings over the job's: checked now, so errors name the job file.
    Settings st = job.settings;
    if (!p.settings_toml.empty()) st.load_toml(p.settings_toml, origin + " part '" + p.label + "'");
    parts.push_back(std::move(p));
  }
  if (parts.empty()) throw SettingError("a plate needs at least one [[part]]", {origin, 0, "part"});
  return parts;
}

// --set "key=value" entries over a job's settings; `check(key, where)` refuses those its route
// does not read.
template <class Check>
void apply_sets(Job& job, const std::vector<std::string>& sets, Check check) {
  for (const auto& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos)
      throw SettingError("expected section.key=value, got '" + s + "'", {"", 0, "--set"});
    const std::string key = s.substr(0, eq);
    job.settings.set_text(key, s.substr(eq + 1), {"--set"});
    check(key, Where{"", 0, "--set " + key});
  }
}

// The output folder of a job read from a file, and its explicit outputs resolved in it.
fs::path output_folder(const Job& job, const std::string& base, const std::string& output_dir,
                       std::vector<std::pair<std::string*, Where>>& outputs) {
  const fs::path dir = resolve(base, output_dir.empty() ? "out/" + job.name : output_dir);
  for (auto& [out, where] : outputs) *out = (dir / *out).lexically_normal().string();
  return dir;
}

// A job file whose route is a reader (RouteSpec::reads): its settings are the file's and --set
// (the machine profile is loaded below them when it runs, as the command does), each checked
// against the reader; its outputs are those it writes, by default in the output folder.
// `outputs` point into `job`.
void read_reader_job(Job& job, const toml::table& root, const std::string& text,
                     const std::string& origin, const std::string& base, bool embedded,
                     const std::string& output_dir,
                     std::vector<std::pair<std::string*, Where>>& outputs,
                     const std::vector<std::string>& sets) {
  const RouteSpec& spec = route_spec(job.route);
  if (const toml::node* part = root.get("part"))
    throw SettingError("build plates ([[part]]) are for the pbf and slice routes, not " + job.route,
                       {origin, static_cast<long>(part->source().begin.line), "part"});
  for (auto& [out, where] : outputs) {
    const std::string field = where.element.substr(4);
    if ((field == "output" && !spec.output_role) || (field == "report" && !spec.report) ||
        (field == "preview" && !spec.preview) || field == "toolpath" || field == "gcode" ||
        field == "lattice")
      throw SettingError("the " + job.route + " reader writes no " + field, where);
  }
  if (job.input.empty() && job.inputs.empty())
    throw SettingError("the " + job.route + " reader needs its files: inputs = [\"...\"]",
                       {origin, 0, "job.inputs"});
  if (!job.design.empty() && !spec.design_role)
    throw SettingError("the " + job.route + " reader reads no design", {origin, 0, "job.design"});
  job.settings.load_toml(text, origin, {"job"});
  job.origin = origin;
  for (const auto& [key, e] : job.settings.entries())
    check_reader_setting(spec, key, {origin, e.origin.line, key});
  resolve_path_settings(job.settings, base);
  apply_sets(job, sets, [&](const std::string& key, const Where& where) {
    check_reader_setting(spec, key, where);
  });
  if (!embedded) {
    const fs::path dir = output_folder(job, base, output_dir, outputs);
    if (job.output.empty() && spec.output_role)
      job.output = (dir / (job.name + spec.output_suffix)).string();
    if (job.report.empty() && spec.report)
      job.report = (dir / (job.name + ".report.json")).string();
    for (const std::string* out : {&job.output, &job.report, &job.preview})
      if (!out->empty()) check_inside(*out, dir.string(), origin);
  }
}

}  // namespace

Job job_from_toml(const std::string& text, const std::string& origin, const std::string& base,
                  bool embedded, const std::string& output_dir_override,
                  const std::vector<std::string>& sets) {
  toml::table root;
  try {
    root = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    throw SettingError(std::string(e.description()),
                       {origin, static_cast<long>(e.source().begin.line)});
  }
  const toml::table* jt = root["job"].as_table();
  if (!jt) throw SettingError("a job needs a [job] table with route = \"...\"", {origin, 1, "job"});
  Job job;
  job.embedded = embedded;
  job.name = fs::path(origin).stem().string();
  std::string output_dir;
  // Explicit outputs are names inside the output folder; resolved once the folder is known.
  std::vector<std::pair<std::string*, Where>> outputs;
  static const std::set<std::string> keys = {
      "route",  "name",   "input",    "inputs", "design",  "machine", "command",
      "output", "report", "toolpath", "gcode",  "lattice", "preview", "output_dir"};
  std::vector<Where> reader_keys;  // inputs, design: checked once the route is known
  for (const auto& [k, n] : *jt) {
    const std::string key(k.str());
    const Where where{origin, static_cast<long>(n.source().begin.line), "job." + key};
    if (!keys.count(key))
      throw SettingError(
          "unknown key (expected route, name, input, inputs, design, machine, output_dir, output, "
          "report, toolpath, gcode, lattice, preview, command)",
          where);
    if (key == "inputs") {
      const toml::array* a = n.as_array();
      if (!a || a->empty()) throw SettingError("a list of files, e.g. [\"a.gcode\"]", where);
      for (const auto& item : *a) {
        if (!item.is_string() || item.value<std::string>()->empty())
          throw SettingError("a list of files (non-empty strings)", where);
        job.inputs.push_back(resolve(base, *item.value<std::string>()));
      }
      reader_keys.push_back(where);
      continue;
    }
    if (!n.is_string()) throw SettingError("expected a string", where);
    const std::string v = *n.value<std::string>();
    // An empty path is not "none" (input = "" made the plan route generate a lattice instead):
    // leave the key out for none.
    if (v.empty() && key != "command")
      throw SettingError("an empty string: leave the key out for none", where);
    if (key == "route")
      job.route = v;
    else if (key == "name")
      job.name = v;
    else if (key == "input")
      job.input = resolve(base, v);
    else if (key == "machine")
      job.machine = resolve(base, v);
    else if (key == "design") {
      job.design = resolve(base, v);
      reader_keys.push_back(where);
    } else if (key == "command")
      job.command = v;
    else if (key == "output_dir")
      output_dir = v;
    else {
      std::string* out = key == "output"     ? &job.output
                         : key == "report"   ? &job.report
                         : key == "toolpath" ? &job.toolpath
                         : key == "gcode"    ? &job.gcode
                         : key == "lattice"  ? &job.lattice
                                             : &job.preview;
      if (!embedded) check_output_name(v, where);
      *out = embedded ? resolve(base, v) : v;
      outputs.emplace_back(out, where);
    }
  }
  if (!output_dir_override.empty()) output_dir = fs::absolute(output_dir_override).string();
  if (job.route.empty()) throw SettingError("missing route = \"...\"", {origin, 0, "job.route"});
  if (job.name.empty() || job.name.find_first_of("/\\") != std::string::npos || job.name == "." ||
      job.name == ".." || std::any_of(job.name.begin(), job.name.end(), [](char ch) {
        return static_cast<unsigned char>(ch) < 0x20;
      }))
    throw SettingError("a name without path separators, e.g. \"part\"", {origin, 0, "job.name"});
  if (route_spec(job.route, {origin, 0, "job.route"}).reads) {
    read_reader_job(job, root, text, origin, base, embedded, output_dir, outputs, sets);
    return job;
  }
  if (!reader_keys.empty()) {
    std::string readers;
    for (const RouteSpec& r : route_specs())
      if (r.reads) readers += (readers.empty() ? "" : ", ") + r.name;
    throw SettingError("inputs and design are the readers' (" + readers + "), not the " +
                           job.route + " route's: it reads one input",
                       reader_keys.front());
  }
  const auto sections = route_sections(job.route);
  // The machine profile first, then the job's own settings over it.
  if (!job.machine.empty() && !embedded) job.settings.load_toml_file(job.machine);
  job.settings.load_toml(text, origin, {"job", "part"});
  job.origin = origin;
  job.parts = parse_plate_parts(root, origin, base, job, sections);
  for (const auto& [key, e] : job.settings.entries()) {
    const std::string sec = key.substr(0, key.find('.'));
    if (e.origin.source == origin &&
        std::find(sections.begin(), sections.end(), sec) == sections.end())
      throw SettingError("the " + job.route + " route does not read [" + sec + "]",
                         {origin, e.origin.line, key});
  }
  resolve_path_settings(job.settings, base);
  apply_sets(job, sets, [&](const std::string& key, const Where& where) {
    if (std::find(sections.begin(), sections.end(), key.substr(0, key.find('.'))) == sections.end())
      throw SettingError(
          "the " + job.route + " route does not read [" + key.substr(0, key.find('.')) + "]",
          where);
  });
  if (!embedded) {
    // Default outputs under output_dir, named after the job.
    const fs::path dir = output_folder(job, base, output_dir, outputs);
    auto def = [&](std::string& out, const std::string& suffix) {
      if (out.empty()) out = (dir / (job.name + suffix)).string();
    };
    const Config c = job.settings.config();
    const std::string gext = !c.machine.file_extension.empty() ? c.machine.file_extension
                             : c.machine.binary_gcode          ? ".bgcode"
                             : c.machine.marlin_family()       ? ".gcode"
                                                               : ".nc";
    const RouteSpec& spec = route_spec(job.route);
    if (spec.gcode_beside_toolpath) {
      def(job.toolpath, ".toolpath.json");
      if (job.input.empty()) def(job.lattice, ".lattice.json");
      if (!job.machine.empty() && c.output.gcode) def(job.*spec.main_output, gext);
    } else {
      def(job.*spec.main_output, spec.output_suffix.empty() ? gext : spec.output_suffix);
    }
    if (spec.report) def(job.report, ".report.json");
    if (c.output.png && spec.preview) def(job.preview, "_preview");
    // Nothing may land outside the output folder, through a symbolic link either.
    for (const std::string* out :
         {&job.output, &job.report, &job.toolpath, &job.gcode, &job.lattice, &job.preview})
      if (!out->empty()) check_inside(*out, dir.string(), origin);
  }
  return job;
}

Job load_job(const std::string& path, const std::string& output_dir,
             const std::vector<std::string>& sets) {
  const std::string base = fs::path(path).parent_path().string();
  Job job =
      job_from_toml(read_file(path), path, base.empty() ? "." : base, false, output_dir, sets);
  if (job.command.empty()) job.command = "trellis run " + fs::path(path).filename().string();
  return job;
}

std::string job_toml(const Job& job, const std::string& base) {
  // The name only names default outputs; an embedded job's outputs are given, so it is left out
  // (the same plan written as a.json or b.json is the same file).
  const RouteSpec& spec = route_spec(job.route);
  std::string out = "[job]\nroute = " + quoted(job.route) + "\n";
  // A reader's prints are all `inputs` (input = "a" and inputs = ["a"] are one job).
  if (!job.input.empty() && !spec.reads)
    out += "input = " + quoted(relative_to(job.input, base)) + "\n";
  if (const auto prints = spec.reads ? job.prints() : job.inputs; !prints.empty()) {
    out += "inputs = [";
    for (std::size_t i = 0; i < prints.size(); ++i)
      out += (i ? ", " : "") + quoted(relative_to(prints[i], base));
    out += "]\n";
  }
  if (!job.design.empty()) out += "design = " + quoted(relative_to(job.design, base)) + "\n";
  if (!job.machine.empty()) out += "machine = " + quoted(relative_to(job.machine, base)) + "\n";
  // Path settings relative to `base` too.
  Settings st = job.settings;
  for (const auto& [key, e] : job.settings.entries()) {
    const Setting* s = find_setting(key);
    if (s && s->unit == "path" && !std::get<std::string>(e.value).empty())
      st.set(key, relative_to(std::get<std::string>(e.value), base), e.origin);
  }
  // Every setting that shapes the output; run.threads does not (outputs are the same for any
  // thread count), so it is left out and outputs made with 1 or 8 threads embed the same job.
  std::vector<std::string> sections = spec.sections;
  sections.erase(std::remove(sections.begin(), sections.end(), "run"), sections.end());
  if (!spec.reads) {
    out += settings_toml(st, sections);
  } else {
    // A reader's: the settings it reads (others of its sections it would refuse) and, with a
    // machine profile or any of its settings given, those of its profile sections as the profile
    // and the settings given left them.
    const auto& profile = spec.profile_sections;
    bool machine = !job.machine.empty();
    for (const auto& [key, e] : job.settings.entries())
      machine |=
          std::find(profile.begin(), profile.end(), key.substr(0, key.find('.'))) != profile.end();
    if (machine) sections.insert(sections.end(), profile.begin(), profile.end());
    out += settings_toml(st, sections, [&](const Setting& s) {
      return std::find(profile.begin(), profile.end(), s.section()) != profile.end() ||
             route_reads(spec, s);
    });
  }
  for (const PlatePart& p : job.parts) {
    std::ostringstream os;
    os << "\n[[part]]\nlabel = " << quoted(p.label) << "\n";
    if (!p.input.empty()) os << "input = " << quoted(relative_to(p.input, base)) << "\n";
    os << "x = " << toml::value<double>(p.x) << "\ny = " << toml::value<double>(p.y)
       << "\nrotation = " << toml::value<double>(p.rotation) << "\n";
    std::istringstream in(p.settings_toml);
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) os << (line[0] == '[' ? "[part." + line.substr(1) : line) << "\n";
    out += os.str();
  }
  return out;
}

Job rerun_job(const std::string& path, const std::string& target) {
  Job job = job_from_output(path);
  const std::string to = target.empty() ? path : target;
  job.output = job.report = job.toolpath = job.gcode = job.lattice = job.preview = "";
  // A JSON output is the main output of a route that makes a lattice or of a reader (its
  // report), else a toolpath.
  const RouteSpec& spec = route_spec(job.route);
  if (fs::path(path).extension() == ".json" && !spec.output_suffix.ends_with(".json") &&
      !spec.reads)
    job.toolpath = to;
  else
    job.*spec.main_output = to;
  return job;
}

Job job_from_output(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  std::string job;
  if (ext == ".3mf" && toolpath_3mf_kind(path) != Toolpath3mfKind::None) {
    // A 3MF toolpath carries the job in its toolpath metadata (machine/toolpath_3mf.hpp).
    job = read_toolpath_3mf_file(path).job;
  } else if (ext == ".3mf" || ext == ".stl") {
    throw ParseError("a " + ext.substr(1) +
                         " file carries no Trellis job (meshes and beam lattices have no header): "
                         "run the job again, or rerun its JSON or G-code output",
                     {path});
  }
  if (ext == ".png")
    throw ParseError(
        "a PNG carries no Trellis job (render's pictures and the previews have no header): run "
        "the render again (its command, or its job file with `trellis run`), or rerun the report, "
        "page, G-code or toolpath that came with it",
        {path});
  if (ext == ".html" || ext == ".htm") {
    // The viewer page (`trellis view`): the job in its script element (routes::with_page_job).
    const std::string page = read_file(path);
    const std::size_t at = page.rfind(routes::kPageJobOpen);
    const std::size_t from = at == std::string::npos ? at : at + std::strlen(routes::kPageJobOpen);
    const std::size_t end = from == std::string::npos ? from : page.find("</script>", from);
    if (end == std::string::npos)
      throw ParseError(
          "no Trellis job in this page (it was not written by `trellis view`, or by "
          "one before the page carried its job)",
          {path});
    try {
      job = nlohmann::json::parse(page.substr(from, end - from)).get<std::string>();
    } catch (const nlohmann::json::exception&) {
      throw ParseError("the page's job is not a JSON string", {path});
    }
  }
  // A text G-code's job is in its header: the rest of a large file is not read.
  const bool gcode = ext == ".gcode" || ext == ".nc" || ext == ".g" || ext == ".gco";
  std::string text = !job.empty() ? std::string() : gcode ? read_gcode_header(path) : std::string();
  if (job.empty() && text.empty()) text = read_file(path);
  if (is_bgcode(text)) text = bgcode_to_text(text, path);
  // Header comment lines: "; job: …" (G-code), "//job: …//" (CLI).
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    const std::string_view line(text.data() + pos, end - pos);
    if (line.rfind("; job: ", 0) == 0 || line == "; job:")
      job += std::string(line.substr(std::min<std::size_t>(7, line.size()))) + "\n";
    else if (line.rfind("//job: ", 0) == 0 && line.size() >= 9 &&
             line.substr(line.size() - 2) == "//")
      job += std::string(line.substr(7, line.size() - 9)) + "\n";
    else if (!job.empty() && !text.empty() && text[0] != '{')
      break;  // the block ended
    pos = end + 1;
  }
  if (job.empty() && !text.empty() && (text[0] == '{' || text[0] == '[')) {
    // JSON (toolpath, report): the "job" field; compare's report (an array of analyses): its
    // first analysis's (each carries it: routes::with_report_job).
    try {
      const auto j = nlohmann::json::parse(text);
      const auto* holder = j.is_array() && !j.empty() ? &j.front() : &j;
      if (holder->is_object() && holder->contains("job") && (*holder)["job"].is_string())
        job = (*holder)["job"].get<std::string>();
    } catch (const nlohmann::json::exception&) {
      throw ParseError("not valid JSON", {path});
    }
  }
  if (job.empty())
    throw ParseError("no Trellis job in this file (it was not written by Trellis 0.2 or later)",
                     {path});
  const std::string base = fs::path(path).parent_path().string();
  return job_from_toml(job, path + " (job header)", base.empty() ? "." : base, true);
}

}  // namespace trellis
