// Minimum trail covers of mixed graphs (see euler.hpp).
#include <algorithm>
#include <numeric>

#include "trellis/plan/euler.hpp"

namespace trellis {

namespace {
constexpr std::uint32_t kNone = UINT32_MAX;
}

struct MixedEuler::Local {
  std::vector<NodeId> global;  // local node -> global node (kNone for the stub node)
  std::vector<std::uint32_t> tail, head;
  std::vector<char> is_free;
  std::vector<EdgeId> gedge;  // global edge id, kNone for the stub
  std::vector<int> bal;       // out - in
  std::uint32_t stub_node = kNone;
};

MixedEuler::MixedEuler(std::size_t node_count) : local_(node_count, 0), stamp_(node_count, 0) {}

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
    L.stub_node = static_cast<std::uint32_t>(L.global.size());
    L.global.push_back(kNone);
    L.bal.push_back(1);
    L.tail.push_back(L.stub_node);
    L.head.push_back(local_[continue_from]);
    L.is_free.push_back(0);
    L.gedge.push_back(kNone);
    --L.bal[local_[continue_from]];
  }
  // Augmenting paths over free struts: reverse a directed run from a surplus node to a deficit
  // node whenever that lowers Σ|bal|.
  const std::size_t n = L.global.size(), me = L.tail.size();
  std::vector<std::uint32_t> off(n + 1, 0), inc;
  for (std::size_t e = 0; e < me; ++e)
    if (L.is_free[e]) {
      ++off[L.tail[e] + 1];
      ++off[L.head[e] + 1];
    }
  for (std::size_t i = 1; i <= n; ++i) off[i] += off[i - 1];
  inc.resize(off[n]);
  {
    std::vector<std::uint32_t> fill(off.begin(), off.end() - 1);
    for (std::size_t e = 0; e < me; ++e)
      if (L.is_free[e]) {
        inc[fill[L.tail[e]]++] = static_cast<std::uint32_t>(e);
        inc[fill[L.head[e]]++] = static_cast<std::uint32_t>(e);
      }
  }
  std::vector<std::uint32_t> parent(n), queue;
  std::vector<std::uint32_t> seen(n, 0);
  std::uint32_t round = 0;
  auto augment = [&](int need_s, int need_t) {
    ++round;
    queue.clear();
    for (std::uint32_t v = 0; v < n; ++v)
      if (L.bal[v] >= need_s) {
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
        if (L.bal[w] <= -need_t) {
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
  for (;;) {
    if (augment(2, 1)) continue;
    if (augment(1, 2)) continue;
    break;
  }
}

std::size_t MixedEuler::lower_bound(const Graph& g, const std::vector<EdgeId>& edges,
                                    const std::vector<std::int8_t>& dir) {
  if (edges.empty()) return 0;
  Local L;
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
                                         const std::vector<std::int8_t>& dir,
                                         NodeId continue_from, bool* continued) {
  if (continued) *continued = false;
  std::vector<Trail> out;
  if (edges.empty()) return out;
  Local L;
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
  std::vector<std::uint32_t> off(n + 2, 0), out_edges(me);
  for (std::size_t e = 0; e < me; ++e) ++off[L.tail[e] + 1];
  for (std::size_t i = 1; i <= n + 1; ++i) off[i] += off[i - 1];
  {
    std::vector<std::uint32_t> fill(off.begin(), off.end() - 1);
    for (std::size_t e = 0; e < me; ++e) out_edges[fill[L.tail[e]]++] = static_cast<std::uint32_t>(e);
  }
  std::vector<std::uint32_t> cursor(off.begin(), off.end() - 1);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> stack, circuit;
  Trail current;
  bool current_is_stub = false;
  auto flush = [&] {
    if (!current.edges.empty()) {
      if (current_is_stub) {
        out.insert(out.begin(), std::move(current));
        if (continued) *continued = true;
      } else {
        out.push_back(std::move(current));
      }
    }
    current = Trail{};
    current_is_stub = false;
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
      if (v == L.stub_node) {
        current_is_stub = true;
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
