// AERO: collision-free Eulerian print paths for 3D strut lattices (embedded printing; paper
// "aero-embedded-lattices-eulerian"). The nozzle model (lattice/collision.hpp) gives a
// precedence: a strut that would obstruct the nozzle while another is printed must wait for it.
//
// Method `periodic` is the paper's semi-manual baseline (plan/periodic.hpp). Method `groups` is
// the paper's AERO: peel groups of valid struts (a strut is valid if printing it
// now leaves every remaining strut printable), decompose each group into the fewest trails
// (Hierholzer on the mixed graph: steep struts are one-way, bottom-up), concatenate. Method
// `dynamic` (default) is the paper's proposed "dynamic refresh": the printable set is refreshed
// after every trail, and the next decomposition is made as if the current trail were still
// open at its end node, so a trail runs on through later groups whenever the struts allow.
// Both order trails by nearest start (trails reversed where no strut is one-way) and keep
// materials in separate trails.
//
// Fewest collisions (default): before planning, the obstruction relation's cycles are broken
// where it costs the fewest collisions (plan/collision_order.hpp: exact per strongly connected
// part where the integer program finishes, local search beyond), and the planner runs on what
// is left, which has no cycle. Without it (the greedy of earlier versions) the planner, when no
// strut is printable, prints the remaining strut that obstructs the fewest. Either way the
// result counts the collisions of the order it returns, with a lower bound for any order.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/run_context.hpp"
#include "trellis/lattice/collision.hpp"
#include "trellis/plan/collision_order.hpp"
#include "trellis/plan/paths.hpp"
#include "trellis/plan/periodic.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// Periodic is not AERO but the paper's semi-manual baseline (plan/periodic.hpp), counted and
// checked the same way so the two compare.
enum class AeroMethod { Dynamic, Groups, Periodic };
AeroMethod aero_method_from_string(const std::string& name);  // throws SettingError
std::string to_string(AeroMethod m);

// The tries of a dynamic plan left at auto: 8, fewer above 25,000 struts (200,000 / struts, at
// least 1) to bound the time.
std::size_t aero_auto_tries(std::size_t struts);

struct AeroParams {
  NozzleModel nozzle;
  bool collisions = true;  // false: no precedence at all, trails = the Euler lower bound
  AeroMethod method = AeroMethod::Dynamic;
  PeriodicParams periodic;  // method periodic: the lattice's cell and the cell path
  // Dynamic: planner runs in the portfolio (the strategies, then shuffled orders); 0 = auto
  // (aero_auto_tries).
  int tries = 0;
  std::uint64_t seed = 1;  // for the shuffled runs: same seed, same plan
  // Break the obstruction cycles where it costs the fewest collisions before planning (exact
  // where possible); false = the greedy (print the strut obstructing the fewest when stuck).
  bool fewest_collisions = true;
  CollisionOrderParams order;  // the exact solver's and local search's budgets
};

struct AeroViolation {
  EdgeId edge = 0;
  std::size_t obstructs = 0;  // remaining struts it obstructs when printed
};

struct AeroResult {
  PathSet trails;                   // in print order, each trail as printed
  std::vector<int> trail_material;  // per trail
  std::size_t groups = 0;           // the paper's peel groups
  std::vector<std::size_t> group_sizes;
  std::size_t lower_bound_trails = 0;  // without collisions (mixed-graph Euler bound)
  std::size_t travel_moves = 0;
  double travel_length = 0;  // straight end-to-start distances (mm)
  std::size_t max_trail_edges = 0;
  std::size_t steep_struts = 0;  // printed bottom-up by the cone rule
  std::size_t blocking_relations = 0, pairs_tested = 0;
  std::size_t decompositions = 0;
  std::size_t insertions = 0;
  std::size_t merges = 0;  // trails moved onto another trail after planning  // trails placed into
                           // the past (joined to an earlier trail)
  std::size_t runs = 1;    // planner runs tried
  std::string strategy;    // the trail-selection strategy that won (see aero.cpp)
  std::vector<AeroViolation> violations;   // struts printed before struts they obstruct
  std::size_t collisions_planned = 0;      // collisions of the returned order (nozzle model)
  std::size_t collisions_lower_bound = 0;  // no order of these struts has fewer
  bool collisions_proven_minimal() const { return collisions_planned == collisions_lower_bound; }
  std::vector<CollisionPart> collision_parts;  // strongly connected parts, largest first
  std::size_t mutual_pairs = 0;  // pairs of struts obstructing each other: a lower bound on
                                 // the collisions of any order
  double seconds_blocking = 0, seconds_order = 0, seconds_planning = 0;
};

// Throws GeometryError for a lattice without edges, SettingError for bad nozzle settings.
// `context` (core/run_context.hpp): progress ("collision model", "tries"), cancel, threads.
AeroResult plan_aero(const Graph& g, const AeroParams& params, Diagnostics& diag,
                     const RunContext& context = {});

// One travel-free path per trail (nozzle tip on the strut axis), tool = material, in one layer.
Toolpath aero_toolpath(const Graph& g, const AeroResult& result, const std::string& source);

}  // namespace trellis
