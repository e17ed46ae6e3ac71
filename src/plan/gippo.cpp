#include "trellis/plan/gippo.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>

#include "trellis/core/error.hpp"
#include "trellis/core/rng.hpp"

namespace trellis {

namespace {

// Incident edges of every node, sorted best-first for the mode: by length (descending for max,
// ascending for min), then by edge id. The first unused entry is a node's best candidate, so a
// per-node cursor that only moves forward finds it in amortised O(1).
struct SortedAdjacency {
  // One slot per (node, incident edge), sorted per node; the far node and the length sit beside
  // the edge id so growing a trail never touches the graph's edge array (fewer cache misses).
  struct Slot {
    EdgeId edge;
    NodeId other;
    double length;
    std::int64_t key;  // length in nm, rounded: the value compared
  };
  std::vector<std::uint32_t> offsets;
  std::vector<Slot> slots;

  SortedAdjacency(const Graph& g, GippoMode mode) : offsets(g.nodes.size() + 1, 0) {
    Adjacency adj(g);
    slots.reserve(2 * g.edges.size());
    for (NodeId n = 0; n < g.nodes.size(); ++n) {
      offsets[n] = static_cast<std::uint32_t>(slots.size());
      for (const EdgeId* e = adj.begin(n); e != adj.end(n); ++e)
        slots.push_back(
            {*e, g.edges[*e].other(n), g.edge_length(*e), gippo_length_key(g.edge_length(*e))});
      auto better = [&](const Slot& x, const Slot& y) {
        if (x.key != y.key) return mode == GippoMode::Max ? x.key > y.key : x.key < y.key;
        return x.edge < y.edge;
      };
      std::sort(slots.begin() + offsets[n], slots.end(), better);
    }
    offsets[g.nodes.size()] = static_cast<std::uint32_t>(slots.size());
  }
};

// The incomplete nodes as a bitset in 64-node words, with a Fenwick tree over the words' counts:
// select the r-th incomplete node (ascending id) and remove one, each in O(log(n/64)).
class IncompleteSet {
 public:
  void reset(const std::vector<std::uint32_t>& remaining) {
    const std::size_t words = (remaining.size() + 63) / 64;
    bits_.assign(words, 0);
    tree_.assign(words + 1, 0);
    count_ = 0;
    for (std::size_t v = 0; v < remaining.size(); ++v)
      if (remaining[v] > 0) bits_[v / 64] |= std::uint64_t{1} << (v % 64);
    for (std::size_t w = 1; w <= words; ++w) {
      const int c = std::popcount(bits_[w - 1]);
      count_ += c;
      tree_[w] += c;
      const std::size_t j = w + (w & (~w + 1));
      if (j <= words) tree_[j] += tree_[w];
    }
    top_ = 1;
    while (top_ * 2 <= words) top_ *= 2;
  }
  void remove(NodeId node) {
    --count_;
    bits_[node / 64] &= ~(std::uint64_t{1} << (node % 64));
    for (std::size_t i = node / 64 + 1; i < tree_.size(); i += i & (~i + 1)) --tree_[i];
  }
  std::size_t count() const { return count_; }
  NodeId select(std::size_t r) const {  // 0-based rank
    std::size_t pos = 0;
    const std::size_t words = bits_.size();
    for (std::size_t step = top_; step > 0; step /= 2)
      if (pos + step <= words && static_cast<std::size_t>(tree_[pos + step]) <= r) {
        pos += step;
        r -= tree_[pos];
      }
    // The answer is bit number r (0-based) among the set bits of word `pos`.
    std::uint64_t w = bits_[pos];
    for (int shift = 0; shift < 64; shift += 8) {
      const auto c = static_cast<std::size_t>(std::popcount((w >> shift) & 0xFF));
      if (r < c) {
        w >>= shift;
        for (int k = 0;; ++k, w >>= 1)
          if ((w & 1) && r-- == 0) return static_cast<NodeId>(pos * 64 + shift + k);
      }
      r -= c;
    }
    return static_cast<NodeId>(pos * 64);  // unreachable for r < count()
  }

 private:
  std::size_t count_ = 0, top_ = 1;
  std::vector<std::uint64_t> bits_;
  std::vector<int> tree_;
};

// A solution as flat arrays: trail i has nodes [node_off[i], node_off[i+1]) and edges
// [node_off[i] - i, node_off[i+1] - i - 1).
struct FlatSolution {
  std::vector<NodeId> nodes;
  std::vector<EdgeId> edges;
  std::vector<std::uint32_t> node_off{0};
  std::vector<double> length;
  double score = -1;
  std::size_t iteration = 0;

  void clear() {
    nodes.clear();
    edges.clear();
    node_off.assign(1, 0);
    length.clear();
  }
  PathSet to_paths() const {
    PathSet set;
    set.trails.resize(length.size());
    for (std::size_t i = 0; i < length.size(); ++i) {
      Trail& t = set.trails[i];
      t.nodes.assign(nodes.begin() + node_off[i], nodes.begin() + node_off[i + 1]);
      t.edges.assign(edges.begin() + (node_off[i] - i), edges.begin() + (node_off[i + 1] - i - 1));
      t.length = length[i];
    }
    return set;
  }
};

class Iteration {
 public:
  Iteration(const Graph& g, const SortedAdjacency& adj) : g_(g), adj_(adj) {
    const std::size_t e = g.edges.size();
    buf_nodes_.resize(2 * e + 3);
    buf_edges_.resize(2 * e + 3);
  }

  // Fills `out` with the solution of iteration k; returns its score (Eq. 1).
  double run(GippoMode mode, std::uint64_t seed, std::uint64_t k, double total_length,
             FlatSolution& out) {
    Rng rng = Rng::stream(seed, k);
    const std::size_t n = g_.nodes.size();
    used_.assign(g_.edges.size(), 0);
    cursor_.assign(adj_.offsets.begin(), adj_.offsets.end() - 1);
    remaining_.resize(n);
    for (NodeId v = 0; v < n; ++v) remaining_[v] = adj_.offsets[v + 1] - adj_.offsets[v];
    incomplete_.reset(remaining_);
    out.clear();
    double weighted = 0;
    const std::size_t mid = g_.edges.size() + 1;
    while (incomplete_.count() > 0) {
      const NodeId start = incomplete_.select(rng.uniform_index(incomplete_.count()));
      std::size_t f = mid, b = mid;  // nodes in [f, b], edges in [f, b)
      buf_nodes_[mid] = start;
      double len = 0;
      while (true) {
        const NodeId vf = buf_nodes_[f], vb = buf_nodes_[b];
        const Slot* sf = best(vf);
        const Slot* sb = best(vb);
        if (!sf && !sb) break;
        // The best length over both ends, then every unused edge of that length at the front
        // (in edge-id order) and at the back (same, skipping the front's): one of them at random.
        std::int64_t key = sf ? sf->key : sb->key;
        if (sf && sb)
          key = mode == GippoMode::Max ? std::max(sf->key, sb->key) : std::min(sf->key, sb->key);
        ties_.clear();
        if (sf && sf->key == key) collect_ties(vf, key, false);
        if (sb && sb->key == key && vb != vf) collect_ties(vb, key, true);
        const auto& [slot, back] =
            ties_.size() == 1 ? ties_[0] : ties_[rng.uniform_index(ties_.size())];
        const Slot& s = *slot;
        take(s.edge, back ? vb : vf, s.other);
        len += s.length;
        if (back) {
          buf_edges_[b] = s.edge;
          buf_nodes_[++b] = s.other;
        } else {
          buf_nodes_[--f] = s.other;
          buf_edges_[f] = s.edge;
        }
      }
      out.nodes.insert(out.nodes.end(), buf_nodes_.begin() + f, buf_nodes_.begin() + b + 1);
      out.edges.insert(out.edges.end(), buf_edges_.begin() + f, buf_edges_.begin() + b);
      out.node_off.push_back(static_cast<std::uint32_t>(out.nodes.size()));
      out.length.push_back(len);
      weighted += len * static_cast<double>(b - f);
    }
    const double paths = static_cast<double>(out.length.size());
    out.score = paths > 0 && total_length > 0 ? weighted / (total_length * paths) : 0;
    out.iteration = k;
    return out.score;
  }

 private:
  using Slot = SortedAdjacency::Slot;

  // The best unused edge at v, or nullptr.
  const Slot* best(NodeId v) {
    std::uint32_t& c = cursor_[v];
    const std::uint32_t end = adj_.offsets[v + 1];
    while (c < end && used_[adj_.slots[c].edge]) ++c;
    return c < end ? &adj_.slots[c] : nullptr;
  }

  // Appends the unused slots of v with this key (they follow the cursor, in edge-id order). At
  // the back end, an edge already listed from the front (it joins the two ends) is skipped.
  void collect_ties(NodeId v, std::int64_t key, bool back) {
    const std::uint32_t end = adj_.offsets[v + 1];
    const std::size_t front_count = ties_.size();
    for (std::uint32_t c = cursor_[v]; c < end && adj_.slots[c].key == key; ++c) {
      const Slot& s = adj_.slots[c];
      if (used_[s.edge]) continue;
      bool dup = false;
      if (back)
        for (std::size_t t = 0; t < front_count; ++t) dup |= ties_[t].first->edge == s.edge;
      if (!dup) ties_.emplace_back(&s, back);
    }
  }

  void take(EdgeId e, NodeId a, NodeId b) {
    used_[e] = 1;
    if (--remaining_[a] == 0) incomplete_.remove(a);
    if (--remaining_[b] == 0) incomplete_.remove(b);
  }

  const Graph& g_;
  const SortedAdjacency& adj_;
  std::vector<char> used_;
  std::vector<std::uint32_t> cursor_, remaining_;
  std::vector<std::pair<const Slot*, bool>> ties_;  // candidate slot, taken at the back end
  IncompleteSet incomplete_;
  std::vector<NodeId> buf_nodes_;
  std::vector<EdgeId> buf_edges_;
};

void check_graph(const Graph& g) {
  if (g.edges.empty()) throw GeometryError("the lattice has no edges to plan");
  for (EdgeId e = 0; e < g.edges.size(); ++e)
    if (g.edges[e].a == g.edges[e].b)
      throw GeometryError("edge " + std::to_string(e) + " is a self-loop (clean the graph first)");
}

bool better(double score, std::size_t k, const FlatSolution& than) {
  return score > than.score || (score == than.score && k < than.iteration);
}
bool worse(double score, std::size_t k, const FlatSolution& than) {
  return than.score < 0 || score < than.score || (score == than.score && k < than.iteration);
}

}  // namespace

PathSet gippo_iteration(const Graph& g, GippoMode mode, std::uint64_t seed, std::uint64_t k) {
  check_graph(g);
  SortedAdjacency adj(g, mode);
  Iteration it(g, adj);
  FlatSolution sol;
  it.run(mode, seed, k, g.total_length(), sol);
  return sol.to_paths();
}

GippoResult plan_gippo(const Graph& g, const GippoParams& params, const RunContext& context) {
  check_graph(g);
  if (params.iterations < 1) throw SettingError("iterations must be >= 1");
  const SortedAdjacency adj(g, params.mode);
  const double total = g.total_length();
  const auto n = static_cast<std::size_t>(params.iterations);
  GippoResult result;
  result.scores.assign(n, 0);

  struct Local {
    std::unique_ptr<Iteration> it;
    FlatSolution current, best, worst;
  };
  tbb::enumerable_thread_specific<Local> locals;
  std::atomic<std::size_t> done{0};
  std::atomic<bool> cancelled{false};
  tbb::task_arena arena(context.threads > 0 ? context.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), [&](const auto& range) {
      Local& L = locals.local();
      if (!L.it) L.it = std::make_unique<Iteration>(g, adj);
      for (std::size_t k = range.begin(); k != range.end(); ++k) {
        if (context.cancelled()) {
          cancelled = true;
          return;
        }
        const double s = L.it->run(params.mode, params.seed, k, total, L.current);
        result.scores[k] = s;
        const bool is_worst = worse(s, k, L.worst);
        if (is_worst) L.worst = L.current;
        if (better(s, k, L.best)) std::swap(L.best, L.current);
        const std::size_t d = ++done;
        if (d % std::max<std::size_t>(1, n / 50) == 0) context.report("gippo", double(d) / n);
      }
    });
  });
  if (cancelled) throw Cancelled("GIPPO planning cancelled");
  const FlatSolution* best = nullptr;
  const FlatSolution* worst = nullptr;
  for (const auto& L : locals) {
    if (L.best.score >= 0 && (!best || better(L.best.score, L.best.iteration, *best)))
      best = &L.best;
    if (L.worst.score >= 0 && (!worst || worse(L.worst.score, L.worst.iteration, *worst)))
      worst = &L.worst;
  }
  assert(best && worst);
  result.best = best->to_paths();
  result.best_iteration = best->iteration;
  result.worst = worst->to_paths();
  result.worst_iteration = worst->iteration;
  return result;
}

GippoRobustness gippo_robustness(const Graph& g, const GippoParams& params, int seeds,
                                 std::size_t long_nodes, const RunContext& context) {
  if (seeds < 1) throw SettingError("the robustness run needs at least one seed");
  GippoRobustness r;
  for (int k = 0; k < seeds; ++k) {
    if (context.cancelled()) throw Error("GIPPO robustness run cancelled");
    GippoParams p = params;
    p.seed = params.seed + static_cast<std::uint64_t>(k);
    Progress quiet;  // cancellation only: the seeds report progress
    quiet.cancel = context.progress.cancel;
    const GippoResult one = plan_gippo(g, p, context.with_progress(quiet));
    r.seeds.push_back(p.seed);
    r.best_scores.push_back(one.scores.empty() ? 0.0 : one.scores[one.best_iteration]);
    r.worst_scores.push_back(one.scores.empty() ? 0.0 : one.scores[one.worst_iteration]);
    r.best_lts.push_back(path_metrics(g, one.best, long_nodes).lts);
    r.worst_lts.push_back(path_metrics(g, one.worst, long_nodes).lts);
    context.report("seeds", static_cast<double>(k + 1) / seeds);
  }
  const auto n = static_cast<double>(seeds);
  double sum = 0;
  for (double v : r.best_scores) sum += v;
  r.mean = sum / n;
  double ss = 0;
  for (double v : r.best_scores) ss += (v - r.mean) * (v - r.mean);
  r.sd = seeds > 1 ? std::sqrt(ss / (n - 1)) : 0.0;
  r.min = *std::min_element(r.best_scores.begin(), r.best_scores.end());
  r.max = *std::max_element(r.best_scores.begin(), r.best_scores.end());
  return r;
}

}  // namespace trellis
