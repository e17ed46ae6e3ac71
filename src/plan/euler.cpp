#include "trellis/plan/euler.hpp"

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

// Incidence lists over the real edges plus virtual edges hub-odd node (ids >= real count).
struct EulerGraph {
  std::vector<NodeId> ea, eb;  // endpoints per edge (real, then virtual)
  std::vector<std::uint32_t> offsets;
  std::vector<EdgeId> incident;

  EulerGraph(const Graph& g, NodeId hub) {
    const std::size_t n = g.nodes.size() + 1;
    ea.reserve(g.edges.size() * 2);
    for (const auto& e : g.edges) {
      ea.push_back(e.a);
      eb.push_back(e.b);
    }
    std::vector<std::uint32_t> degree(n, 0);
    for (const auto& e : g.edges) {
      ++degree[e.a];
      ++degree[e.b];
    }
    for (NodeId v = 0; v < g.nodes.size(); ++v)
      if (degree[v] % 2 == 1) {
        ea.push_back(hub);
        eb.push_back(v);
      }
    offsets.assign(n + 1, 0);
    for (std::size_t e = 0; e < ea.size(); ++e) {
      ++offsets[ea[e] + 1];
      ++offsets[eb[e] + 1];
    }
    for (std::size_t i = 1; i <= n; ++i) offsets[i] += offsets[i - 1];
    incident.resize(offsets[n]);
    std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (std::size_t e = 0; e < ea.size(); ++e) {
      incident[fill[ea[e]]++] = static_cast<EdgeId>(e);
      incident[fill[eb[e]]++] = static_cast<EdgeId>(e);
    }
  }
};

}  // namespace

PathSet plan_euler(const Graph& g) {
  if (g.edges.empty()) throw GeometryError("the lattice has no edges to plan");
  const auto hub = static_cast<NodeId>(g.nodes.size());
  const EulerGraph eg(g, hub);
  const std::size_t real = g.edges.size();
  std::vector<char> used(eg.ea.size(), 0);
  std::vector<std::uint32_t> cursor(eg.offsets.begin(), eg.offsets.end() - 1);
  std::vector<std::pair<NodeId, EdgeId>> stack;  // (node, edge used to reach it)
  std::vector<std::pair<NodeId, EdgeId>> circuit;
  PathSet set;
  constexpr EdgeId kNone = UINT32_MAX;

  // Turns a closed walk (reversed Hierholzer output) into trails cut at the hub.
  auto emit = [&](const std::vector<std::pair<NodeId, EdgeId>>& walk) {
    Trail t;
    for (std::size_t i = 0; i < walk.size(); ++i) {
      const auto [v, e_in] = walk[i];
      if (v == hub) {
        if (!t.edges.empty()) set.trails.push_back(std::move(t));
        t = Trail{};
        continue;
      }
      if (e_in != kNone && e_in < real) {
        t.edges.push_back(e_in);
        t.length += g.edge_length(e_in);
      }
      t.nodes.push_back(v);
    }
    if (!t.edges.empty()) set.trails.push_back(std::move(t));
  };

  auto walk_from = [&](NodeId start) {
    stack.clear();
    circuit.clear();
    stack.push_back({start, kNone});
    while (!stack.empty()) {
      const NodeId v = stack.back().first;
      std::uint32_t& c = cursor[v];
      while (c < eg.offsets[v + 1] && used[eg.incident[c]]) ++c;
      if (c < eg.offsets[v + 1]) {
        const EdgeId e = eg.incident[c];
        used[e] = 1;
        stack.push_back({eg.ea[e] == v ? eg.eb[e] : eg.ea[e], e});
      } else {
        circuit.push_back(stack.back());
        stack.pop_back();
      }
    }
    // Popped nodes form the circuit backwards; the edge joining popped entries i+1 and i is
    // the one stored with entry i, so read in reverse each entry carries its incoming edge.
    std::vector<std::pair<NodeId, EdgeId>> forward(circuit.rbegin(), circuit.rend());
    emit(forward);
  };

  if (eg.ea.size() > real) walk_from(hub);
  for (EdgeId e = 0; e < real; ++e)
    if (!used[e]) walk_from(g.edges[e].a);
  return set;
}

}  // namespace trellis
