// `analyze` (a print measured, optionally against its design lattice; a laser build file against
// its .vcad) and `compare` (prints side by side against one design).
#include <fmt/format.h>

#include <cctype>
#include <filesystem>
#include <map>

#include "routes.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/reports.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::routes {

namespace {

Analysis analyze_toolpath(const Toolpath& tp, const Graph* design, const AnalysisParams& params,
                          const std::string& name) {
  Analysis a = analyze(tp, toolpath_counts(tp), design, params);
  a.name = name;
  return a;
}

// One print measured: G-code of any slicer, or a toolpath JSON as planned (no filament or
// retractions: the machine's G-code adds them). A file that is no print (a report, a lattice, a
// mesh, a design) is refused naming it, never read as G-code with nothing in it.
Analysis analyze_file(const std::string& f, const Graph* design, const AnalysisParams& params,
                      const GcodeReadOptions& read, Diagnostics& diag) {
  std::string ext = std::filesystem::path(f).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".json") return analyze_toolpath(read_toolpath(f), design, params, f);
  // A 3MF toolpath (a laser one went to the laser analysis); a mesh 3MF is refused by the reader.
  if (ext == ".3mf") return analyze_toolpath(read_toolpath_3mf_file(f, &diag), design, params, f);
  for (const char* other : {".stl", ".obj", ".csv", ".vcad", ".toml", ".png", ".html"})
    if (ext == other)
      throw ParseError(
          f + ": a '" + ext +
          "' file is not a print: analyze reads G-code (.gcode/.g/.gco/.nc/.bgcode), "
          "a laser .cli, a 3MF toolpath or a toolpath JSON (a lattice goes to --design)");
  return analyze_gcode_file(f, design, params, read, diag);
}

// The PNGs of one print's layers (the printed toolpath; with a design, the design in grey,
// doubles red, missing struts blue), named after its file (`stems` numbers files of one name),
// each added to `files`.
std::string write_layer_pictures(const Analysis& a, const std::string& f, const Graph* design,
                                 const std::string& folder, double width,
                                 std::map<std::string, int>& stems,
                                 std::vector<std::string>& files) {
  const Toolpath& tp = a.printed;
  if (tp.layers.empty())
    throw GeometryError("nothing to draw for --preview: the file has no extrusion", {f});
  create_output_directories(folder);
  std::string stem = std::filesystem::path(f).stem().string();
  if (const int n = ++stems[stem]; n > 1) stem += fmt::format("_{}", n);
  auto name = [&](std::size_t i) -> const std::string& {
    files.push_back(
        (std::filesystem::path(folder) / (stem + fmt::format("_layer_{:04}.png", i))).string());
    return files.back();
  };
  if (!design) {
    RenderOptions ro;
    ro.colour_by_role = true;
    ro.bead_width = width;
    for (std::size_t i = 0; i < tp.layers.size(); ++i) render_layer_png(tp, i, name(i), ro);
    return fmt::format("wrote {} layer picture(s) to {}\n", tp.layers.size(), folder);
  }
  std::vector<Segment2> dsegs;
  for (const auto& e : design->edges)
    dsegs.push_back({design->nodes[e.a].xy(), design->nodes[e.b].xy()});
  for (std::size_t i = 0; i < a.layers.size() && i < tp.layers.size(); ++i) {
    std::vector<Segment2> blue;
    for (EdgeId e : a.layers[i].missing)
      blue.push_back(
          {design->nodes[design->edges[e].a].xy(), design->nodes[design->edges[e].b].xy()});
    render_overlay_png(dsegs, tp.layers[i], a.layers[i].doubles, blue, width, name(i));
  }
  return fmt::format("wrote {} layer picture(s) to {}\n",
                     std::min(a.layers.size(), tp.layers.size()), folder);
}

// Every print of the job measured (and drawn, with a preview folder); the pictures' lines go to
// `out.summary`, their files to `out.files`.
std::vector<Analysis> analyze_prints(const Job& job, const Config& c, Diagnostics& diag,
                                     JobResult& out) {
  std::shared_ptr<const Graph> design = job.design_graph;
  if (!design && !job.design.empty())
    design = std::make_shared<Graph>(read_lattice(job.design, {}, diag));
  AnalysisParams params = c.read.analysis;
  params.keep_printed = !job.preview.empty();
  std::vector<Analysis> runs;
  if (job.print)
    runs.push_back(analyze_toolpath(*job.print, design.get(), params, job.print->source));
  std::map<std::string, int> stems;  // files of one name (a/x.gcode, b/x.gcode): x, x_2, ...
  for (const auto& f : job.prints()) {
    runs.push_back(analyze_file(f, design.get(), params, c.read.gcode, diag));
    const Analysis& a = runs.back();
    if (a.auto_aligned)
      diag.warn("analyze_aligned",
                fmt::format("{}: the print lies outside the design, moved by ({:.2f}, {:.2f}) mm "
                            "to align their centres; set analyze.align to always align",
                            f, a.shift.x, a.shift.y));
    if (!job.preview.empty())
      out.summary +=
          write_layer_pictures(a, f, design.get(), job.preview, params.width, stems, out.files);
  }
  return runs;
}

// A line per layer: starts (and the lower bound of the design's struts there), retractions,
// travel.
std::string layer_lines(const Analysis& a) {
  std::string out = std::string("layer        z   starts") + (a.has_design ? "  (bound)" : "") +
                    "  retractions  travels  travel mm\n";
  for (std::size_t i = 0; i < a.counts.per_layer.size(); ++i) {
    const auto& l = a.counts.per_layer[i];
    out += fmt::format("{:5} {:8.3f} {:8}", i, l.z, l.starts);
    if (a.has_design)
      out += fmt::format("  ({:5})", i < a.layers.size() ? a.layers[i].lower_bound : 0);
    out += fmt::format(" {:12} {:8} {:10.1f}\n", l.retractions, l.travel_moves, l.travel_length);
  }
  return out;
}

std::string analysis_summary(const Analysis& a, double filament_diameter) {
  std::string out = fmt::format(
      "{}: {} layer(s), {} paths, {} extrusion starts, {:.1f} mm extruded, {} travel moves ({:.1f} "
      "mm), {} retractions, score {:.4f}\n",
      a.name, a.counts.layers, a.paths, a.counts.extrusion_starts, a.extruded_length,
      a.counts.travel_moves, a.counts.travel_length, a.counts.retractions, a.score);
  out += fmt::format("  print time {:.1f} min, of which heater waits {:.1f} min\n",
                     a.counts.print_time_s / 60, a.counts.heating_s / 60);
  // Build plates: each labelled part (M486 / Klipper EXCLUDE_OBJECT).
  for (const auto& p : a.counts.parts)
    out += fmt::format(
        "  part {}: {:.1f} mm extruded, {:.2f} mm filament ({:.1f} mm³ at {:.2f} mm), {:.1f} min\n",
        p.label, p.extruded_length, p.filament,
        p.filament * 3.14159265358979 * filament_diameter * filament_diameter / 4,
        filament_diameter, p.print_time_s / 60);
  if (a.has_design)
    out += fmt::format(
        "  against the design: ratio {:.3f}, double {:.2f} mm, off-design {:.2f} mm, missing {} of "
        "{} struts, corrected score {:.4f}\n",
        a.extrusion_ratio, a.double_length, a.off_design_length, a.missing_edges, a.design_edges,
        a.score_corrected);
  return out;
}

JobResult analyze_laser(const Job& job, const Config& c, Diagnostics& diag,
                        const Toolpath* read = nullptr) {
  std::string json;
  JobResult r = read ? analyze_build_toolpath(*read, job.prints().at(0), job.design, c.laser, &json)
                     : analyze_build_file(job.prints().at(0), job.design, c.laser, &json, diag);
  r.summary += "\n";
  r.report_json = json;
  return r;
}

}  // namespace

JobResult reader_analyze(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  if (!job.print && is_laser_build_file(job.prints().at(0))) return analyze_laser(job, c, diag);
  // A toolpath JSON of a laser build (pbf --toolpath) is timed as the build file would be: each
  // laser with its own scanner.
  if (const auto prints = job.prints(); !job.print && prints.size() == 1) {
    std::string ext = std::filesystem::path(prints[0]).extension().string();
    for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (ext == ".json")
      if (const Toolpath tp = read_toolpath(prints[0]); is_laser_toolpath(tp))
        return analyze_laser(job, c, diag, &tp);
  }
  JobResult r;
  const auto runs = analyze_prints(job, c, diag, r);
  const Analysis& a = runs.front();
  r.report_json = analysis_json(a);
  if (c.read.per_layer) r.summary += layer_lines(a);
  r.summary += analysis_summary(a, c.read.filament_diameter);
  return r;
}

JobResult reader_compare(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  JobResult r;
  const auto runs = analyze_prints(job, c, diag, r);
  if (c.read.per_layer)
    for (const auto& a : runs) r.summary += a.name + ":\n" + layer_lines(a);
  r.summary += comparison_table(runs);
  r.report_json = "[\n";
  for (std::size_t i = 0; i < runs.size(); ++i)
    r.report_json += (i ? ",\n" : "") + analysis_json(runs[i]);
  r.report_json += "]\n";
  return r;
}

}  // namespace trellis::routes
