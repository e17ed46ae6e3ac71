// Generated inputs for property tests: random planar graphs (jittered grid, random subset of
// grid edges and one diagonal per cell, so no two struts cross) and random general graphs.
#pragma once
#include <set>

#include "trellis/core/rng.hpp"
#include "trellis/lattice/graph.hpp"

namespace trellis::test {

inline Graph random_planar_graph(std::uint64_t seed, int nx = 8, int ny = 8, double keep = 0.75) {
  Rng rng(seed);
  Graph g;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      g.nodes.push_back(
          {i * 1.0 + 0.3 * (rng.uniform01() - 0.5), j * 1.0 + 0.3 * (rng.uniform01() - 0.5), 0});
  auto id = [&](int i, int j) { return static_cast<NodeId>(j * nx + i); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      if (i + 1 < nx && rng.uniform01() < keep) g.edges.push_back({id(i, j), id(i + 1, j)});
      if (j + 1 < ny && rng.uniform01() < keep) g.edges.push_back({id(i, j), id(i, j + 1)});
      if (i + 1 < nx && j + 1 < ny && rng.uniform01() < keep * 0.6) {
        if (rng.uniform01() < 0.5)
          g.edges.push_back({id(i, j), id(i + 1, j + 1)});
        else
          g.edges.push_back({id(i + 1, j), id(i, j + 1)});
      }
    }
  if (g.edges.empty()) g.edges.push_back({0, 1});
  return g;
}

// Random simple graph (no self-loops or duplicate edges) on n nodes in 3D.
inline Graph random_graph(std::uint64_t seed, int n, int m) {
  Rng rng(seed);
  Graph g;
  for (int i = 0; i < n; ++i) g.nodes.push_back({rng.uniform01() * 10, rng.uniform01() * 10, 0});
  std::set<std::pair<NodeId, NodeId>> seen;
  for (int k = 0; k < m * 4 && static_cast<int>(g.edges.size()) < m; ++k) {
    auto a = static_cast<NodeId>(rng.uniform_index(n)),
         b = static_cast<NodeId>(rng.uniform_index(n));
    if (a == b || !seen.insert({std::min(a, b), std::max(a, b)}).second) continue;
    g.edges.push_back({a, b});
  }
  return g;
}

// Random 3D strut lattice: a jittered n×n×n grid (spacing 5 mm, jitter ±`jitter` mm) with a
// random subset of its axis struts and face diagonals (vertical, inclined and horizontal struts).
inline Graph random_lattice3d(std::uint64_t seed, int n = 4, double keep = 0.6,
                              double jitter = 0.3) {
  Rng rng(seed);
  Graph g;
  auto id = [&](int i, int j, int k) { return static_cast<NodeId>((k * n + j) * n + i); };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        g.nodes.push_back({i * 5.0 + jitter * (2 * rng.uniform01() - 1),
                           j * 5.0 + jitter * (2 * rng.uniform01() - 1),
                           k * 5.0 + jitter * (2 * rng.uniform01() - 1)});
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        if (i + 1 < n && rng.uniform01() < keep) g.edges.push_back({id(i, j, k), id(i + 1, j, k)});
        if (j + 1 < n && rng.uniform01() < keep) g.edges.push_back({id(i, j, k), id(i, j + 1, k)});
        if (k + 1 < n && rng.uniform01() < keep) g.edges.push_back({id(i, j, k), id(i, j, k + 1)});
        if (i + 1 < n && k + 1 < n && rng.uniform01() < keep * 0.5)
          g.edges.push_back({id(i, j, k), id(i + 1, j, k + 1)});
        if (j + 1 < n && k + 1 < n && rng.uniform01() < keep * 0.5)
          g.edges.push_back({id(i, j + 1, k), id(i, j, k + 1)});
      }
  if (g.edges.empty()) g.edges.push_back({0, 1});
  return g;
}

// A dense random strut lattice: nodes on an n x n x n grid of pitch 2 mm, each moved up to
// ±0.3 mm per axis, and each pair of nodes 1.6-3.8 mm apart joined with probability `keep`
// (axis, face- and body-diagonal neighbours): the kind of stochastic lattice whose obstruction
// relation has many cycles.
inline Graph dense_lattice3d(std::uint64_t seed, int n = 5, double keep = 0.47) {
  Rng rng(seed);
  Graph g;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        g.nodes.push_back({2.0 * i + 0.3 * (2 * rng.uniform01() - 1),
                           2.0 * j + 0.3 * (2 * rng.uniform01() - 1),
                           2.0 * k + 0.3 * (2 * rng.uniform01() - 1)});
  for (NodeId a = 0; a < g.nodes.size(); ++a)
    for (NodeId b = a + 1; b < g.nodes.size(); ++b) {
      const double d = distance(g.nodes[a], g.nodes[b]);
      if (d >= 1.6 && d <= 3.8 && rng.uniform01() < keep) g.edges.push_back({a, b});
    }
  if (g.edges.empty()) g.edges.push_back({0, 1});
  return g;
}

// The same lattice listed in another order: node i becomes (i * step + shift) mod n, struts in
// reverse order and each reversed (step coprime with the node count).
inline Graph relisted(const Graph& g, std::size_t step, std::size_t shift) {
  Graph h;
  const std::size_t n = g.nodes.size();
  std::vector<NodeId> perm(n);
  for (NodeId i = 0; i < n; ++i) perm[i] = static_cast<NodeId>((i * step + shift) % n);
  h.nodes.resize(n);
  for (NodeId i = 0; i < n; ++i) h.nodes[perm[i]] = g.nodes[i];
  for (std::size_t k = g.edges.size(); k-- > 0;)
    h.edges.push_back({perm[g.edges[k].b], perm[g.edges[k].a]});
  return h;
}

}  // namespace trellis::test
