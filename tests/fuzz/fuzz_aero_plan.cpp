// Fuzzes the AERO route on parsed lattices: parse_lattice_json → clean → plan_aero (a few runs)
// → the independent checker. Any input either plans (every strut in exactly one trail, the
// checker agreeing that each strut was printed once) or throws trellis::Error; never crashes or
// hangs. Inputs are capped at 400 struts to keep each run short.
#include <cstdlib>
#include <string>

#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/aero.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    const auto in =
        trellis::parse_lattice_json(std::string(reinterpret_cast<const char*>(data), size), "fuzz");
    trellis::Diagnostics diag;
    const trellis::Graph g = trellis::clean_graph(in.graph, {}, diag, in.edge_where);
    if (g.edges.empty() || g.edges.size() > 400) return 0;
    trellis::AeroParams p;
    p.tries = 2;
    trellis::RunContext context;
    context.threads = 1;
    const trellis::AeroResult r = trellis::plan_aero(g, p, diag, context);
    if (!trellis::validate_paths(g, r.trails).empty()) std::abort();
    const auto c = trellis::check_collisions(g, trellis::aero_toolpath(g, r, "fuzz"), {});
    // Struts shorter than the snap distance cannot be told apart by the checker.
    bool tiny = false;
    for (trellis::EdgeId e = 0; e < g.edges.size(); ++e) tiny |= g.edge_length(e) < 0.2;
    if (!tiny && c.printed_once != g.edges.size()) std::abort();
  } catch (const trellis::Error&) {
  }
  return 0;
}
