#include "trellis/plan/order.hpp"

#include <algorithm>
#include <numeric>

#include "trellis/core/error.hpp"

namespace trellis {

PathOrder path_order_from_string(const std::string& name) {
  if (name == "longest-first") return PathOrder::LongestFirst;
  if (name == "travel") return PathOrder::Travel;
  throw SettingError("unknown path order '" + name + "' (expected longest-first or travel)");
}

std::string to_string(PathOrder order) {
  return order == PathOrder::LongestFirst ? "longest-first" : "travel";
}

double travel_length(const Graph& g, const PathSet& set) {
  double len = 0;
  for (std::size_t i = 1; i < set.trails.size(); ++i)
    len += distance(g.nodes[set.trails[i - 1].nodes.back()], g.nodes[set.trails[i].nodes.front()]);
  return len;
}

namespace {

void longest_first(PathSet& set) {
  std::stable_sort(set.trails.begin(), set.trails.end(), [](const Trail& a, const Trail& b) {
    if (a.edges.size() != b.edges.size()) return a.edges.size() > b.edges.size();
    return a.length > b.length;
  });
}

// Greedy nearest neighbour over trail ends (either end may start a trail), O(n²).
void nearest_neighbour(const Graph& g, PathSet& set, Vec3 start) {
  const std::size_t n = set.trails.size();
  std::vector<Trail> out;
  out.reserve(n);
  std::vector<char> taken(n, 0);
  Vec3 at = start;
  for (std::size_t step = 0; step < n; ++step) {
    double best = 1e300;
    std::size_t bi = 0;
    bool reverse = false;
    for (std::size_t i = 0; i < n; ++i) {
      if (taken[i]) continue;
      const Trail& t = set.trails[i];
      const double d0 = distance(at, g.nodes[t.nodes.front()]);
      const double d1 = distance(at, g.nodes[t.nodes.back()]);
      if (d0 < best) {
        best = d0;
        bi = i;
        reverse = false;
      }
      if (d1 < best) {
        best = d1;
        bi = i;
        reverse = true;
      }
    }
    taken[bi] = 1;
    out.push_back(std::move(set.trails[bi]));
    if (reverse) out.back().reverse();
    at = g.nodes[out.back().nodes.back()];
  }
  set.trails = std::move(out);
}

// 2-opt on the trail sequence: reversing a run of trails also reverses each trail in it.
// Windowed for long sequences so it stays near-linear.
void two_opt(const Graph& g, PathSet& set, Vec3 start) {
  const std::size_t n = set.trails.size();
  if (n < 3) return;
  auto s = [&](std::size_t i) { return g.nodes[set.trails[i].nodes.front()]; };
  auto e = [&](std::size_t i) { return g.nodes[set.trails[i].nodes.back()]; };
  const std::size_t window = n > 2000 ? 64 : n;
  for (int pass = 0; pass < 20; ++pass) {
    bool improved = false;
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const Vec3 before = i == 0 ? start : e(i - 1);
      for (std::size_t j = i + 1; j < n && j - i <= window; ++j) {
        double old_cost = distance(before, s(i));
        double new_cost = distance(before, e(j));
        if (j + 1 < n) {
          old_cost += distance(e(j), s(j + 1));
          new_cost += distance(s(i), s(j + 1));
        }
        if (new_cost < old_cost - 1e-9) {
          std::reverse(set.trails.begin() + i, set.trails.begin() + j + 1);
          for (std::size_t k = i; k <= j; ++k) set.trails[k].reverse();
          improved = true;
        }
      }
    }
    if (!improved) break;
  }
}

}  // namespace

void order_paths(const Graph& g, PathSet& set, PathOrder order, Vec3 start) {
  if (order == PathOrder::LongestFirst) {
    longest_first(set);
  } else {
    nearest_neighbour(g, set, start);
    two_opt(g, set, start);
  }
}

}  // namespace trellis
