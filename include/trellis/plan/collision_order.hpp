// Fewest nozzle collisions: the order of struts that breaks the fewest obstruction relations.
//
// The nozzle model gives, for each strut s, the struts it obstructs if printed before them
// (BlockingGraph::blocks). Read as a precedence digraph (u -> s: u should come before s), a print
// order's collisions are exactly its backward arcs, so the fewest collisions is a minimum
// feedback arc set. Arcs between strongly connected parts never need breaking, so each part is
// solved on its own:
//  - an upper bound from a greedy order (Eades-Lin-Smyth) improved by insertion local search
//    (each strut moved to its best place, repeated; a few shuffled restarts);
//  - a lower bound from a packing of arc-disjoint cycles (each costs one collision);
//  - parts up to `exact_max_struts`: an integer program over the arcs (GLPK, branch and cut)
//    with one "break at least one arc" row per cycle, cycles added lazily until the solution
//    leaves no cycle, which proves it minimal. Each solve is bounded by a node count (not a
//    clock) so the result is the same on every machine.
#pragma once
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "trellis/lattice/collision.hpp"

namespace trellis {

struct CollisionOrderParams {
  // Parts (strongly connected sets of struts) up to this many struts and relations get the
  // exact integer program; larger ones only the local search and the bounds. 0 = never exact.
  std::size_t exact_max_struts = 1500;
  std::size_t exact_max_relations = 60000;
  // Branch-and-bound nodes per integer-program solve; a solve that needs more leaves the part
  // unproven (deterministic work bound instead of a time limit).
  std::size_t exact_node_limit = 20000;
  // Rounds of adding violated cycles to the integer program before giving up on a part.
  int exact_rounds = 60;
  // Local-search restarts from shuffled orders per part, besides the greedy start.
  int restarts = 2;
  std::uint64_t seed = 1;  // for the restarts
  // Arcs the cycle-packing lower bound may scan per part (work bound; a smaller packing is a
  // weaker but still valid bound).
  std::size_t packing_budget = 200'000'000;
};

struct CollisionPart {
  std::size_t struts = 0, relations = 0;  // inside the part
  std::size_t planned = 0;                // relations the chosen order breaks
  std::size_t lower_bound = 0;            // no order breaks fewer
  bool exact = false;                     // the integer program ran to the end
  bool proven() const { return planned == lower_bound; }
};

struct CollisionOrder {
  std::vector<CollisionPart> parts;  // non-trivial parts only (2+ struts), largest first
  // Relations (s, u), u in blocks[s], that the chosen order breaks: s printed before u.
  std::vector<std::pair<EdgeId, EdgeId>> broken;
  std::size_t planned = 0, lower_bound = 0;
  bool proven() const { return planned == lower_bound; }
};

// `height` (optional, per strut) seeds one more local search with a bottom-up order.
CollisionOrder fewest_collisions(const BlockingGraph& blocking, const CollisionOrderParams& params,
                                 const std::vector<double>& height = {});

// The blocking graph without the given relations (s, u): what a planner must respect once
// those collisions are accepted.
BlockingGraph without_relations(const BlockingGraph& blocking,
                                const std::vector<std::pair<EdgeId, EdgeId>>& dropped);

// Collisions of a print order: relations (s, u) with s printed before u. `rank[e]` is strut e's
// place in the order.
std::size_t count_collisions(const BlockingGraph& blocking, const std::vector<std::size_t>& rank);

}  // namespace trellis
