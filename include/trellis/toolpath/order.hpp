// Print order by travel, shared by every planner and slicer: a greedy nearest neighbour from a
// start point, then 2-opt, over items that each have a start and an end and may be printed
// either way (lattice trails, fill chains, islands of a layer).
#pragma once
#include <cstddef>
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis {

struct OrderItem {
  Vec3 start, end;
  bool reversible = true;  // may be printed from `end` to `start`
};

struct OrderStep {
  std::size_t item = 0;
  bool reversed = false;  // printed from its end to its start
};

// Every item once. Nearest neighbour: the next item is the one with an end nearest the last
// end (ties: the lower index, its start before its end), found through a grid of the ends, so
// thousands of items cost about linear time; then 2-opt on the sequence (reversing a run also
// reverses each item in it, so only when every item in the run is reversible), windowed to 64
// items beyond 2,000 items, at most 20 passes.
std::vector<OrderStep> order_by_travel(const std::vector<OrderItem>& items, Vec3 from);

// Straight travel from `from` through the items in that order.
double order_travel(const std::vector<OrderItem>& items, const std::vector<OrderStep>& order,
                    Vec3 from);

}  // namespace trellis
