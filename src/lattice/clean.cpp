// Graph cleaning: merge coincident nodes (spatial hash), split T-junctions (nodes lying on an
// edge's interior), drop self-loops, zero-length and duplicate edges.
#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <unordered_set>

#include "trellis/core/error.hpp"
#include "trellis/lattice/graph.hpp"

namespace trellis {

namespace {

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey&) const = default;
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(k.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return h;
  }
};

// Uniform grid of node ids keyed by cell.
class PointGrid {
 public:
  explicit PointGrid(double cell) : cell_(cell) {}
  CellKey key(Vec3 p) const {
    return {static_cast<std::int64_t>(std::floor(p.x / cell_)),
            static_cast<std::int64_t>(std::floor(p.y / cell_)),
            static_cast<std::int64_t>(std::floor(p.z / cell_))};
  }
  void insert(Vec3 p, NodeId id) { cells_[key(p)].push_back(id); }
  const std::vector<NodeId>* at(const CellKey& k) const {
    auto it = cells_.find(k);
    return it == cells_.end() ? nullptr : &it->second;
  }
  double cell() const { return cell_; }

 private:
  double cell_;
  std::unordered_map<CellKey, std::vector<NodeId>, CellHash> cells_;
};

std::string edge_name(const std::vector<std::string>& where, std::size_t i) {
  return i < where.size() ? where[i] : "edge " + std::to_string(i);
}

// Maps every input node to its representative (first node within tolerance), compacted.
std::vector<NodeId> merge_nodes(const std::vector<Vec3>& nodes, double tol,
                                std::vector<Vec3>& out_nodes, Diagnostics& diag) {
  std::vector<NodeId> map(nodes.size());
  if (tol <= 0) {
    out_nodes = nodes;
    for (NodeId i = 0; i < nodes.size(); ++i) map[i] = i;
    return map;
  }
  PointGrid grid(tol * 4);
  std::size_t merged = 0;
  for (NodeId i = 0; i < nodes.size(); ++i) {
    const Vec3 p = nodes[i];
    const CellKey k = grid.key(p);
    NodeId found = UINT32_MAX;
    for (int dx = -1; dx <= 1 && found == UINT32_MAX; ++dx)
      for (int dy = -1; dy <= 1 && found == UINT32_MAX; ++dy)
        for (int dz = -1; dz <= 1 && found == UINT32_MAX; ++dz) {
          const auto* cell = grid.at({k.x + dx, k.y + dy, k.z + dz});
          if (!cell) continue;
          for (NodeId j : *cell)
            if (distance(out_nodes[j], p) <= tol) {
              found = j;
              break;
            }
        }
    if (found == UINT32_MAX) {
      found = static_cast<NodeId>(out_nodes.size());
      out_nodes.push_back(p);
      grid.insert(p, found);
    } else {
      ++merged;
    }
    map[i] = found;
  }
  if (merged)
    diag.warn("merged_nodes", std::to_string(merged) + " coincident node(s) merged (tolerance " +
                                  std::to_string(tol) + " mm)");
  return map;
}

// Typical edge length, used to size the grid for the T-junction search.
double median_edge_length(const Graph& g) {
  std::vector<double> len;
  const std::size_t step = std::max<std::size_t>(1, g.edges.size() / 1000);
  for (std::size_t i = 0; i < g.edges.size(); i += step) len.push_back(g.edge_length(i));
  if (len.empty()) return 1.0;
  std::nth_element(len.begin(), len.begin() + len.size() / 2, len.end());
  return len[len.size() / 2];
}

// For each edge, the interior nodes within `tol` of it, sorted along the edge.
Graph split_t_junctions(const Graph& g, double tol, Diagnostics& diag,
                        const std::vector<std::string>& where,
                        std::vector<std::size_t>& origin_of_edge) {
  // Cells of the typical strut length, but no edge may span more than ~64 cells (bounded work
  // for lattices that mix tiny and huge struts).
  double longest = 0;
  for (EdgeId e = 0; e < g.edges.size(); ++e) longest = std::max(longest, g.edge_length(e));
  const double cell = std::max({median_edge_length(g), tol * 8, longest / 64});
  PointGrid grid(cell);
  std::vector<char> used(g.nodes.size(), 0);
  for (const auto& e : g.edges) used[e.a] = used[e.b] = 1;
  for (NodeId i = 0; i < g.nodes.size(); ++i)
    if (used[i]) grid.insert(g.nodes[i], i);

  Graph out;
  out.nodes = g.nodes;
  std::vector<std::size_t> new_origin;
  std::vector<std::pair<double, NodeId>> hits;
  std::unordered_set<CellKey, CellHash> seen;
  for (EdgeId ei = 0; ei < g.edges.size(); ++ei) {
    const Edge& e = g.edges[ei];
    const Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
    const double len = distance(a, b);
    hits.clear();
    seen.clear();
    const int steps = static_cast<int>(std::ceil(len / (cell * 0.5))) + 1;
    for (int s = 0; s <= steps; ++s) {
      const Vec3 p = a + (b - a) * (static_cast<double>(s) / steps);
      const CellKey k = grid.key(p);
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const CellKey c{k.x + dx, k.y + dy, k.z + dz};
            if (!seen.insert(c).second) continue;
            const auto* nodes = grid.at(c);
            if (!nodes) continue;
            for (NodeId n : *nodes) {
              if (n == e.a || n == e.b) continue;
              double t = 0;
              if (distance_to_segment(g.nodes[n], a, b, &t) <= tol && t > 0 && t < 1 &&
                  distance(g.nodes[n], a) > tol && distance(g.nodes[n], b) > tol)
                hits.emplace_back(t, n);
            }
          }
    }
    if (hits.empty()) {
      out.edges.push_back(e);
      new_origin.push_back(origin_of_edge[ei]);
      continue;
    }
    std::sort(hits.begin(), hits.end());
    diag.warn("t_junction_split", edge_name(where, origin_of_edge[ei]) + ": split at " +
                                      std::to_string(hits.size()) + " node(s) lying on it");
    NodeId prev = e.a;
    for (const auto& [t, n] : hits) {
      out.edges.push_back({prev, n, e.material, e.directed, e.radius});
      new_origin.push_back(origin_of_edge[ei]);
      prev = n;
    }
    out.edges.push_back({prev, e.b, e.material, e.directed, e.radius});
    new_origin.push_back(origin_of_edge[ei]);
  }
  origin_of_edge = std::move(new_origin);
  return out;
}

}  // namespace

Graph clean_graph(const Graph& input, const CleanOptions& options, Diagnostics& diag,
                  const std::vector<std::string>& where) {
  if (!std::isfinite(options.merge_tolerance) || options.merge_tolerance < 0 ||
      options.merge_tolerance > 1)
    throw GeometryError("merge tolerance must be between 0 and 1 mm");
  for (std::size_t i = 0; i < input.nodes.size(); ++i) {
    const Vec3 p = input.nodes[i];
    if (!is_finite(p) || std::abs(p.x) > kMaxCoordinate || std::abs(p.y) > kMaxCoordinate ||
        std::abs(p.z) > kMaxCoordinate)
      throw GeometryError("coordinate beyond ±1e6 mm", {"", 0, "node " + std::to_string(i)});
  }
  for (std::size_t i = 0; i < input.edges.size(); ++i)
    if (input.edges[i].a >= input.nodes.size() || input.edges[i].b >= input.nodes.size())
      throw GeometryError("node index out of range", {"", 0, edge_name(where, i)});
  Graph g;
  if (!options.merge_nodes) {
    std::vector<Vec3> merged;
    Diagnostics quiet;
    merge_nodes(input.nodes, std::max(options.merge_tolerance, 1e-9), merged, quiet);
    if (merged.size() < input.nodes.size())
      diag.warn("coincident_nodes_kept",
                std::to_string(input.nodes.size() - merged.size()) +
                    " node(s) lie on another node but are kept apart (node merging is off): "
                    "struts meeting there are not joined");
  }
  const auto map =
      merge_nodes(input.nodes, options.merge_nodes ? options.merge_tolerance : 0.0, g.nodes, diag);
  std::vector<std::size_t> origin;
  g.edges.reserve(input.edges.size());
  for (std::size_t i = 0; i < input.edges.size(); ++i) {
    Edge e = input.edges[i];
    e.a = map[e.a];
    e.b = map[e.b];
    if (e.a == e.b) {
      const bool zero = input.edges[i].a != input.edges[i].b;
      diag.warn(
          zero ? "zero_length_edge" : "self_loop",
          edge_name(where, i) + (zero ? ": zero-length edge dropped" : ": self-loop dropped"));
      continue;
    }
    g.edges.push_back(e);
    origin.push_back(i);
  }
  if (options.split_t_junctions && !g.edges.empty())
    g = split_t_junctions(g, std::max(options.merge_tolerance, 1e-9), diag, where, origin);

  Graph out;
  out.nodes = std::move(g.nodes);
  std::unordered_map<std::uint64_t, std::size_t> seen;
  seen.reserve(g.edges.size() * 2);
  for (std::size_t i = 0; i < g.edges.size(); ++i) {
    const Edge& e = g.edges[i];
    const std::uint64_t key =
        (static_cast<std::uint64_t>(std::min(e.a, e.b)) << 32) | std::max(e.a, e.b);
    auto [it, fresh] = seen.emplace(key, origin[i]);
    if (!fresh) {
      diag.warn("duplicate_edge", edge_name(where, origin[i]) + ": duplicate of " +
                                      edge_name(where, it->second) + ", dropped");
      continue;
    }
    out.edges.push_back(e);
  }
  return out;
}

}  // namespace trellis
