// A planned set of trails over a graph: each trail is a node sequence walking edges, every edge
// of the graph in exactly one trail. Shared by every graph planner and by the metrics.
#pragma once
#include <vector>

#include "trellis/lattice/graph.hpp"

namespace trellis {

struct Trail {
  std::vector<NodeId> nodes;  // nodes.size() == edges.size() + 1
  std::vector<EdgeId> edges;  // edges[i] joins nodes[i] and nodes[i+1]
  double length = 0;          // mm
  std::size_t edge_count() const { return edges.size(); }
  void reverse();
};

struct PathSet {
  std::vector<Trail> trails;
  double total_length() const;
  std::size_t total_edges() const;
};

// GIPPO metrics (paper Eq. 1-3) and counts. A trail with n nodes (n = edges + 1) is long for
// LTS/OE if n >= long_nodes; the size classes are long > 15 nodes, medium 5..15, short < 5.
struct PathMetrics {
  std::size_t paths = 0;
  std::size_t lower_bound_paths = 0;
  double score = 0;  // Eq. 1
  double lts = 0;    // Eq. 2, percent
  double oe = 0;     // Eq. 3, percent
  double total_length = 0;
  std::size_t total_edges = 0;
  std::size_t long_paths = 0, medium_paths = 0, short_paths = 0;
};

double gippo_score(const PathSet& set);  // Eq. 1
PathMetrics path_metrics(const Graph& g, const PathSet& set, std::size_t long_nodes = 5);

// Joins trails that end at the same node into one trail, and splices each closed trail (both
// ends at one node) into an open trail that visits one of its nodes (a trail may pass a node
// again, so the result is still a trail), until neither applies. Returns how many joins were
// made (the path count falls by that much). Deterministic: nodes in increasing order, trails
// by index.
std::size_t merge_shared_ends(PathSet& set);

// Every edge covered exactly once, consecutive nodes joined by the listed edge. Returns an empty
// string if valid, else what is wrong (used by tests and as a debug assertion).
std::string validate_paths(const Graph& g, const PathSet& set);

}  // namespace trellis
