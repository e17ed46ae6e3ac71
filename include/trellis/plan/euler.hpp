// Euler planner: the minimum number of trails, max(1, odd/2) per connected component, by
// Hierholzer's algorithm in O(E): a virtual hub joined to every odd node makes all degrees even;
// the Euler circuit through the hub, cut at the hub, gives one trail per pair of odd nodes;
// components without odd nodes give one closed trail each.
#pragma once
#include "trellis/plan/paths.hpp"

namespace trellis {

PathSet plan_euler(const Graph& g);

}  // namespace trellis
