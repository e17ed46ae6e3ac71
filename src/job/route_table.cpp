// The route table: each route once, as data (job/job.hpp RouteSpec), the readers (check, analyze,
// compare, view, render) among them. The CLI's commands, `trellis run`, the job loader, Python,
// sharding and merging all read it; adding a route is adding a row here and its functions in
// routes_*.cpp or reader_*.cpp (docs/architecture.md).
#include <algorithm>
#include <set>

#include "routes.hpp"
#include "trellis/core/error.hpp"
#include "trellis/job/job.hpp"

namespace trellis {

namespace {

std::vector<std::string> with_machine(std::initializer_list<const char*> own) {
  std::vector<std::string> s = machine_sections();
  s.insert(s.end(), own.begin(), own.end());
  return s;
}

void merge_plan(Job& job, const Config& c, Toolpath& tp, const ShardLayers&, JobResult& out,
                Diagnostics& diag) {
  job.gcode = job.output;  // a plan's shards are named after its G-code
  routes::merge_plan_main(job, c, tp, out, diag);
}

void merge_slice(Job& job, const Config& c, Toolpath& tp, const ShardLayers& shards, JobResult& out,
                 Diagnostics& diag) {
  if (!shards.graded.empty())
    routes::write_graded_merge(job, c, tp, shards.graded, shards.outline_z, shards.total_layers,
                               out, diag);
  else
    routes::write_slice_main(job, c, tp, out, diag);
}

void merge_pbf(Job& job, const Config& c, Toolpath& tp, const ShardLayers&, JobResult& out,
               Diagnostics&) {
  routes::write_pbf_main(job, c, tp, out);
}

void merge_nonplanar(Job& job, const Config& c, Toolpath& tp, const ShardLayers&, JobResult& out,
                     Diagnostics& diag) {
  routes::write_nonplanar_main(job, c, tp, out, diag);
}

// The test surfaces are meshes; the angle test is a toolpath (JSON) or a print (G-code, 3MF).
std::vector<std::string> surface_formats(const Config& c) {
  if (c.surface.kind == SurfaceKind::AngleTest) return {".json", "gcode", ".3mf"};
  return {".stl", ".obj", ".3mf"};
}

}  // namespace

const std::vector<std::string>& machine_sections() {
  static const std::vector<std::string> s = {"machine",     "placement",  "extrusion", "speed",
                                             "temperature", "retraction", "flow",      "pneumatic",
                                             "embedded",    "gradient",   "purge",     "gcode"};
  return s;
}

const std::vector<RouteSpec>& route_specs() {
  // The plan route shards with euler and gippo writing G-code; it says so itself (planner,
  // plan.order, plan.layer_start) when a shard is asked of it.
  static const std::vector<RouteSpec> table = {
      {.name = "lattice2d",
       .sections = {"lattice2d", "output", "run"},
       .run = &routes::lattice2d,
       .output_suffix = ".lattice.json",
       .report = false,
       .formats = {".json"}},
      {.name = "lattice3d",
       .sections = {"lattice3d", "output", "run"},
       .run = &routes::lattice3d,
       .output_suffix = ".lattice.json",
       .report = false,
       .formats = {".json", ".3mf"}},
      {.name = "plan",
       .input = "lattice",
       .sections = with_machine({"lattice2d", "lattice3d", "lattice", "layers", "onto", "plan",
                                 "gippo", "aero", "nozzle", "output", "run"}),
       .choice = "plan.planner",
       .shards = true,
       .run = &routes::plan,
       .merge = &merge_plan,
       .main_output = &Job::gcode,
       .gcode = RouteSpec::Gcode::when_written,
       .gcode_beside_toolpath = true,
       .formats = {"gcode", ".3mf"},
       .design = &routes::plan_design},
      {.name = "gcode",
       .input = "toolpath",
       .sections = with_machine({"run"}),
       .run = &routes::gcode,
       .gcode = RouteSpec::Gcode::always,
       .report = false,
       .preview = false,
       .formats = {"gcode", ".3mf"}},
      {.name = "slice",
       .input = "design",
       .sections = with_machine({"slice", "fgm", "process", "plate", "output", "run"}),
       .shards = true,
       .plates = true,
       .streams = true,
       .run = &routes::slice,
       .merge = &merge_slice,
       .gcode = RouteSpec::Gcode::always,
       .formats = {"gcode", ".3mf"},
       .design = &routes::slice_design},
      {.name = "pbf",
       .input = "design",
       .sections = {"machine", "laser", "lasers", "scan", "timing", "pbf", "plate", "output",
                    "run"},
       .shards = true,
       .plates = true,
       .streams = true,
       .run = &routes::pbf,
       .merge = &merge_pbf,
       .output_suffix = ".cli",
       .formats = {".cli", ".3mf"},
       .design = &routes::pbf_design},
      {.name = "nonplanar",
       .input = "surface",
       .sections = with_machine({"nonplanar", "surface", "output", "run"}),
       .shards = true,
       .run = &routes::nonplanar,
       .merge = &merge_nonplanar,
       .gcode = RouteSpec::Gcode::when_written,
       .bath_example = "profiles/fresh_nonplanar_2syringe.toml",
       .formats = {"gcode", ".3mf"},
       .design = &routes::nonplanar_design},
      // The angle test can be written as G-code: the machine sections.
      {.name = "surface",
       .sections = with_machine({"surface", "output", "run"}),
       .choice = "surface.kind",
       .run = &routes::surface,
       .gcode = RouteSpec::Gcode::when_named_gcode,
       .output_suffix = ".stl",
       .report = false,
       .formats_of = &surface_formats},
      // The readers. Their profile sections: G-code is read with the profile's valve commands,
      // tool offsets and node overlap (check, view), the valves alone (render); a laser profile
      // times a build file (analyze). Their reports (check, analyze, compare: NAME.report.json)
      // and view's page embed the job.
      {.name = "check",
       .sections = {"check", "read", "nozzle", "lattice", "run"},
       .run = &routes::reader_check,
       .main_output = &Job::report,
       .reads = true,
       .profile_sections = machine_sections(),
       .print_role = "the print",
       .design_role = "the lattice"},
      {.name = "analyze",
       .sections = {"analyze", "read", "run"},
       .run = &routes::reader_analyze,
       .main_output = &Job::report,
       .reads = true,
       .profile_sections = {"laser", "lasers", "scan", "timing"},
       .print_role = "the G-code",
       .design_role = "the design"},
      {.name = "compare",
       .sections = {"analyze", "read", "run"},
       .run = &routes::reader_compare,
       .main_output = &Job::report,
       .reads = true,
       .print_role = "the G-code",
       .design_role = "the design"},
      {.name = "view",
       .sections = {"view", "check", "read", "nozzle", "lattice", "run"},
       .run = &routes::reader_view,
       .output_suffix = ".html",
       .report = false,
       .preview = false,
       .formats = {".html", ".htm"},
       .reads = true,
       .profile_sections = machine_sections(),
       .print_role = "the file to show",
       .design_role = "the design (--design)",
       .output_role = "the HTML (-o)"},
      {.name = "render",
       .sections = {"render", "read", "run"},
       .run = &routes::reader_render,
       .output_suffix = ".png",
       .report = false,
       .preview = false,
       .formats = {".png"},
       .reads = true,
       .profile_sections = machine_sections(),
       .print_role = "the toolpath",
       .output_role = "the PNG (-o)",
       .output_per_layer = true},
  };
  return table;
}

const std::vector<std::string>& route_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const RouteSpec& r : route_specs()) n.push_back(r.name);
    return n;
  }();
  return names;
}

const RouteSpec& route_spec(const std::string& name, const Where& where) {
  for (const RouteSpec& r : route_specs())
    if (r.name == name) return r;
  std::string all;
  for (const auto& r : route_names()) all += (all.empty() ? "" : ", ") + r;
  throw SettingError("unknown route '" + name + "' (expected one of " + all + ")", where);
}

std::vector<std::string> route_sections(const std::string& route) {
  return route_spec(route).sections;
}

std::vector<std::pair<std::string, std::string>> route_keywords(const RouteSpec& route,
                                                                const std::string& choice) {
  Settings chosen;
  if (!route.choice.empty() && !choice.empty())
    chosen.set_text(route.choice, choice, {"keyword " + route.choice});
  const Settings* choices = chosen.has(route.choice) ? &chosen : nullptr;
  std::vector<std::pair<std::string, std::string>> out;
  std::set<std::string> taken;
  // The route's own section first: its flags win over another section's of the same name. A
  // keyword names one key whatever the choice (plan's seed is plan.seed, which euler does not
  // use, never lattice2d.seed): the choice only leaves keywords out.
  for (const bool own : {true, false})
    for (const Setting& s : all_settings()) {
      if (s.flag.empty() || s.key == route.choice || (s.section() == route.name) != own ||
          !route_reads(route, s))
        continue;
      std::string name = s.flag;
      std::replace(name.begin(), name.end(), '-', '_');
      if (taken.insert(name).second && (!choices || route_uses(s, route.name, choices)))
        out.emplace_back(name, s.key);
    }
  return out;
}

bool route_reads(const RouteSpec& route, const Setting& setting) {
  return std::find(route.sections.begin(), route.sections.end(), setting.section()) !=
             route.sections.end() &&
         route_uses(setting, route.name);
}

void require_shards(const RouteSpec& route, const Where& where) {
  if (route.shards) return;
  std::vector<std::string> names;
  for (const RouteSpec& r : route_specs())
    if (r.shards) names.push_back(r.name);
  std::string list;
  for (std::size_t i = 0; i < names.size(); ++i)
    list += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
  throw SettingError("the " + route.name + " route does not shard (" + list + " do)", where);
}

}  // namespace trellis
