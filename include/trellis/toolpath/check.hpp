// The rules every path of the IR keeps, checked in one place for every reader that builds paths
// from outside data (the JSON reader, the Python package's Toolpath.from_arrays): at least two
// points, coordinates finite within ±1e6 mm, no negative tool, width, height, speed, power,
// filament, temperature, flow or mixture fraction, a fan of at most 100 %. Each reader names the
// offending element its own way, so the check says what and where in the path, not the file.
#pragma once
#include <cstddef>
#include <optional>
#include <string>

#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct PathProblem {
  std::string attribute;  // "points", "via", "mixture", "width", "tool", ...
  std::size_t index = 0;  // the point or mixture entry, for points, via and mixture
  std::string message;    // "is not finite or beyond ±1e6", "must be >= 0", ...
};

// The first rule `path` breaks, or nothing.
std::optional<PathProblem> path_problem(const Path& path);

}  // namespace trellis
