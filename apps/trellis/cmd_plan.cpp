#include <chrono>
#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/report.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

void add_plan(CLI::App& app) {
  struct Opts {
    std::string planner, input, output, report, mode = "max", order = "longest-first", png_prefix;
    PlanParams p;
    double merge_tolerance = 1e-6;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("plan", "Plan print paths over a lattice (toolpath JSON + report)");
  cmd->footer(
      "Planners:\n  gippo  the paper's randomized greedy growth (max: longest edge first, min: "
      "shortest),\n         N iterations, best score (Eq. 1) kept; reproducible for a seed.\n"
      "  euler  Hierholzer: exactly the lower bound max(1, odd nodes/2) of paths per component.\n"
      "Lattice formats: .json, NAME_vertices.csv/NAME_edges.csv (AERO), segment .csv, .obj.\n"
      "Planar levels (edges at one z) and materials are planned separately; the nozzle z is the\n"
      "design z plus the layer height.");
  cmd->add_option("planner", o->planner, "gippo or euler")
      ->required()
      ->check(CLI::IsMember({"gippo", "euler"}));
  cmd->add_option("lattice", o->input, "lattice file")->required();
  cmd->add_option("-o,--output", o->output, "toolpath JSON to write")->required();
  cmd->add_option("--report", o->report, "report JSON to write");
  cmd->add_option("--mode", o->mode, "gippo: max or min")
      ->check(CLI::IsMember({"max", "min"}))
      ->capture_default_str();
  cmd->add_option("--iterations", o->p.gippo.iterations, "gippo: iterations")
      ->check(CLI::Range(1, 10000000))
      ->capture_default_str();
  cmd->add_option("--seed", o->p.gippo.seed, "gippo: random seed")->capture_default_str();
  cmd->add_option("--threads", o->p.gippo.threads, "threads (0 = all cores)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  cmd->add_option("--order", o->order,
                  "path order: longest-first (paper) or travel (nearest neighbour + 2-opt)")
      ->check(CLI::IsMember({"longest-first", "travel"}))
      ->capture_default_str();
  cmd->add_option("--layer-height", o->p.layer_height, "bead height (mm)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--long-nodes", o->p.long_path_nodes,
                  "LTS/OE: a path is long with at least this many nodes")
      ->capture_default_str();
  cmd->add_option("--merge-tolerance", o->merge_tolerance, "merge nodes closer than this (mm)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--png", o->png_prefix,
                  "write PREFIX.layerNNN.png previews (and PREFIX.scores.png for gippo)");
  cmd->callback([o] {
    const auto t0 = std::chrono::steady_clock::now();
    PlanParams p = o->p;
    p.planner = planner_from_string(o->planner);
    p.gippo.mode = o->mode == "max" ? GippoMode::Max : GippoMode::Min;
    p.order = path_order_from_string(o->order);
    p.gippo.progress.report = progress_line;
    Diagnostics diag;
    const Graph g = read_lattice(o->input, {o->merge_tolerance, true}, diag);
    PlanResult r = plan_lattice(g, p, diag);
    r.toolpath.source = "trellis plan " + o->planner + " " + o->input;
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    write_toolpath(o->output, r.toolpath);
    if (!o->report.empty())
      write_file_atomic(
          o->report,
          plan_report_json(r, p, diag, {o->input, g.nodes.size(), g.edges.size()}));
    if (!o->png_prefix.empty()) {
      for (std::size_t i = 0; i < r.toolpath.layers.size(); ++i) {
        char name[32];
        std::snprintf(name, sizeof name, ".layer%03zu.png", i);
        render_layer_png(r.toolpath, i, o->png_prefix + name);
      }
      if (!r.layers.empty() && !r.layers[0].scores.empty())
        render_scores_png(r.layers[0].scores, r.layers[0].best_iteration,
                          "GIPPO score per iteration", o->png_prefix + ".scores.png");
    }
    print_warnings(diag);
    std::cout << o->planner << ": " << g.edges.size() << " edges, " << r.toolpath.layers.size()
              << " layer(s), " << r.total.paths << " paths (lower bound "
              << r.total.lower_bound_paths << "), score " << num(r.total.score, 4) << ", LTS "
              << num(r.total.lts, 1) << "%, OE " << num(r.total.oe, 2) << "%, travel "
              << r.travel.moves << " moves / " << num(r.travel.length, 1) << " mm, " << num(secs, 3)
              << " s -> " << o->output << "\n";
  });
}

}  // namespace trellis::cli
