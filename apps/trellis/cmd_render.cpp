#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "commands.hpp"
#include "progress_display.hpp"
#include "trellis/core/budget.hpp"
#include "trellis/core/error.hpp"
#include "trellis/render/render.hpp"
#include "trellis/view/view.hpp"

namespace trellis::cli {

void add_render(CLI::App& app) {
  struct Opts {
    std::string input, output;
    int layer = -1;
    bool force = false;
    double max_time = Budget{}.seconds, max_memory = 0;
    int progress = -1;
    std::string colour = "feature";
    RenderOptions r;
    std::string machine;
    ViewLoadOptions load;
    bool follow = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("render", "Render toolpath layers to PNG");
  cmd->footer(
      "Reads a toolpath JSON, G-code of any slicer (.gcode/.g/.nc), a laser .cli or a 3MF\n"
      "toolpath. Paths are coloured by feature type (or print order, or mixture) in the viewer's\n"
      "colours, travel is dashed grey, path starts are white discs in a dark ring (seen on any\n"
      "colour; laser hatch vectors have none) and ends small dark dots. A G-code file's mixture\n"
      "is drawn as deposited (its header's mixing look-ahead undone); --colour commanded draws\n"
      "the mixture where the commands were issued; --colour tool draws each tool (each laser of\n"
      "a laser file) in its colour, the default for a build file of several lasers. Each PNG has\n"
      "a title (file, layer, Z, what colour means), a legend or colour bar and a scale bar in mm.\n"
      "Without --layer every layer is written as OUT.layerNNN.png (OUT without .png).");
  cmd->add_option("toolpath", o->input,
                  "toolpath JSON, G-code (.gcode/.g/.nc), laser .cli or 3MF toolpath")
      ->required()
      ->check(path_value());
  auto* colour =
      cmd->add_option("--colour", o->colour,
                      "what colour means: feature, order, mixture (as deposited), "
                      "commanded (the mixture as commanded), tool (laser) or set "
                      "(laser parameter set: contour k, core, up-/down-skin hatch); "
                      "default: tool for a laser file of several lasers, else feature")
          ->check(CLI::IsMember({"feature", "order", "mixture", "commanded", "tool", "set"}));
  cmd->add_option("--machine", o->machine, ".nc files: machine profile (valve commands)")
      ->check(path_value());
  cmd->add_option("-o,--output", o->output, "PNG file (with --layer) or prefix")
      ->required()
      ->check(path_value());
  add_follow_symlinks(cmd, o->follow);
  cmd->add_option("--layer", o->layer, "layer index (0-based)")->check(number_value(0, 1e9));
  cmd->add_option("--image-size", o->r.size_px, "image size in pixels")
      ->check(CLI::Range(16, 8000))
      ->capture_default_str();
  cmd->add_option("--bead-width", o->r.bead_width, "line width (mm; default: from the toolpath)")
      ->check(number_value(0, 100, true));
  cmd->add_option("--max-time", o->max_time,
                  "refuse when the estimated time is longer than this (s; run.max_time)")
      ->check(number_value(0, 1e9, true))
      ->capture_default_str();
  cmd->add_option("--max-memory", o->max_memory,
                  "refuse when the estimate needs more memory than this (MB; run.max_memory; "
                  "default: half the memory available)")
      ->check(number_value(0, 1e9, true));
  cmd->add_flag("--force", o->force, "render even when the estimate is beyond the budget");
  add_progress_flag(cmd, o->progress);
  cmd->add_flag("!--no-travel", o->r.travel, "do not draw travel moves");
  cmd->callback([o, colour] {
    // Without --layer, -o is the prefix of OUT.layerNNN.png: the batch refuses any of them that
    // is an input.
    if (o->layer < 0) {
      // Each layer's PNG is written beside the prefix: a device or FIFO there (-o /dev/null)
      // would scatter files through its folder.
      std::error_code ec;
      const auto st = std::filesystem::status(o->output, ec);
      if (!ec && (std::filesystem::is_character_file(st) || std::filesystem::is_block_file(st) ||
                  std::filesystem::is_fifo(st) || std::filesystem::is_socket(st)))
        throw SettingError(o->output +
                           ": without --layer, -o is the prefix of one PNG per layer "
                           "(OUT.layerNNN.png beside it), and this is a device or FIFO; give "
                           "--layer N to write one PNG to it");
    }
    RunFiles files(o->follow);
    files.input("the toolpath", o->input);
    files.input("the machine profile (--machine)", o->machine);
    if (o->layer >= 0) files.output("the PNG (-o)", o->output);
    files.check();
    Diagnostics diag;
    machine_valves(o->machine, o->load);
    ViewScene scene = load_view_scene(o->input, o->load, diag);
    if (scene.kind == "lattice")
      throw ParseError(o->input +
                       ": a lattice, not a toolpath (plan it first, or `trellis view` it)");
    print_warnings(diag);
    Toolpath& tp = scene.toolpath;
    // A laser file: a .cli, or paths that carry a laser power (a 3MF toolpath of a laser build).
    bool laser = scene.kind == "cli";
    int tools = 0;
    for (const auto& l : tp.layers)
      for (const auto& p : l.paths) laser |= p.power > 0, tools = std::max(tools, p.tool + 1);
    if (colour->count() == 0 && laser && tools > 1) o->colour = "tool";
    o->r.colour_by_tool = o->colour == "tool";
    o->r.colour_by_set = o->colour == "set";
    o->r.tools_are_lasers = laser;
    o->r.colour_by_role = o->colour == "feature";
    o->r.colour_by_mixture = o->colour == "mixture" || o->colour == "commanded";
    o->r.mixture_label = mixture_label(scene, o->colour == "commanded");
    if (o->colour == "commanded" && !scene.commanded.empty()) {
      std::size_t k = 0;
      for (auto& l : tp.layers)
        for (auto& p : l.paths) p.mixture = scene.commanded.at(k++);
    }
    if (o->r.title.empty()) o->r.title = scene.name;
    // Estimate before work: the images and the points they draw.
    const std::size_t first = o->layer >= 0 ? static_cast<std::size_t>(o->layer) : 0;
    const std::size_t end =
        o->layer >= 0 ? std::min(first + 1, tp.layers.size()) : tp.layers.size();
    double points = 0;
    for (std::size_t i = first; i < end; ++i)
      for (const auto& p : tp.layers[i].paths) points += static_cast<double>(p.points.size());
    ProgressDisplay display(progress_mode(o->progress), "trellis render");
    const Progress progress = display.progress();
    Budget budget;
    budget.force = o->force;
    budget.seconds = o->max_time;
    budget.memory = o->max_memory * 1e6;
    budget.seen = progress.estimate;
    Estimate e =
        layer_images_estimate(o->layer >= 0 ? 1.0 : double(tp.layers.size()), o->r.size_px, points);
    e.change = "--image-size or --layer";
    check_budget(e, budget);
    if (o->layer >= 0) {
      render_layer_png(tp, static_cast<std::size_t>(o->layer), o->output, o->r);
      std::cout << "wrote " << o->output << "\n";
      return;
    }
    std::string prefix = o->output;
    if (prefix.size() > 4 && prefix.substr(prefix.size() - 4) == ".png")
      prefix.resize(prefix.size() - 4);
    for (std::size_t i = 0; i < tp.layers.size(); ++i) {
      char name[32];
      std::snprintf(name, sizeof name, ".layer%03zu.png", i);
      progress("layers", static_cast<double>(i) / static_cast<double>(tp.layers.size()));
      render_layer_png(tp, i, prefix + name, o->r);
    }
    progress("layers", 1.0);
    display.finish();
    std::cout << "wrote " << tp.layers.size() << " PNG(s): " << prefix << ".layerNNN.png\n";
  });
}

}  // namespace trellis::cli
