// A strut lattice as an undirected graph embedded in 3D: nodes are points (mm), edges are struts.
// Edges may carry a material index, a `directed` flag (print only from a to b) and a radius.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/vec.hpp"

namespace trellis {

using NodeId = std::uint32_t;
using EdgeId = std::uint32_t;

struct Edge {
  NodeId a = 0, b = 0;
  int material = 0;
  bool directed = false;
  double radius = 0;  // strut radius (mm) where the input gives one (3MF beams), 0 = not given
  NodeId other(NodeId n) const { return n == a ? b : a; }
};

struct Graph {
  std::vector<Vec3> nodes;
  std::vector<Edge> edges;

  double edge_length(EdgeId e) const { return distance(nodes[edges[e].a], nodes[edges[e].b]); }
  double total_length() const;
  BBox3 bbox() const;  // of nodes that have at least one edge
};

// Compressed incidence lists: for node n, edge ids incident_[offsets_[n] .. offsets_[n+1]).
class Adjacency {
 public:
  explicit Adjacency(const Graph& g);
  std::size_t degree(NodeId n) const { return offsets_[n + 1] - offsets_[n]; }
  const EdgeId* begin(NodeId n) const { return incident_.data() + offsets_[n]; }
  const EdgeId* end(NodeId n) const { return incident_.data() + offsets_[n + 1]; }
  std::size_t node_count() const { return offsets_.size() - 1; }

 private:
  std::vector<std::uint32_t> offsets_;
  std::vector<EdgeId> incident_;
};

// Connected components over edges: component id per node (-1 for nodes without edges).
std::vector<int> connected_components(const Graph& g, int* count = nullptr);

// Lower bound on the number of trails that cover every edge once: per component with edges,
// max(1, odd-degree nodes / 2); summed.
std::size_t lower_bound_paths(const Graph& g);

// Coordinates beyond ±1 km are rejected as input errors (they also overflow spatial grids).
inline constexpr double kMaxCoordinate = 1e6;

// The lattice as solid walls for other slicers: every strut a box of `width` x `height` (from
// its z upward), every node a 16-sided prism of diameter `width`, as overlapping closed shells
// (slicers take their union).
struct TriangleMesh;
TriangleMesh lattice_walls(const Graph& g, double width, double height);
// Its memory and time (core/budget.hpp): 12 triangles a strut and 60 a node.
struct Estimate;
Estimate lattice_walls_estimate(const Graph& g);

struct CleanOptions {
  double merge_tolerance = 1e-6;  // nodes closer than this (mm) become one
  bool split_t_junctions = true;  // a node lying on another edge splits that edge
  // false: nodes stay as listed, even where they coincide (counted as a warning); a segment
  // list (which has no node ids) still joins ends at identical coordinates. With
  // split_t_junctions = false too, an indexed lattice keeps exactly its nodes and struts (only
  // self-loops and duplicates, which cannot be printed as such, are dropped, with warnings).
  bool merge_nodes = true;
};

// Both off: the lattice exactly as given (`--keep-graph`).
inline CleanOptions keep_graph_options() {
  return {1e-6, false, false};
}

// Merges coincident nodes (throws GeometryError for coordinates beyond kMaxCoordinate or a
// tolerance that is negative or not finite), splits T-junctions, drops self-loops, zero-length and
// duplicate edges; each drop or split is counted in `diag`. `edge_where` (optional, parallel to
// edges) names where each input edge came from, for the warnings. Node order of first occurrence is
// kept; nodes merged into an earlier one disappear.
Graph clean_graph(const Graph& input, const CleanOptions& options, Diagnostics& diag,
                  const std::vector<std::string>& edge_where = {});

}  // namespace trellis
