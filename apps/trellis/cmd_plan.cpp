#include <chrono>
#include <iostream>

#include "commands.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/aero.hpp"
#include "trellis/plan/gippo.hpp"
#include "trellis/plan/report.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis::cli {

namespace {

// `trellis plan aero`: plan, check independently, write toolpath, report and previews.
template <class Opts>
void plan_aero_cli(const Opts& o) {
  const auto t0 = std::chrono::steady_clock::now();
  AeroParams p = o.aero;
  p.method = aero_method_from_string(o.method);
  p.collisions = !o.no_collisions;
  p.seed = o.p.gippo.seed;
  p.threads = o.p.gippo.threads;
  p.progress.report = progress_line;
  Diagnostics diag;
  const Graph g = read_lattice(
      o.input, o.keep_graph ? keep_graph_options() : CleanOptions{o.merge_tolerance, true}, diag);
  const AeroResult r = plan_aero(g, p, diag);
  const Toolpath tp = aero_toolpath(g, r, "trellis plan aero " + o.input);
  // The independent check sees the struts as they will be printed (ends pushed past their
  // nodes by the overlap, as the embedded writer does).
  CheckOptions check;
  check.nozzle = p.nozzle;
  check.snap = p.nozzle.end_overlap + 0.05;
  Toolpath printed = tp;
  for (auto& l : printed.layers)
    for (auto& path : l.paths) extend_path_ends(path, p.nozzle.end_overlap);
  const CollisionCheck c = check_collisions(g, printed, check);
  if (p.collisions && c.collisions != r.collisions_planned)
    diag.warn("collision_count_mismatch",
              "the independent check finds " + std::to_string(c.collisions) +
                  " collision(s), the plan counts " + std::to_string(r.collisions_planned));
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_toolpath(o.output, tp);
  if (!o.report.empty()) {
    AeroReportInput in{o.input, g.nodes.size(), g.edges.size(), secs};
    in.checked_collisions = static_cast<long long>(c.collisions);
    in.checked_once = c.printed_once == g.edges.size() && c.repeated.empty();
    write_file_atomic(o.report, aero_report_json(r, p, diag, in));
  }
  if (!o.png_prefix.empty()) {
    View3dOptions v;
    for (const auto& h : c.hits) v.marks.push_back(h.point);
    v.title = std::to_string(r.trails.trails.size()) + " trails, " + std::to_string(c.collisions) +
              " collisions (" + o.input + ")";
    render_3d_png(tp, o.png_prefix + ".png", v);
    for (std::size_t k = 1; k <= std::min(o.frames, r.trails.trails.size()); ++k) {
      View3dOptions f;
      f.upto = k;
      f.title = "step " + std::to_string(k) + " of " + std::to_string(r.trails.trails.size());
      char name[32];
      std::snprintf(name, sizeof name, ".step%02zu.png", k);
      render_3d_png(tp, o.png_prefix + name, f);
    }
  }
  print_warnings(diag);
  std::cout << "aero " << to_string(p.method) << ": " << g.edges.size() << " struts, " << r.groups
            << " groups, " << r.trails.trails.size() << " trails (lower bound "
            << r.lower_bound_trails << "), longest " << r.max_trail_edges << " struts, travel "
            << r.travel_moves << " moves / " << num(r.travel_length, 1) << " mm, collisions "
            << c.collisions << " (checked; planned " << r.collisions_planned << ", lower bound "
            << r.collisions_lower_bound
            << (r.collisions_proven_minimal() ? ", proven minimal" : "") << "), " << num(secs, 3)
            << " s -> " << o.output << "\n";
}

}  // namespace

void add_plan(CLI::App& app) {
  struct Opts {
    std::string planner, input, output, report, mode = "max", order = "longest-first", png_prefix;
    PlanParams p;
    double merge_tolerance = 1e-6;
    bool keep_graph = false;
    int seeds = 0;
    std::string seeds_report;
    // aero
    AeroParams aero;
    std::string method = "dynamic";
    bool no_collisions = false;
    std::size_t frames = 0;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("plan", "Plan print paths over a lattice (toolpath JSON + report)");
  cmd->footer(
      "Planners:\n  gippo  the paper's randomized greedy growth (max: longest edge first, min: "
      "shortest),\n         N iterations, best score (Eq. 1) kept; reproducible for a seed.\n"
      "  euler  Hierholzer: exactly the lower bound max(1, odd nodes/2) of paths per component.\n"
      "  aero   3D strut lattices for embedded printing: collision-free Eulerian trails\n"
      "         (nozzle = vertical cylinder; struts within the cone print bottom-up); the plan\n"
      "         is replayed by the independent collision checker and the result reported.\n"
      "Lattice formats: .json, NAME_vertices.csv/NAME_edges.csv (AERO), segment .csv, .obj.\n"
      "Planar levels (edges at one z) and materials are planned separately; the nozzle z is the\n"
      "design z plus the layer height.");
  cmd->add_option("planner", o->planner, "gippo, euler or aero")
      ->required()
      ->check(CLI::IsMember({"gippo", "euler", "aero"}));
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
  cmd->add_option("--seeds", o->seeds,
                  "gippo: also run seeds SEED .. SEED+N-1 and report the best score's spread")
      ->check(CLI::Range(0, 100000));
  cmd->add_option("--seeds-report", o->seeds_report, "gippo --seeds: JSON with every seed's scores");
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
  cmd->add_flag("--keep-graph", o->keep_graph,
                "keep the lattice exactly as given: no node merging, no T-junction splitting");
  cmd->add_option("--png", o->png_prefix,
                  "write PREFIX.layerNNN.png previews (PREFIX.scores.png for gippo; for aero an "
                  "isometric PREFIX.png)");
  auto* ag = "AERO (3D, embedded printing)";
  cmd->add_option("--method", o->method,
                  "aero: dynamic (refresh after every trail, default) or groups (the paper's)")
      ->check(CLI::IsMember({"dynamic", "groups"}))
      ->capture_default_str()
      ->group(ag);
  cmd->add_flag("--no-collisions", o->no_collisions,
                "aero: ignore the nozzle (trails = the Euler lower bound)")
      ->group(ag);
  add_nozzle_options(cmd, o->aero.nozzle, ag);
  cmd->add_option("--overlap", o->aero.nozzle.end_overlap,
                  "aero: the writer's node overlap (mm; embedded.node_overlap of the profile): "
                  "struts are planned as if that much longer at each end")
      ->capture_default_str()
      ->group(ag);
  cmd->add_option("--tries", o->aero.tries,
                  "aero dynamic: planner runs (strategies, then shuffled orders; best kept); "
                  "0 = 8, fewer above 25,000 struts")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str()
      ->group(ag);
  cmd->add_flag("--greedy-collisions{false}", o->aero.fewest_collisions,
                "aero: no fewest-collisions order (print the strut obstructing the fewest when "
                "stuck, as before)")
      ->group(ag);
  cmd->add_option("--exact-struts", o->aero.order.exact_max_struts,
                  "aero: solve obstruction cycles exactly (integer program) in parts up to this "
                  "many struts; 0 = local search only")
      ->capture_default_str()
      ->group(ag);
  cmd->add_option("--frames", o->frames,
                  "aero: with --png, also PREFIX.stepNN.png for the first N trails")
      ->group(ag);
  cmd->callback([o] {
    if (o->planner == "aero") return plan_aero_cli(*o);
    const auto t0 = std::chrono::steady_clock::now();
    PlanParams p = o->p;
    p.planner = planner_from_string(o->planner);
    p.gippo.mode = o->mode == "max" ? GippoMode::Max : GippoMode::Min;
    p.order = path_order_from_string(o->order);
    p.gippo.progress.report = progress_line;
    Diagnostics diag;
    const Graph g = read_lattice(
        o->input, o->keep_graph ? keep_graph_options() : CleanOptions{o->merge_tolerance, true},
        diag);
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
    if (o->seeds > 0 && p.planner == Planner::Gippo) {
      const GippoRobustness rob = gippo_robustness(g, p.gippo, o->seeds);
      if (!o->seeds_report.empty())
        write_file_atomic(o->seeds_report, gippo_robustness_json(rob, p.gippo));
      std::cout << "gippo robustness over " << o->seeds << " seeds: best score mean "
                << num(rob.mean, 4) << ", SD " << num(rob.sd, 4) << " (CV "
                << num(rob.cv_percent(), 2) << "%), min " << num(rob.min, 4) << ", max "
                << num(rob.max, 4) << "\n";
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
