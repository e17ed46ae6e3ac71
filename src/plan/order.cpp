#include "trellis/plan/order.hpp"

#include <algorithm>
#include <numeric>

#include "trellis/core/error.hpp"
#include "trellis/toolpath/order.hpp"

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

// Nearest neighbour + 2-opt over the trails' end nodes (toolpath/order.hpp, shared with the
// slicers' linking stage); either end may start a trail.
void by_travel(const Graph& g, PathSet& set, Vec3 start) {
  std::vector<OrderItem> items;
  items.reserve(set.trails.size());
  for (const Trail& t : set.trails)
    items.push_back({g.nodes[t.nodes.front()], g.nodes[t.nodes.back()]});
  std::vector<Trail> out;
  out.reserve(set.trails.size());
  for (const OrderStep& s : order_by_travel(items, start)) {
    out.push_back(std::move(set.trails[s.item]));
    if (s.reversed) out.back().reverse();
  }
  set.trails = std::move(out);
}

}  // namespace

void order_paths(const Graph& g, PathSet& set, PathOrder order, Vec3 start) {
  if (order == PathOrder::LongestFirst) {
    longest_first(set);
  } else {
    by_travel(g, set, start);
  }
}

}  // namespace trellis
