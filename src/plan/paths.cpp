#include "trellis/plan/paths.hpp"

#include <algorithm>
#include <string>

namespace trellis {

void Trail::reverse() {
  std::reverse(nodes.begin(), nodes.end());
  std::reverse(edges.begin(), edges.end());
}

double PathSet::total_length() const {
  double len = 0;
  for (const auto& t : trails) len += t.length;
  return len;
}

std::size_t PathSet::total_edges() const {
  std::size_t n = 0;
  for (const auto& t : trails) n += t.edges.size();
  return n;
}

double gippo_score(const PathSet& set) {
  const double total = set.total_length();
  if (set.trails.empty() || total <= 0) return 0;
  double sum = 0;
  for (const auto& t : set.trails) sum += t.length * static_cast<double>(t.edges.size());
  return sum / (total * static_cast<double>(set.trails.size()));
}

PathMetrics path_metrics(const Graph& g, const PathSet& set, std::size_t long_nodes) {
  PathMetrics m;
  m.paths = set.trails.size();
  m.lower_bound_paths = lower_bound_paths(g);
  m.score = gippo_score(set);
  m.total_length = set.total_length();
  m.total_edges = set.total_edges();
  double long_len = 0, long_weighted = 0;
  for (const auto& t : set.trails) {
    const std::size_t nodes = t.edges.size() + 1;
    if (nodes >= long_nodes) {
      long_len += t.length;
      long_weighted += t.length * static_cast<double>(t.edges.size());
    }
    if (nodes > 15)
      ++m.long_paths;
    else if (nodes >= 5)
      ++m.medium_paths;
    else
      ++m.short_paths;
  }
  if (m.total_length > 0) {
    m.lts = 100 * long_len / m.total_length;
    if (m.total_edges > 0)
      m.oe = 100 * long_weighted / (m.total_length * static_cast<double>(m.total_edges));
  }
  return m;
}

std::string validate_paths(const Graph& g, const PathSet& set) {
  std::vector<int> count(g.edges.size(), 0);
  for (std::size_t ti = 0; ti < set.trails.size(); ++ti) {
    const Trail& t = set.trails[ti];
    const std::string at = "trail " + std::to_string(ti) + ": ";
    if (t.edges.empty()) return at + "no edges";
    if (t.nodes.size() != t.edges.size() + 1) return at + "node/edge count mismatch";
    for (std::size_t i = 0; i < t.edges.size(); ++i) {
      const EdgeId e = t.edges[i];
      if (e >= g.edges.size()) return at + "edge id out of range";
      const Edge& ed = g.edges[e];
      const bool ok = (ed.a == t.nodes[i] && ed.b == t.nodes[i + 1]) ||
                      (ed.b == t.nodes[i] && ed.a == t.nodes[i + 1]);
      if (!ok) return at + "edge " + std::to_string(e) + " does not join its nodes";
      ++count[e];
    }
  }
  for (std::size_t e = 0; e < count.size(); ++e)
    if (count[e] != 1)
      return "edge " + std::to_string(e) + " covered " + std::to_string(count[e]) + " times";
  return {};
}

}  // namespace trellis
