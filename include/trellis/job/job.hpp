// A job: one run of one route — what to read, what to write, and every setting — as a value.
// The CLI builds one from its flags, `trellis run JOB.toml` reads one from a file, and every
// output carries the job that made it (header comments / a "job" field), so `trellis rerun
// OUTPUT` regenerates it byte for byte.
//
// Job file:
//   [job]   route = "plan" | "lattice2d" | "lattice3d" | "gcode" | "slice" | "pbf" |
//                   "nonplanar" | "surface", or a reader: "check" | "analyze" | "compare" |
//                   "view" | "render" (RouteSpec::reads; inputs = [prints], design = "file",
//                   output, report, preview; it runs as its command does)
//           name (default: the file's stem), output_dir (default "out/<name>"),
//           input = "file" (lattice, toolpath, design, surface; optional where the route
//           generates its input), machine = "profile.toml",
//           output / report / toolpath / gcode / lattice / preview: output paths; each has a
//           default under output_dir named after the job (see docs/jobs.md)
//   [section] any setting of the schema (settings.hpp; `trellis settings` lists them),
//           overriding the machine profile.
// Input paths and output_dir are relative to the job file's folder; explicit outputs are names
// inside the output folder (no "..", not absolute, no symbolic link leading out: SettingError).
#pragma once
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/run_context.hpp"
#include "trellis/core/run_files.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/settings/settings.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// A part of a build plate ([[part]] tables of a job): its own design, placement on the plate and
// settings over the job's (job/plate.hpp).
struct PlatePart {
  std::string label;    // names the part in outputs (CLI $$LABEL, G-code comments)
  std::string input;    // its design (.vcad / mesh; the PBF envelope); empty: from its settings
  double x = 0, y = 0;  // mm: where the centre of its footprint goes on the plate
  double rotation = 0;  // degrees about z, counter-clockwise
  std::string settings_toml;  // its own [part.SECTION] tables as TOML ("[pbf]\ncell = 2\n")
  long line = 0;              // where it is in the job file (errors)
};

struct Job {
  std::string route;
  std::string name = "job";
  std::string input;  // path; empty where the route generates its input
  // A reader route's (RouteSpec::reads: route = "analyze", ...): the prints it reads after
  // `input` (any number: `inputs = ["a.gcode", "b.gcode"]`) and the design they are read against.
  std::vector<std::string> inputs;
  std::string design;
  // A reader's design and print in memory instead of files (Python); not part of the embedded job.
  std::shared_ptr<const Graph> design_graph;
  std::shared_ptr<const Toolpath> print;
  std::string machine;  // profile the settings were read from (provenance)
  std::string command;  // the command line that made it (recorded in reports)
  // Outputs; empty = not written.
  std::string output;  // the route's main output
  std::string report, toolpath, gcode, lattice, preview;
  Settings settings;
  std::vector<PlatePart> parts;  // a build plate: empty for one part
  std::string origin;            // the job file (errors naming plate parts)
  // Sharding (job/plate.hpp): shard `shard` (1-based) of `shards`; 0 = the whole job. Not part
  // of the embedded job: every shard and the merged file record the same job.
  int shard = 0, shards = 0;
  // false: a route that can write its outputs layer by layer in bounded memory (pbf) does so and
  // leaves JobResult::toolpath empty (the command line; Python keeps the toolpath).
  bool keep_toolpath = true;
  // Read back from an output's header (rerun, merge): every setting is recorded there, given or
  // not, so "the user gave this setting" cannot be told from Settings::has.
  bool embedded = false;

  // A reader's prints: `input` (when given), then `inputs`.
  std::vector<std::string> prints() const;
};

// Routes and the settings sections each reads (for flags, headers and job checks): from the
// route table below.
const std::vector<std::string>& route_names();
std::vector<std::string> route_sections(const std::string& route);
const std::vector<std::string>& machine_sections();

// Reads a job file; relative paths are taken from the file's folder. The machine profile, if
// any, is loaded below the job's own settings.
// `output_dir` replaces the job's own [job] output_dir when not empty; `sets` ("key=value", from
// the command line) apply over the job's settings.
Job load_job(const std::string& path, const std::string& output_dir = "",
             const std::vector<std::string>& sets = {});
// A job from TOML text. `base` is the folder relative paths start from. Embedded jobs (from an
// output's header) carry every setting already, so their profile is not read again.
Job job_from_toml(const std::string& text, const std::string& origin, const std::string& base,
                  bool embedded, const std::string& output_dir = "",
                  const std::vector<std::string>& sets = {});

// The job as TOML, paths relative to `base` (the folder of the file it is written into).
// Outputs are left out: a job embedded in an output regenerates that output wherever asked.
std::string job_toml(const Job& job, const std::string& base);

// The job embedded in an output (G-code / .nc / .cli header comments, toolpath or report JSON).
// Throws ParseError naming the file when it has none.
Job job_from_output(const std::string& path);
// The job that regenerates `path` (an output of Trellis) as the same kind of file at `target`
// (default: over `path`); its other outputs are not written.
Job rerun_job(const std::string& path, const std::string& target = "");

// Reads a print back into design coordinates for checking against its lattice: a toolpath JSON
// as it is; G-code with the valve commands and tool offsets of `machine` — by default the
// machine settings of the job the file embeds — and the placement offset Trellis wrote into the
// header undone. `snap` gets the profile's node overlap + kNodeSnap when it is left at kNodeSnap.
// Mixtures as deposited, or as commanded when asked (GcodeReadOptions::commanded_mixtures).
Toolpath read_print(const std::string& path, const Settings* machine, double* snap,
                    Diagnostics& diag, bool commanded_mixtures = false);
// The same print layer by layer, never held whole: a text G-code whose mixtures need no
// look-ahead undone; empty when it must be read whole (read_print). Each visit reads the file
// again; only the first reports to `diag` (keep it alive).
LayerSource print_layers(const std::string& path, const Settings* machine, double* snap,
                         Diagnostics& diag, bool commanded_mixtures = false);

// The thumbnails the machine's gcode.thumbnails asks for, drawn from the toolpath (cairo module),
// for write_gcode.
std::vector<GcodeThumbnail> gcode_thumbnails(const Toolpath& toolpath,
                                             const MachineProfile& machine);
std::vector<GcodeThumbnail> gcode_thumbnails(const LayerSource& layers,
                                             const MachineProfile& machine);

// GIPPO parts on a solid: the height at which layer `layer` (of thickness h) is cropped to the
// solid's section — its middle, or just below the top for a partial top layer.
double solid_section_z(const BBox3& box, int layer, double h);

// The design as a 3MF output's build item carries it (machine/toolpath_3mf.hpp), where the route
// has it: set before the route writes.
struct JobGeometry {
  std::shared_ptr<const TriangleMesh> mesh;  // a solid's triangles, or the surface printed on
  bool surface = false;                      // `mesh` is the open surface printed on
  std::shared_ptr<const Graph> struts;  // the struts, where the toolpath prints them as they lie
  // Where the design lies in the toolpath's coordinates (a part dropped on the plate).
  Transform3mf transform = kIdentity3mf;
  // A plate's parts (Path::part k: parts[k - 1]), each its design at its place on the plate
  // (job/plate.hpp place_transform); parts of one design share its mesh (one object).
  struct Part {
    std::shared_ptr<const TriangleMesh> mesh;
    Transform3mf transform = kIdentity3mf;
    std::string name;  // the object's: the design's file name, else the part's label
  };
  std::vector<Part> parts;
};

struct JobResult {
  std::vector<std::string> files;  // written, in order
  // What the route made, in memory (for callers such as the Python package); may be null.
  std::shared_ptr<const Toolpath> toolpath;
  std::shared_ptr<const Graph> lattice;
  JobGeometry geometry;
  std::string summary;  // one or two lines for the terminal
  int exit_code = 0;    // 1 when a check found problems
  // The reader routes (RouteSpec::reads): the report, written or not, without the job its file
  // carries.
  std::string report_json;
};

// The layers of a sharded run as `trellis merge` hands them to the route's writer (job/plate.hpp).
struct ShardLayers {
  std::string graded;  // graded slicing: the manifests' "graded" object (JSON); else empty
  std::vector<double> outline_z;  // graded slicing with process fields: the outline planes
  std::size_t total_layers = 0;
};

// A route as data: everything the front ends (the CLI's commands and `run`, the job loader,
// Python, sharding and merging, docs) need to know of it is here, once (route_specs()).
// Two kinds of rows: the routes that make a lattice, a toolpath or a surface from at most one
// input, and the readers (`reads`: check, analyze, compare, view, render) that read prints made
// by anyone (job.input, job.inputs) against their design (job.design) and write a report, a page
// or pictures. Both run through run_job and embed their job in their main output (rerun).
struct RouteSpec {
  std::string name;                   // job.route, the CLI command (plan: with its planners)
  std::string input;                  // what its input is ("lattice", "toolpath", "design",
                                      // "surface"); empty when it generates its design
  std::vector<std::string> sections;  // the settings sections it reads
  // A choice setting that names what the route makes (plan: plan.planner), taken as the first
  // argument of its Python function (and its CLI command's positional): the keywords offered are
  // those the chosen value uses (route_keywords). Empty: none.
  std::string choice;
  bool shards = false;   // `trellis run --shard K/N`, Python run_shard
  bool plates = false;   // [[part]] build plates
  bool streams = false;  // writes its layers in bounded memory when its output is alone
  // With the context run_job builds (core/run_context.hpp; its diagnostics never null).
  JobResult (*run)(const Job&, const Config&, const RunContext&) = nullptr;
  // `trellis merge`: writes the main output (job.output; plan: job.gcode) from the shards' layers
  // with the single-process writer; null when the route does not shard.
  void (*merge)(Job&, const Config&, Toolpath&, const ShardLayers&, JobResult&,
                Diagnostics&) = nullptr;
  // The job field of its main output (a plan's: its G-code): shards are named after it, `rerun`
  // writes it.
  std::string Job::*main_output = &Job::output;
  // When that output is G-code, the `gcode` fact of Setting::when: always, when it is written,
  // or when it is written under a name other than .json or .stl.
  enum class Gcode { never, always, when_written, when_named_gcode };
  Gcode gcode = Gcode::never;
  // A job's default output names in its output folder (the job's name + a suffix): the main
  // output's ("" = the machine's G-code extension); whether a report and previews are written.
  std::string output_suffix;
  bool report = true;
  bool preview = true;
  // Its main output is G-code written beside its toolpath (plan): the toolpath is named
  // .toolpath.json, the G-code written with a machine and output.gcode, the lattice it makes
  // when it has no input .lattice.json; -o names the toolpath.
  bool gcode_beside_toolpath = false;
  // A bath profile to name when its G-code is asked of a machine that prints in air.
  std::string bath_example = "profiles/embedded_aero_410um.toml";
  // The extensions its main output may be named with (case-insensitive), each one the format it
  // is written in; "gcode" stands for G-code: text (.gcode, .g, .gco, .nc, the machine's
  // gcode.extension) or binary (.bgcode). An output named otherwise is refused before anything
  // is written (check_output_names). `formats_of`, when set, gives them for the run's settings.
  std::vector<std::string> formats;
  std::vector<std::string> (*formats_of)(const Config&) = nullptr;
  // A run's design as a 3MF's build items (JobResult::geometry), found again from its job alone:
  // what `trellis gcode` of a toolpath JSON that embeds the job writes. Null: the beads printed.
  void (*design)(const Job&, const Config&, JobResult&) = nullptr;

  // A reader (check, analyze, compare, view, render). Its settings are those of `sections` that
  // its `route=` conditions allow (route_reads: its flags, `--set`, Python keywords), and any of
  // `profile_sections`, read from its machine profile (or --set) with no flags of their own; one
  // it does not read is refused (check_reader_setting). It never shards nor takes plates. Its
  // report (main_output = &Job::report) or page (output) embeds the job; its pictures do not.
  bool reads = false;
  std::vector<std::string> profile_sections;
  // Its files as errors name them (core/run_files.hpp); null: it has none of that kind. Its
  // output's extensions are `formats` (as written: ".html"), its report's .json.
  const char* print_role = nullptr;
  const char* design_role = nullptr;
  const char* output_role = nullptr;
  // Without render.layer its output is the prefix of one file per layer, not a file.
  bool output_per_layer = false;
};

// What the job's outputs are written as, by their names: its main output one of its route's
// formats (RouteSpec::formats), the toolpath and the report JSON, the lattice JSON or a 3MF beam
// lattice. An output named for another format (a .obj holding STL bytes, a .json holding G-code)
// → SettingError naming the output and the extensions it may have; run_job checks it first.
void check_output_names(const Job& job, const Config& config);

const std::vector<RouteSpec>& route_specs();
// The route called `name`; SettingError naming the routes there are otherwise (`where` names the
// place that asked: the job file's route, a command).
const RouteSpec& route_spec(const std::string& name, const Where& where = {"", 0, "job.route"});
// The keyword arguments of the route's Python function, each with its setting key, in the
// schema's order: the flags (`-` as `_`) of the settings of its sections that the route uses —
// with `choice` (a value of its RouteSpec::choice setting; empty: any) those that value uses;
// the choice setting itself is the function's first argument, not a keyword.
// Where two sections share a flag (seed, density, cell), the route's own section wins.
std::vector<std::pair<std::string, std::string>> route_keywords(const RouteSpec& route,
                                                                const std::string& choice = "");
// SettingError (exit 2) unless the route shards, naming those that do (`where`: the flag).
void require_shards(const RouteSpec& route, const Where& where);
// Whether the route reads `setting`: one of its sections' that its `route=` conditions allow
// (a reader's flags, `--set` and Python keywords; route_keywords's filter).
bool route_reads(const RouteSpec& route, const Setting& setting);
// A reader (RouteSpec::reads): SettingError at `where` unless it takes `key`, a setting it reads
// (route_reads) or one of its profile sections'.
void check_reader_setting(const RouteSpec& reader, const std::string& key, const Where& where);
// A laser build file (.cli, or a 3MF toolpath of a laser build): `analyze` measures it against a
// .vcad design (analyze_build_file).
bool is_laser_build_file(const std::string& path);

// A laser build file (CLI, ASCII or binary, any tool's) measured against its design (.vcad):
// vectors outside the part, FR_a per layer, scan time with `laser`'s timing. The report JSON
// goes to `report_json` when given; the summary and the toolpath read are in the result.
// A .3mf is read as a 3MF toolpath, a .json as a toolpath JSON, any other file as a CLI.
JobResult analyze_build_file(const std::string& path, const std::string& design,
                             const LaserProfile& laser, std::string* report_json,
                             Diagnostics& diag);
// The same of a toolpath already read (`path` names it in the report and summary).
JobResult analyze_build_toolpath(const Toolpath& toolpath, const std::string& path,
                                 const std::string& design, const LaserProfile& laser,
                                 std::string* report_json);
// Whether a toolpath is a laser build's: it declares lasers (Toolpath::lasers) or a path has
// laser power. `trellis analyze` of a toolpath JSON of one times it as a build file.
bool is_laser_toolpath(const Toolpath& toolpath);

// Every file the job reads (input, machine, path settings, parts' designs) and writes (its
// outputs, the preview folder, the shard files of a shard), each with its role.
RunFiles job_files(const Job& job, bool follow_symlinks);

// Runs the job's route: reads, plans or slices, writes every requested output atomically. Its
// files (job_files) are checked first (core/run_files.hpp): an output that is an input or another
// output, a folder or a symbolic link (unless run.follow_symlinks) is refused before anything runs.
// The route runs with `context`'s progress and diagnostics (none: warnings dropped) and the run
// section's threads (run.threads; the context's when it is 0) and budget (run.max_memory,
// run.max_time, run.force).
// A reader's job (RouteSpec::reads) runs as its command does: the settings given (flags, --set,
// keywords) are checked against it and its files first, its machine profile is loaded below them
// (not again for an embedded job, which carries them), and its report (or page) is written with
// the job embedded; JobResult::summary is what its command prints.
JobResult run_job(const Job& job, const RunContext& context);
// The same with a context of `diag` and `progress`.
JobResult run_job(const Job& job, Diagnostics& diag, const Progress& progress = {});

}  // namespace trellis
