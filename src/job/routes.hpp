// The routes behind run_job (private). Each reads its settings from the Config, writes the
// outputs the Job asks for, and returns what it wrote and a summary line.
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "trellis/core/budget.hpp"
#include "trellis/job/job.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/render/render.hpp"
#include "trellis/slice/nonplanar.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/pbf_lasers.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis::routes {

JobResult lattice2d(const Job& job, const Config& c, const RunContext& context);
JobResult lattice3d(const Job& job, const Config& c, const RunContext& context);
JobResult plan(const Job& job, const Config& c, const RunContext& context);
JobResult gcode(const Job& job, const Config& c, const RunContext& context);
JobResult slice(const Job& job, const Config& c, const RunContext& context);
JobResult pbf(const Job& job, const Config& c, const RunContext& context);
// A design's minfeaturesize (a 3MF level set, Volumetric & Implicit Part I §4.1.1: a consumer
// that cannot resolve such features "SHOULD raise a warning") finer than what the route prints
// (`width`: the bead, the laser's melt pool) or samples (`step`, the setting `step_key`): said,
// by the slice and pbf routes alike.
void warn_min_feature(const std::string& input, double feature, const char* width_name,
                      double width, double step, const char* step_key, const RunContext& context);
// Solid parts on the pbf route (routes_pbf_solid.cpp): a mesh input, or a .vcad with a solid
// scan strategy (rectilinear, meander, stripe, island); pbf() hands such jobs to pbf_solid.
bool is_mesh_path(const std::string& path);
bool pbf_solid_job(const Job& job, const Config& c);
JobResult pbf_solid(const Job& job, const Config& c, const RunContext& context);
JobResult nonplanar(const Job& job, const Config& c, const RunContext& context);
JobResult surface(const Job& job, const Config& c, const RunContext& context);

// The main output of the pbf, slice and nonplanar routes from their whole toolpath: what a single
// run writes and what `trellis merge` writes from the shards' layers (job/plate.hpp), so both are
// the same bytes. `tp` gets the job embedded.
void write_pbf_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out);
void write_slice_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out,
                      Diagnostics& diag, GcodeStats* stats = nullptr);
// The merge of graded slicing shards (their layers before the whole-print step; `graded`: the
// manifests' "graded" object; `outline_z`: the shards' outline planes in order, when the design
// has process fields): the whole-print step (slice/pipeline.hpp finish_graded: prime tower, tool
// mixtures; the process pass) on all layers in order, then write_slice_main.
void write_graded_merge(const Job& job, const Config& c, Toolpath& tp, const std::string& graded,
                        const std::vector<double>& outline_z, std::size_t total_layers,
                        JobResult& out, Diagnostics& diag);
GcodeStats write_nonplanar_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out,
                                Diagnostics& diag);

// The plan route's G-code (euler, gippo) from its whole toolpath, for the single run and merge.
void write_plan_main(const Job& job, const Config& c, const Toolpath& tp, JobResult& out,
                     Diagnostics& diag, GcodeStats* stats = nullptr);
// `trellis merge` of plan shards: what they left to the merge (a travel order starts where the
// layer below ended; then the surface, onto.*), then write_plan_main.
void merge_plan_main(const Job& job, const Config& c, Toolpath& tp, JobResult& out,
                     Diagnostics& diag);

// The job as it is embedded into a file at `path` (paths relative to its folder).
std::string embedded_job(const Job& job, const std::string& path);
// A JSON output with the job added as its "job" field; reports (`command` true) also record the
// literal command line, which main outputs leave out so that CLI, Python and rerun agree.
// Reports also get the run's warnings (`diag`) as a "warnings" array when they have none.
std::string with_job(const std::string& json, const Job& job, const std::string& path,
                     bool command = true, const Diagnostics* diag = nullptr);
// A JSON document with `field` set to another JSON document (text).
std::string with_field(const std::string& json, const std::string& field,
                       const std::string& value_json);
// Writes the toolpath JSON with the job embedded.
void write_toolpath_with_job(const std::string& path, Toolpath toolpath, const Job& job);
// Writes G-code for the machine at `path` (nothing when empty) with the job embedded, after the
// machine check; its warnings go to `diag`. Keeps the toolpath in `out` either way.
GcodeStats write_gcode_out(const std::string& path, Toolpath tp, const Job& job,
                           const MachineProfile& machine, JobResult& out, Diagnostics& diag);
// Whether `path` names a 3MF toolpath package (.3mf): the routes that write G-code or .cli write
// the Toolpath Extension instead (machine/toolpath_3mf.hpp), through write_gcode_out,
// write_gcode_streamed and write_laser_build.
bool is_3mf_output(const std::string& path);
// The toolpath as a 3MF package at `path` with the job embedded (into `tp`), and the design the
// route left in `out.geometry` as its build item: triangles and/or struts as beams (of their
// radius, else half the toolpath's bead width, else half `nozzle` mm); without any, the beads
// printed (toolpath_3mf.hpp). `laser` for laser builds. Returns the package's size in bytes.
std::size_t write_3mf_out(const std::string& path, Toolpath& tp, const Job& job,
                          const LaserProfile* laser, JobResult& out, Diagnostics* diag = nullptr,
                          double nozzle = 0);
// A design file as a 3MF output's triangles: a mesh (STL, OBJ, 3MF) as read, a field design
// (.vcad, implicit 3MF) meshed at `voxel` mm over its extent (coarser where its longest side
// would take more than kGeometryCells voxels); the work is checked against `budget` first.
std::shared_ptr<const TriangleMesh> design_mesh_3mf(const std::string& input, double voxel,
                                                    const Budget& budget);
std::shared_ptr<const TriangleMesh> field_mesh_3mf(const Field& field, double voxel,
                                                   const Budget& budget);
// The design of a job of the plan, slice (one part or a plate), pbf or nonplanar route as its 3MF
// output carries it (out.geometry): their RouteSpec::design.
void plan_design(const Job& job, const Config& c, JobResult& out);
void slice_design(const Job& job, const Config& c, JobResult& out);
void pbf_design(const Job& job, const Config& c, JobResult& out);
void nonplanar_design(const Job& job, const Config& c, JobResult& out);
// The pbf route's build file: .cli (binary if asked) or, for .3mf, the Toolpath Extension.
void write_laser_build(const std::string& path, Toolpath& tp, const Job& job, const Config& c,
                       JobResult& out, const std::vector<CliParameterSet>& sets = {});
// Where the machine's origin lies in design coordinates (the origin hatch phase): the design's
// origin at pbf.plate_position on the plate, by default its centre.
Vec2 pbf_machine_origin(const Config& c);
// Whether a route writes its output alone (no toolpath JSON, previews or toolpath kept for the
// caller): then it may stream its layers in bounded memory instead of holding the toolpath.
bool output_alone(const Job& job);
// write_gcode_out for streamed layers (`meta`: source and part labels; `layers` of them).
// `shared_source`: the source may be visited from two threads at once (LayerSpill::source):
// the thumbnails are then made while the text is written.
GcodeStats write_gcode_streamed(const std::string& path, Toolpath meta, std::size_t layers,
                                const LayerSource& source, const Job& job,
                                const MachineProfile& machine, JobResult& out, Diagnostics& diag,
                                bool shared_source = false);
// Bath routes (nonplanar, plan aero) writing G-code need a bath machine (machine.flavor =
// embedded): MachineError naming the route, the machine and a bath profile otherwise.
void require_bath(const Job& job, const MachineProfile& machine, const std::string& route,
                  const std::string& why);
// Planar routes on a bath machine: a warning (planar layers print in a bath too, e.g. FRESH).
void note_planar_in_bath(const MachineProfile& machine, const std::string& route,
                         Diagnostics& diag);
// DIR/layer_0000.png … for `count` layers spread over the toolpath (all when count >= layers).
void previews(const Toolpath& tp, const std::string& dir, int count, const RenderOptions& ro,
              JobResult& out, const std::string& prefix = "layer_");
std::string preview_name(const std::string& dir, const std::string& file);
// The pbf routes' previews: paths coloured by role at the melt pool's width, no travel.
void laser_previews(const Toolpath& tp, const Job& job, const Config& c, JobResult& out);

// Multi-laser PBF (slice/pbf_lasers.hpp, docs/laser.md): the configuration's lasers; whether a
// pbf route splits its layers among them (several lasers, or one whose field is to be checked);
// the per-laser times as the report's "lasers" object and as the summary's tail ("" for one).
LaserSetup lasers_of(const Config& c);
bool splits_layers(const Config& c);
void add_laser_report(nlohmann::ordered_json& report, const LaserTimes& times, const Config& c);
std::string laser_summary(const LaserTimes& times);
std::string fixed(double v, int decimals);

// Estimates before work (estimate.cpp): each route checks its estimate with check_budget against
// context.budget before it allocates the work; the budget tells `progress.estimate` each estimate
// it checks.
Budget budget_of(const Settings& settings, const Config& c, const Progress& progress);
// The context a route or reader runs with (run_job): the caller's progress and diagnostics; the
// run section's threads (run.threads; the caller's when it is 0) and budget (budget_of).
RunContext run_context(const Settings& settings, const Config& c, const RunContext& given);
double threads_of_run();
Estimate estimate_lattice2d(const AtlasParams& a, int layers);
Estimate estimate_lattice3d(const Config& c);
Estimate estimate_gippo(std::size_t edges, int iterations, int seeds);
Estimate estimate_aero(std::size_t edges, int tries);
Estimate estimate_nonplanar(const BBox2& domain, const NonplanarParams& p);
// Every setting the user gave must change this run's output (Setting::when): refused otherwise,
// with the reason (a job file's setting the command line left idle: a warning). Before the
// toolpath is made (`written` null) the toolpath's facts hold; the G-code writer checks again
// with the toolpath it writes.
void check_settings_used(const Job& job, const Toolpath* written, Diagnostics& diag);
// Writing a toolpath JSON file as G-code: reading it and writing about as many bytes of G-code.
Estimate estimate_gcode_of(const std::string& toolpath_json);
// toolpath_json: the whole toolpath is also written as JSON (time and memory of its document).
Estimate estimate_pbf_time(const PbfDesign& design, const PbfOptions& options, bool toolpath_json,
                           bool package_3mf = false);

// The reader routes (RouteSpec::reads): check (reader_check.cpp), view and render
// (reader_view.cpp), analyze and compare (reader_analyze.cpp). Each gets the job with its profile
// loaded below its settings; the report it makes goes in JobResult::report_json (run_reader writes
// it), view writes its page itself (with_page_job).
JobResult reader_check(const Job& job, const Config& c, const RunContext& context);
JobResult reader_view(const Job& job, const Config& c, const RunContext& context);
JobResult reader_render(const Job& job, const Config& c, const RunContext& context);
JobResult reader_analyze(const Job& job, const Config& c, const RunContext& context);
JobResult reader_compare(const Job& job, const Config& c, const RunContext& context);
// run_job of a reader's job (readers.cpp): the settings given and its files checked, the profile
// loaded below the settings (not for an embedded job: it carries them), the reader run, its report
// written with the job embedded (not for a design or print in memory: no file to name).
JobResult run_reader(const RouteSpec& spec, const Job& job, const RunContext& context);
// A report (JSON: an object, or compare's array of analyses) with the job added: an object's
// "job" field, each analysis of an array (compare); the rest of its bytes as they were.
std::string with_report_job(const std::string& report, const std::string& job);
// The viewer page with the job embedded as it would be at `path`: a JSON string in a script
// element the browser does not run, `<` escaped so no text of the job can end it, just before
// </body>. kPageJobOpen opens it (job_from_output finds the job after it).
inline constexpr const char* kPageJobOpen = "<script type=\"application/json\" id=\"trellis-job\">";
std::string with_page_job(const std::string& html, const Job& job, const std::string& path);

}  // namespace trellis::routes
