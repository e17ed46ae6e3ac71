#include <gtest/gtest.h>

#include "trellis/lattice/graph.hpp"

using namespace trellis;

TEST(Clean, MergesCoincidentNodesWithinTolerance) {
  Graph g;
  g.nodes = {{0, 0, 0}, {1, 0, 0}, {1 + 5e-7, 0, 0}, {2, 0, 0}};
  g.edges = {{0, 1}, {2, 3}};
  Diagnostics d;
  const Graph c = clean_graph(g, {1e-6, true}, d);
  EXPECT_EQ(c.nodes.size(), 3u);
  EXPECT_EQ(c.edges[1].a, 1u);
  EXPECT_EQ(d.count("merged_nodes"), 1u);
  Diagnostics d2;
  EXPECT_EQ(clean_graph(g, {1e-9, true}, d2).nodes.size(), 4u);
}

TEST(Clean, DropsSelfLoopsZeroLengthAndDuplicatesWithWarnings) {
  Graph g;
  g.nodes = {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  g.edges = {{0, 1}, {1, 0}, {0, 0}, {1, 2}, {0, 3}};
  Diagnostics d;
  const Graph c = clean_graph(g, {}, d, {"e0", "e1", "e2", "e3", "e4"});
  EXPECT_EQ(c.edges.size(), 2u);
  EXPECT_EQ(d.count("duplicate_edge"), 1u);
  EXPECT_EQ(d.count("self_loop"), 1u);
  EXPECT_EQ(d.count("zero_length_edge"), 1u);
  bool named = false;
  for (const auto& m : d.messages())
    named |= m.text.find("e1: duplicate of e0") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST(Clean, SplitsTJunctionsAndOverlaps) {
  Graph g;
  // A long edge 0-1 with nodes 2 and 3 lying on it; a short edge 0-2 overlapping its start.
  g.nodes = {{0, 0, 0}, {10, 0, 0}, {4, 0, 0}, {7, 0, 0}, {4, 3, 0}};
  g.edges = {{0, 1}, {2, 4}, {3, 4}, {0, 2}};
  Diagnostics d;
  const Graph c = clean_graph(g, {}, d);
  // 0-2, 2-3, 3-1 from the split; 0-2 again is a duplicate.
  EXPECT_EQ(c.edges.size(), 5u);
  EXPECT_EQ(d.count("t_junction_split"), 1u);
  EXPECT_EQ(d.count("duplicate_edge"), 1u);
  EXPECT_NEAR(c.total_length(), 10 + 3 + std::hypot(3, 3), 1e-12);
}

TEST(Graph, LowerBoundPerComponent) {
  Graph g;
  // Component 1: a triangle (no odd nodes) -> 1. Component 2: a star with 3 leaves (4 odd) -> 2.
  g.nodes = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 0},
             {6, 5, 0}, {5, 6, 0}, {4, 5, 0}, {9, 9, 0}};
  g.edges = {{0, 1}, {1, 2}, {2, 0}, {3, 4}, {3, 5}, {3, 6}};
  EXPECT_EQ(lower_bound_paths(g), 3u);
  int n = 0;
  const auto comp = connected_components(g, &n);
  EXPECT_EQ(n, 2);
  EXPECT_EQ(comp[7], -1);
}
