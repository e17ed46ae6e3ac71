// `view` (the viewer page of prints and lattices, over their design and checked as `check` does)
// and `render` (layer PNGs of a print).
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <optional>
#include <system_error>

#include "routes.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/print_check.hpp"
#include "trellis/view/view.hpp"

namespace trellis::routes {

namespace {

// How a pneumatic file is read: read.valve_on / read.valve_off, else the profile's valve commands
// (a pneumatic or bath profile), else the file's own header.
ViewLoadOptions view_load(const Job& job, const Config& c) {
  ViewLoadOptions load;
  load.valve_on = c.read.gcode.valve_on;
  load.valve_off = c.read.gcode.valve_off;
  if (job.machine.empty() || c.machine.marlin_family()) return load;
  if (load.valve_on.empty()) load.valve_on = c.machine.valve_on;
  if (load.valve_off.empty()) load.valve_off = c.machine.valve_off;
  return load;
}

// A line of the view's summary: what the page shows of one file.
std::string scene_line(const ViewScene& s) {
  std::string out = s.name + " (" + s.kind + "): ";
  if (s.kind == "lattice") return out + std::to_string(s.design.size()) + " struts\n";
  // Paths as `analyze` and the page count them: runs of extrusion between travels (a laser build
  // file: its vectors).
  std::size_t segments = 0;
  const std::size_t paths = s.kind == "cli" ? s.toolpath.path_count() : run_count(s.toolpath);
  for (const auto& l : s.toolpath.layers)
    for (const auto& p : l.paths) segments += p.segments();
  if (s.kind == "check")
    out += fmt::format("{} collisions, {} ringed", s.collisions, s.hits.size());
  else
    out += fmt::format("{} layer(s), {} paths, {} segments", s.toolpath.layers.size(), paths,
                       segments);
  if (s.checked && s.kind != "check") out += fmt::format(", {} collisions", s.collisions);
  if (!s.deviation.empty()) {
    float worst = 0;
    for (float d : s.deviation) worst = std::max(worst, d);
    out += fmt::format(", deviation from the design up to {:.3f} mm", worst);
  }
  if (!s.bed.shape.empty()) out += ", build volume of " + s.bed.machine;
  return out + "\n";
}

}  // namespace

JobResult reader_view(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  const bool machine = !job.machine.empty();
  const ViewLoadOptions load = view_load(job, c);
  std::optional<PrintCheck> checker;
  if (!job.design.empty()) {
    checker.emplace(job.settings, machine, c.read.snap);
    checker->read_design(job.design, diag);
  }
  std::vector<ViewScene> scenes;
  std::string title = c.read.title;
  for (const auto& f : job.prints()) {
    ViewScene s = load_view_scene(f, load, diag);
    const bool print =
        s.kind == "gcode" || s.kind == "nc" || s.kind == "bgcode" || s.kind == "toolpath";
    if (checker && s.kind != "lattice") {
      if (print) {
        // As `check` reads it: back in design coordinates, then replayed.
        s.toolpath = checker->read(f, diag);
        set_design(s, checker->design());
        set_collisions(s, checker->check(s.toolpath));
      } else {
        set_design(s, checker->design());
      }
    } else if (checker) {
      diag.warn("view", f + " is a lattice: --design is not compared with it");
    }
    if (machine && print && s.kind != "toolpath") {
      if (!checker)
        set_build_volume(s, c.machine, c.machine.name);
      else
        diag.warn("view", f + ": no build volume drawn: with --design the print is shown in "
                              "design coordinates, not on the machine's bed");
    }
    scenes.push_back(std::move(s));
    if (c.read.title.empty()) title += (title.empty() ? "" : ", ") + scenes.back().name;
  }
  // The page carries its job (rerun), like a report.
  write_file_atomic(job.output, with_page_job(viewer_html(scenes, title), job, job.output));
  JobResult r;
  r.files.push_back(job.output);
  for (const auto& s : scenes) r.summary += scene_line(s);
  r.summary += "wrote " + job.output + "\n";
  return r;
}

namespace {

// What the colours of a layer PNG mean (render.colour), auto resolved: tool for a laser file of
// several lasers, else feature.
RenderOptions render_options(const Config& c, const ViewScene& scene) {
  const Toolpath& tp = scene.toolpath;
  // A laser file: a .cli, or paths that carry a laser power (a 3MF toolpath of a laser build).
  bool laser = scene.kind == "cli";
  int tools = 0;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) laser |= p.power > 0, tools = std::max(tools, p.tool + 1);
  RenderColour colour = c.read.colour;
  if (colour == RenderColour::Auto)
    colour = laser && tools > 1 ? RenderColour::Tool : RenderColour::Feature;
  RenderOptions r = c.read.render;
  r.colour_by_tool = colour == RenderColour::Tool;
  r.colour_by_set = colour == RenderColour::Set;
  r.tools_are_lasers = laser;
  r.colour_by_role = colour == RenderColour::Feature;
  r.colour_by_mixture = colour == RenderColour::Mixture || colour == RenderColour::Commanded;
  r.mixture_label = mixture_label(scene, colour == RenderColour::Commanded);
  if (r.title.empty()) r.title = scene.name;
  return r;
}

// Without render.layer, -o is the prefix of OUT.layerNNN.png, each written beside it: a device or
// FIFO there (-o /dev/null) would scatter files through its folder.
void refuse_device_prefix(const std::string& output) {
  std::error_code ec;
  const auto st = std::filesystem::status(output, ec);
  if (!ec && (std::filesystem::is_character_file(st) || std::filesystem::is_block_file(st) ||
              std::filesystem::is_fifo(st) || std::filesystem::is_socket(st)))
    throw SettingError(output +
                       ": without render.layer, the output is the prefix of one PNG per layer "
                       "(OUT.layerNNN.png beside it), and this is a device or FIFO; give "
                       "render.layer to write one PNG to it");
}

}  // namespace

JobResult reader_render(const Job& job, const Config& c, const RunContext& context) {
  Diagnostics& diag = *context.diagnostics;
  const Progress& progress = context.progress;
  const int layer = c.read.layer;
  if (layer < 0) refuse_device_prefix(job.output);
  const std::string input = job.prints().at(0);
  ViewScene scene = load_view_scene(input, view_load(job, c), diag);
  if (scene.kind == "lattice")
    throw ParseError(input + ": a lattice, not a toolpath (plan it first, or `trellis view` it)");
  const RenderOptions ro = render_options(c, scene);
  Toolpath& tp = scene.toolpath;
  if (c.read.colour == RenderColour::Commanded && !scene.commanded.empty()) {
    std::size_t k = 0;
    for (auto& l : tp.layers)
      for (auto& p : l.paths) p.mixture = scene.commanded.at(k++);
  }
  // Estimate before work: the images and the points they draw.
  const std::size_t first = layer >= 0 ? static_cast<std::size_t>(layer) : 0;
  const std::size_t end = layer >= 0 ? std::min(first + 1, tp.layers.size()) : tp.layers.size();
  double points = 0;
  for (std::size_t i = first; i < end; ++i)
    for (const auto& p : tp.layers[i].paths) points += static_cast<double>(p.points.size());
  Estimate e =
      layer_images_estimate(layer >= 0 ? 1.0 : double(tp.layers.size()), ro.size_px, points);
  e.change = "render.image_size or render.layer";
  check_budget(e, context.budget);
  JobResult r;
  if (layer >= 0) {
    render_layer_png(tp, static_cast<std::size_t>(layer), job.output, ro);
    r.files = {job.output};
    r.summary = "wrote " + job.output + "\n";
    return r;
  }
  std::string prefix = job.output;
  if (prefix.size() > 4 && prefix.substr(prefix.size() - 4) == ".png")
    prefix.resize(prefix.size() - 4);
  for (std::size_t i = 0; i < tp.layers.size(); ++i) {
    progress("layers", static_cast<double>(i) / static_cast<double>(tp.layers.size()));
    r.files.push_back(prefix + fmt::format(".layer{:03}.png", i));
    render_layer_png(tp, i, r.files.back(), ro);
  }
  progress("layers", 1.0);
  r.summary = fmt::format("wrote {} PNG(s): {}.layerNNN.png\n", tp.layers.size(), prefix);
  return r;
}

}  // namespace trellis::routes
