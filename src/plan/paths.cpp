#include "trellis/plan/paths.hpp"

#include <algorithm>
#include <map>
#include <string>

namespace trellis {

void Trail::reverse() {
  std::reverse(nodes.begin(), nodes.end());
  std::reverse(edges.begin(), edges.end());
}

std::size_t merge_shared_ends(PathSet& set) {
  std::size_t joins = 0;
  for (bool changed = true; changed;) {
    changed = false;
    // End node -> trails ending there (closed trails, both ends at one node, are spliced below).
    std::map<NodeId, std::vector<std::size_t>> ends;
    for (std::size_t i = 0; i < set.trails.size(); ++i) {
      const Trail& t = set.trails[i];
      if (t.nodes.size() < 2 || t.nodes.front() == t.nodes.back()) continue;
      ends[t.nodes.front()].push_back(i);
      ends[t.nodes.back()].push_back(i);
    }
    std::vector<bool> gone(set.trails.size(), false), touched(set.trails.size(), false);
    for (const auto& [node, list] : ends) {
      // Pair the trails ending here, two at a time; each trail joins once per round.
      std::vector<std::size_t> free;
      for (std::size_t i : list)
        if (!touched[i]) free.push_back(i);
      for (std::size_t k = 0; k + 1 < free.size(); k += 2) {
        Trail& a = set.trails[free[k]];
        Trail& b = set.trails[free[k + 1]];
        if (a.nodes.back() != node) a.reverse();
        if (b.nodes.front() != node) b.reverse();
        a.nodes.insert(a.nodes.end(), b.nodes.begin() + 1, b.nodes.end());
        a.edges.insert(a.edges.end(), b.edges.begin(), b.edges.end());
        a.length += b.length;
        touched[free[k]] = touched[free[k + 1]] = true;
        gone[free[k + 1]] = true;
        ++joins;
        changed = true;
      }
    }
    // A closed trail through a node that another trail visits is spliced into that trail at
    // the node: one trail fewer (a trail may pass a node again).
    std::map<NodeId, std::size_t> visits;  // node -> an open trail, not joined this round
    for (std::size_t i = 0; i < set.trails.size(); ++i) {
      const Trail& t = set.trails[i];
      if (gone[i] || touched[i] || t.nodes.size() < 2 || t.nodes.front() == t.nodes.back())
        continue;
      for (NodeId n : t.nodes) visits.try_emplace(n, i);
    }
    for (std::size_t i = 0; i < set.trails.size(); ++i) {
      Trail& c = set.trails[i];
      if (gone[i] || c.nodes.size() < 2 || c.nodes.front() != c.nodes.back()) continue;
      for (std::size_t k = 0; k + 1 < c.nodes.size(); ++k) {
        const auto it = visits.find(c.nodes[k]);
        if (it == visits.end() || touched[it->second]) continue;
        Trail& host = set.trails[it->second];
        // Rotate the loop to start at its k-th node, then insert it where the host visits it.
        std::vector<NodeId> loop(c.nodes.begin() + static_cast<long>(k), c.nodes.end() - 1);
        loop.insert(loop.end(), c.nodes.begin(), c.nodes.begin() + static_cast<long>(k) + 1);
        std::vector<EdgeId> loop_edges(c.edges.begin() + static_cast<long>(k), c.edges.end());
        loop_edges.insert(loop_edges.end(), c.edges.begin(),
                          c.edges.begin() + static_cast<long>(k));
        const auto at = static_cast<long>(
            std::find(host.nodes.begin(), host.nodes.end(), c.nodes[k]) - host.nodes.begin());
        host.nodes.insert(host.nodes.begin() + at + 1, loop.begin() + 1, loop.end());
        host.edges.insert(host.edges.begin() + at, loop_edges.begin(), loop_edges.end());
        host.length += c.length;
        touched[it->second] = true;
        gone[i] = true;
        ++joins;
        changed = true;
        break;
      }
    }
    std::vector<Trail> kept;
    kept.reserve(set.trails.size());
    for (std::size_t i = 0; i < set.trails.size(); ++i)
      if (!gone[i]) kept.push_back(std::move(set.trails[i]));
    set.trails = std::move(kept);
  }
  return joins;
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
