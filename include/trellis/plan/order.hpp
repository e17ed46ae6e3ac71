// Print order of trails: `longest-first` (GIPPO paper: by edge count, then length) or `travel`
// (nearest neighbour from a start point, then 2-opt; trails may be reversed).
#pragma once
#include <string>

#include "trellis/plan/paths.hpp"

namespace trellis {

enum class PathOrder { LongestFirst, Travel };

PathOrder path_order_from_string(const std::string& name);  // throws SettingError
std::string to_string(PathOrder order);

void order_paths(const Graph& g, PathSet& set, PathOrder order, Vec3 start);

// Sum of the straight travel distances between consecutive trails (end to next start).
double travel_length(const Graph& g, const PathSet& set);

}  // namespace trellis
