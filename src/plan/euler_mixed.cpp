// Minimum trail covers of mixed graphs (see euler.hpp).
#include <algorithm>
#include <numeric>

#include "trellis/plan/euler.hpp"

namespace trellis {

namespace {
constexpr std::uint32_t kNone = UINT32_MAX;
}

// Scratch of one decomposition, kept between calls so repeated calls do not allocate.
struct MixedEuler::Local {
  std::vector<NodeId> global;  // local node -> global node (kNone for the lead-in node)
  std::vector<std::uint32_t> tail, head;
  std::vector<char> is_free;
  std::vector<EdgeId> gedge;  // global edge id, kNone for the lead-in edge
  std::vector<int> bal;       // out - in
  std::uint32_t lead_node = kNone;
  // work arrays
  std::vector<std::uint32_t> off, inc, fill, parent, queue, seen, cursor, out_edges;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> stack, circuit;
  std::uint32_t round = 0;

  void clear() {
    global.clear();
    tail.clear();
    head.clear();
    is_free.clear();
    gedge.clear();
    bal.clear();
    lead_node = kNone;
  }
};

MixedEuler::MixedEuler(std::size_t node_count)
    : local_(node_count, 0), stamp_(node_count, 0), scratch_(std::make_unique<Local>()) {}
MixedEuler::~MixedEuler() = default;
MixedEuler::MixedEuler(MixedEuler&&) noexcept = default;

void MixedEuler::build(const Graph& g, const std::vector<EdgeId>& edges,
                       const std::vector<std::int8_t>& dir, NodeId continue_from, Local& L) {
  if (++tick_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    tick_ = 1;
  }
  auto local = [&](NodeId v) {
    if (stamp_[v] != tick_) {
      stamp_[v] = tick_;
      local_[v] = static_cast<std::uint32_t>(L.global.size());
      L.global.push_back(v);
      L.bal.push_back(0);
    }
    return local_[v];
  };
  const std::size_t m = edges.size();
  L.tail.reserve(m + 1);
  L.head.reserve(m + 1);
  L.is_free.reserve(m + 1);
  L.gedge.reserve(m + 1);
  // Fixed struts first so the greedy orientation of free ones sees their balance.
  for (int pass = 0; pass < 2; ++pass)
    for (EdgeId e : edges) {
      const bool fixed = dir[e] != 0;
      if (fixed != (pass == 0)) continue;
      const std::uint32_t a = local(g.edges[e].a), b = local(g.edges[e].b);
      std::uint32_t t = a, h = b;
      if (dir[e] < 0 || (!fixed && L.bal[b] < L.bal[a])) std::swap(t, h);
      L.tail.push_back(t);
      L.head.push_back(h);
      L.is_free.push_back(!fixed);
      L.gedge.push_back(e);
      ++L.bal[t];
      --L.bal[h];
    }
  if (continue_from != kNoNode && continue_from < stamp_.size() && stamp_[continue_from] == tick_) {
    L.lead_node = static_cast<std::uint32_t>(L.global.size());
    L.global.push_back(kNone);
    L.bal.push_back(1);
    L.tail.push_back(L.lead_node);
    L.head.push_back(local_[continue_from]);
    L.is_free.push_back(0);
    L.gedge.push_back(kNone);
    --L.bal[local_[continue_from]];
  }
  // Augmenting paths over free struts: reverse a directed run from a surplus node to a deficit
  // node whenever that lowers Σ|bal|.
  const std::size_t n = L.global.size(), me = L.tail.size();
  auto& off = L.off;
  auto& inc = L.inc;
  off.assign(n + 1, 0);
  for (std::size_t e = 0; e < me; ++e)
    if (L.is_free[e]) {
      ++off[L.tail[e] + 1];
      ++off[L.head[e] + 1];
    }
  for (std::size_t i = 1; i <= n; ++i) off[i] += off[i - 1];
  inc.resize(off[n]);
  {
    auto& fill = L.fill;
    fill.assign(off.begin(), off.end() - 1);
    for (std::size_t e = 0; e < me; ++e)
      if (L.is_free[e]) {
        inc[fill[L.tail[e]]++] = static_cast<std::uint32_t>(e);
        inc[fill[L.head[e]]++] = static_cast<std::uint32_t>(e);
      }
  }
  auto& parent = L.parent;
  auto& queue = L.queue;
  auto& seen = L.seen;
  parent.resize(n);
  if (seen.size() < n) seen.resize(n, 0);
  std::uint32_t& round = L.round;
  // Reverses a run of free struts from a node with bal >= need_s to a node with bal <= -need_t
  // (or to `only` if given).
  auto augment = [&](int need_s, int need_t, std::uint32_t only = kNone) {
    ++round;
    queue.clear();
    for (std::uint32_t v = 0; v < n; ++v)
      if (L.bal[v] >= need_s && v != L.lead_node) {
        queue.push_back(v);
        seen[v] = round;
        parent[v] = kNone;
      }
    for (std::size_t qi = 0; qi < queue.size(); ++qi) {
      const std::uint32_t u = queue[qi];
      for (std::uint32_t k = off[u]; k < off[u + 1]; ++k) {
        const std::uint32_t e = inc[k];
        if (L.tail[e] != u) continue;
        const std::uint32_t w = L.head[e];
        if (seen[w] == round) continue;
        seen[w] = round;
        parent[w] = e;
        if (only == kNone ? L.bal[w] <= -need_t : w == only) {
          std::uint32_t v = w;
          while (parent[v] != kNone) {
            const std::uint32_t pe = parent[v];
            const std::uint32_t from = L.tail[pe];
            std::swap(L.tail[pe], L.head[pe]);
            v = from;
          }
          L.bal[v] -= 2;
          L.bal[w] += 2;
          return true;
        }
        queue.push_back(w);
      }
    }
    return false;
  };
  auto worth = [&](int need_s, int need_t) {
    bool src = false, dst = false;
    for (std::uint32_t v = 0; v < n; ++v) {
      src |= L.bal[v] >= need_s && v != L.lead_node;
      dst |= L.bal[v] <= -need_t;
    }
    return src && dst;
  };
  for (;;) {
    if (worth(2, 1) && augment(2, 1)) continue;
    if (worth(1, 2) && augment(1, 2)) continue;
    break;
  }
  // With a lead-in edge, a trail ending at the continuation node would leave the lead-in trail
  // empty; among the optimal orientations prefer one where the open trail runs on (same Σ|bal|).
  if (L.lead_node != kNone) {
    const std::uint32_t c = local_[continue_from];
    if (L.bal[c] < 0) augment(1, 0, c);
  }
}

std::size_t MixedEuler::lower_bound(const Graph& g, const std::vector<EdgeId>& edges,
                                    const std::vector<std::int8_t>& dir) {
  if (edges.empty()) return 0;
  Local& L = *scratch_;
  L.clear();
  build(g, edges, dir, kNoNode, L);
  const std::size_t n = L.global.size();
  std::vector<std::uint32_t> root(n);
  std::iota(root.begin(), root.end(), 0);
  auto find = [&](std::uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  for (std::size_t e = 0; e < L.tail.size(); ++e) root[find(L.tail[e])] = find(L.head[e]);
  std::vector<std::size_t> surplus(n, 0);
  std::vector<char> has(n, 0);
  for (std::uint32_t v = 0; v < n; ++v) {
    has[find(v)] = 1;
    if (L.bal[v] > 0) surplus[find(v)] += static_cast<std::size_t>(L.bal[v]);
  }
  std::size_t total = 0;
  for (std::uint32_t v = 0; v < n; ++v)
    if (has[v]) total += std::max<std::size_t>(1, surplus[v]);
  return total;
}

std::vector<Trail> MixedEuler::decompose(const Graph& g, const std::vector<EdgeId>& edges,
                                         const std::vector<std::int8_t>& dir, NodeId continue_from,
                                         bool* continued) {
  if (continued) *continued = false;
  std::vector<Trail> out;
  if (edges.empty()) return out;
  Local& L = *scratch_;
  L.clear();
  build(g, edges, dir, continue_from, L);
  const auto n = static_cast<std::uint32_t>(L.global.size());
  const std::uint32_t hub = n;
  for (std::uint32_t v = 0; v < n; ++v) {
    for (int k = 0; k < L.bal[v]; ++k) {  // surplus: a trail starts here
      L.tail.push_back(hub);
      L.head.push_back(v);
      L.gedge.push_back(kNone);
    }
    for (int k = 0; k < -L.bal[v]; ++k) {  // deficit: a trail ends here
      L.tail.push_back(v);
      L.head.push_back(hub);
      L.gedge.push_back(kNone);
    }
  }
  const std::size_t me = L.tail.size();
  auto& off = L.off;
  auto& out_edges = L.out_edges;
  off.assign(n + 2, 0);
  out_edges.resize(me);
  for (std::size_t e = 0; e < me; ++e) ++off[L.tail[e] + 1];
  for (std::size_t i = 1; i <= n + 1; ++i) off[i] += off[i - 1];
  {
    auto& fill = L.fill;
    fill.assign(off.begin(), off.end() - 1);
    for (std::size_t e = 0; e < me; ++e)
      out_edges[fill[L.tail[e]]++] = static_cast<std::uint32_t>(e);
  }
  auto& cursor = L.cursor;
  cursor.assign(off.begin(), off.end() - 1);
  auto& stack = L.stack;
  auto& circuit = L.circuit;
  Trail current;
  bool current_is_lead = false;
  auto flush = [&] {
    if (!current.edges.empty()) {
      if (current_is_lead) {
        out.insert(out.begin(), std::move(current));
        if (continued) *continued = true;
      } else {
        out.push_back(std::move(current));
      }
    }
    current = Trail{};
    current_is_lead = false;
  };
  auto walk = [&](std::uint32_t start) {
    stack.clear();
    circuit.clear();
    stack.push_back({start, kNone});
    while (!stack.empty()) {
      const std::uint32_t v = stack.back().first;
      std::uint32_t& c = cursor[v];
      if (c < off[v + 1]) {
        const std::uint32_t e = out_edges[c++];
        stack.push_back({L.head[e], e});
      } else {
        circuit.push_back(stack.back());
        stack.pop_back();
      }
    }
    for (auto it = circuit.rbegin(); it != circuit.rend(); ++it) {
      const auto [v, e_in] = *it;
      if (v == hub) {
        flush();
        continue;
      }
      if (v == L.lead_node) {
        current_is_lead = true;
        continue;
      }
      if (e_in != kNone && L.gedge[e_in] != kNone) {
        current.edges.push_back(L.gedge[e_in]);
        current.length += g.edge_length(L.gedge[e_in]);
      }
      current.nodes.push_back(L.global[v]);
    }
    flush();
  };
  if (off[hub + 1] > off[hub]) walk(hub);
  for (std::uint32_t v = 0; v < n; ++v)
    if (cursor[v] < off[v + 1]) walk(v);
  return out;
}

}  // namespace trellis
