// Euler planner: the minimum number of trails, max(1, odd/2) per connected component, by
// Hierholzer's algorithm in O(E): a virtual hub joined to every odd node makes all degrees even;
// the Euler circuit through the hub, cut at the hub, gives one trail per pair of odd nodes;
// components without odd nodes give one closed trail each.
#pragma once
#include <cstdint>
#include <memory>

#include "trellis/plan/paths.hpp"

namespace trellis {

PathSet plan_euler(const Graph& g);

}  // namespace trellis

namespace trellis {

// Minimum trail covers of mixed graphs (some struts one-way), used by the AERO planner on the
// strut subsets it may print at a time. Hand-written: no graph library here handles mixed
// graphs. The free struts are oriented to minimise Σ|out - in| (augmenting paths reverse runs of
// free struts from a node with surplus to one with deficit; optimal for this separable convex
// cost), then a virtual hub balances every node and Hierholzer's algorithm on the directed
// graph gives max(1, Σ surplus) trails per weakly connected component — the lower bound.
class MixedEuler {
 public:
  static constexpr NodeId kNoNode = UINT32_MAX;

  explicit MixedEuler(std::size_t node_count);
  ~MixedEuler();
  MixedEuler(MixedEuler&&) noexcept;

  // Trails covering `edges` exactly once; `dir[e]` for a global edge id: 0 either way, +1 only
  // a→b, -1 only b→a. If `continue_from` is a node, the decomposition is made as if a trail
  // already arrived there (a virtual lead-in edge), so one trail may continue it at no cost: if so
  // it is returned first (starting at continue_from) and *continued is set.
  std::vector<Trail> decompose(const Graph& g, const std::vector<EdgeId>& edges,
                               const std::vector<std::int8_t>& dir, NodeId continue_from = kNoNode,
                               bool* continued = nullptr);

  // The minimum number of trails covering `edges` (Σ over components of max(1, surplus)).
  std::size_t lower_bound(const Graph& g, const std::vector<EdgeId>& edges,
                          const std::vector<std::int8_t>& dir);

 private:
  struct Local;
  void build(const Graph& g, const std::vector<EdgeId>& edges, const std::vector<std::int8_t>& dir,
             NodeId continue_from, Local& L);

  std::vector<std::uint32_t> local_, stamp_;
  std::uint32_t tick_ = 0;
  std::unique_ptr<Local> scratch_;
};

}  // namespace trellis
