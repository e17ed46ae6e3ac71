#include "trellis/plan/collision_order.hpp"

#include <glpk.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <set>

namespace trellis {

namespace {

using Local = std::uint32_t;
constexpr Local kNo = UINT32_MAX;

// One strongly connected part of the precedence digraph in local ids: arc a -> b means strut a
// should be printed before strut b (a is in blocks[b]).
struct Part {
  std::vector<EdgeId> struts;
  std::vector<std::pair<Local, Local>> arcs;
  std::vector<std::vector<std::uint32_t>> out;  // arc ids leaving each vertex
  std::vector<std::vector<std::uint32_t>> in;   // arc ids entering each vertex
};

// Strongly connected components of u -> s (u in blocks[s]), i.e. successors = blocked_by.
// Iterative Tarjan; returns the component of every strut.
std::vector<std::uint32_t> components(const BlockingGraph& b, std::size_t m) {
  std::vector<std::uint32_t> index(m, kNo), low(m, 0), comp(m, kNo);
  std::vector<EdgeId> stack, call;
  std::vector<std::uint32_t> next(m, 0);
  std::vector<char> on(m, 0);
  std::uint32_t counter = 0, ncomp = 0;
  for (EdgeId root = 0; root < m; ++root) {
    if (index[root] != kNo) continue;
    call.push_back(root);
    while (!call.empty()) {
      const EdgeId v = call.back();
      if (index[v] == kNo) {
        index[v] = low[v] = counter++;
        stack.push_back(v);
        on[v] = 1;
      }
      if (next[v] < b.blocked_by.count(v)) {
        const EdgeId w = b.blocked_by.begin(v)[next[v]++];
        if (index[w] == kNo) {
          call.push_back(w);
        } else if (on[w]) {
          low[v] = std::min(low[v], index[w]);
        }
        continue;
      }
      call.pop_back();
      if (!call.empty()) low[call.back()] = std::min(low[call.back()], low[v]);
      if (low[v] == index[v]) {
        EdgeId w;
        do {
          w = stack.back();
          stack.pop_back();
          on[w] = 0;
          comp[w] = ncomp;
        } while (w != v);
        ++ncomp;
      }
    }
  }
  return comp;
}

std::vector<Part> nontrivial_parts(const BlockingGraph& b, std::size_t m) {
  const std::vector<std::uint32_t> comp = components(b, m);
  std::vector<std::uint32_t> size(m, 0);
  for (EdgeId e = 0; e < m; ++e) ++size[comp[e]];
  std::vector<std::uint32_t> part_of(m, kNo);
  std::vector<Part> parts;
  std::vector<Local> local(m, kNo);
  for (EdgeId e = 0; e < m; ++e) {
    if (size[comp[e]] < 2) continue;
    if (part_of[comp[e]] == kNo) {
      part_of[comp[e]] = static_cast<std::uint32_t>(parts.size());
      parts.emplace_back();
    }
    Part& p = parts[part_of[comp[e]]];
    local[e] = static_cast<Local>(p.struts.size());
    p.struts.push_back(e);
  }
  for (Part& p : parts) {
    p.out.resize(p.struts.size());
    p.in.resize(p.struts.size());
    for (Local v = 0; v < p.struts.size(); ++v) {
      const EdgeId s = p.struts[v];
      for (const EdgeId* u = b.blocks.begin(s); u != b.blocks.end(s); ++u) {
        if (comp[*u] != comp[s]) continue;
        const auto id = static_cast<std::uint32_t>(p.arcs.size());
        p.arcs.push_back({local[*u], v});
        p.out[local[*u]].push_back(id);
        p.in[v].push_back(id);
      }
    }
  }
  std::stable_sort(parts.begin(), parts.end(),
                   [](const Part& a, const Part& c) { return a.struts.size() > c.struts.size(); });
  return parts;
}

std::size_t order_cost(const Part& p, const std::vector<Local>& order) {
  std::vector<std::uint32_t> pos(order.size());
  for (std::uint32_t i = 0; i < order.size(); ++i) pos[order[i]] = i;
  std::size_t c = 0;
  for (auto [a, b] : p.arcs) c += pos[a] > pos[b];
  return c;
}

// Eades-Lin-Smyth: sinks to the back, sources to the front, otherwise the vertex with the
// largest out-degree minus in-degree to the front.
std::vector<Local> greedy_order(const Part& p) {
  const std::size_t n = p.struts.size();
  std::vector<int> indeg(n), outdeg(n);
  for (Local v = 0; v < n; ++v) {
    indeg[v] = static_cast<int>(p.in[v].size());
    outdeg[v] = static_cast<int>(p.out[v].size());
  }
  std::vector<char> gone(n, 0);
  std::set<std::pair<int, Local>> by_delta;  // (-(out - in), v)
  for (Local v = 0; v < n; ++v) by_delta.insert({indeg[v] - outdeg[v], v});
  std::vector<Local> front, back, check(n);
  std::iota(check.begin(), check.end(), Local{0});  // vertices that may have become a sink/source
  auto remove = [&](Local v) {
    by_delta.erase({indeg[v] - outdeg[v], v});
    gone[v] = 1;
    for (std::uint32_t a : p.out[v]) {
      const Local w = p.arcs[a].second;
      if (gone[w]) continue;
      by_delta.erase({indeg[w] - outdeg[w], w});
      if (--indeg[w] == 0) check.push_back(w);
      by_delta.insert({indeg[w] - outdeg[w], w});
    }
    for (std::uint32_t a : p.in[v]) {
      const Local w = p.arcs[a].first;
      if (gone[w]) continue;
      by_delta.erase({indeg[w] - outdeg[w], w});
      if (--outdeg[w] == 0) check.push_back(w);
      by_delta.insert({indeg[w] - outdeg[w], w});
    }
  };
  std::reverse(check.begin(), check.end());
  while (!by_delta.empty()) {
    if (!check.empty()) {
      const Local v = check.back();
      check.pop_back();
      if (gone[v]) continue;
      if (outdeg[v] == 0) {
        back.push_back(v);
        remove(v);
      } else if (indeg[v] == 0) {
        front.push_back(v);
        remove(v);
      }
      continue;
    }
    const Local v = by_delta.begin()->second;
    front.push_back(v);
    remove(v);
  }
  front.insert(front.end(), back.rbegin(), back.rend());
  return front;
}

// Insertion local search: each vertex in turn moves to the place in the order where it breaks
// the fewest arcs, until a sweep changes nothing. Returns the cost.
std::size_t sift(const Part& p, std::vector<Local>& order) {
  const std::size_t n = order.size();
  std::vector<std::uint32_t> pos(n);
  for (std::uint32_t i = 0; i < n; ++i) pos[order[i]] = i;
  std::vector<std::pair<std::uint32_t, int>> ev;  // (place without v, +1 out / -1 in)
  for (int sweep = 0; sweep < 200; ++sweep) {
    bool improved = false;
    for (Local v = 0; v < n; ++v) {
      const std::uint32_t p0 = pos[v];
      ev.clear();
      long long in_count = 0;
      for (std::uint32_t a : p.in[v]) {
        const std::uint32_t q = pos[p.arcs[a].first];
        ev.push_back({q < p0 ? q : q - 1, -1});
        ++in_count;
      }
      for (std::uint32_t a : p.out[v]) {
        const std::uint32_t q = pos[p.arcs[a].second];
        ev.push_back({q < p0 ? q : q - 1, +1});
      }
      std::sort(ev.begin(), ev.end());
      // cost(g): v placed before the g-th of the others = in-arcs from places >= g plus
      // out-arcs to places < g. It changes only just after an event place.
      auto cost_at = [&](std::uint32_t g) {
        long long c = 0;
        for (auto [q, s] : ev) c += s < 0 ? (q >= g) : (q < g);
        return c;
      };
      const long long current = cost_at(p0);
      long long c = in_count, best = current;
      std::uint32_t best_g = p0;
      if (c < best) best = c, best_g = 0;
      for (std::size_t i = 0; i < ev.size();) {
        const std::uint32_t q = ev[i].first;
        while (i < ev.size() && ev[i].first == q) c += ev[i++].second;
        if (c < best) best = c, best_g = q + 1;
      }
      if (best >= current) continue;
      improved = true;
      order.erase(order.begin() + p0);
      order.insert(order.begin() + best_g, v);
      const std::uint32_t lo = std::min(p0, best_g), hi = std::max(p0, best_g);
      for (std::uint32_t i = lo; i <= hi; ++i) pos[order[i]] = i;
    }
    if (!improved) break;
  }
  return order_cost(p, order);
}

// Shortest cycle through arc `a` using only arcs with use[arc] set (breadth-first from its head
// back to its tail, at most max_len arcs); empty if none or when `budget` (arcs scanned, counted
// down) runs out. `parent` is scratch of the part's size,
// all kNo between calls.
std::vector<std::uint32_t> shortest_cycle(const Part& p, std::uint32_t a,
                                          const std::vector<char>& use, std::size_t max_len,
                                          std::vector<std::uint32_t>& parent,
                                          std::vector<std::uint32_t>& depth, std::size_t& budget) {
  const auto [tail, head] = p.arcs[a];
  std::vector<Local> queue{head};
  parent[head] = a;
  depth[head] = 1;
  for (std::size_t k = 0; k < queue.size() && parent[tail] == kNo; ++k) {
    const Local v = queue[k];
    if (depth[v] + 1 > max_len) continue;
    if (budget < p.out[v].size()) break;
    budget -= p.out[v].size();
    for (std::uint32_t x : p.out[v]) {
      if (!use[x]) continue;
      const Local w = p.arcs[x].second;
      if (parent[w] != kNo) continue;
      parent[w] = x;
      depth[w] = depth[v] + 1;
      queue.push_back(w);
    }
  }
  std::vector<std::uint32_t> cycle;
  if (parent[tail] != kNo) {
    cycle.push_back(a);
    for (Local v = tail; v != head; v = p.arcs[parent[v]].first) cycle.push_back(parent[v]);
  }
  for (Local v : queue) parent[v] = kNo;
  return cycle;
}

// Arc-disjoint cycles, shortest first: each costs a collision in any order. The search scans at
// most `budget` arcs in all (a smaller packing is still a bound).
std::size_t cycle_packing(const Part& p, std::size_t budget) {
  std::vector<char> use(p.arcs.size(), 1);
  std::vector<std::uint32_t> parent(p.struts.size(), kNo), depth(p.struts.size());
  std::size_t count = 0;
  for (std::size_t max_len : {2, 3, 4, 6, 1 << 30})
    for (std::uint32_t a = 0; a < p.arcs.size(); ++a) {
      if (!use[a]) continue;
      const auto c = shortest_cycle(p, a, use, max_len, parent, depth, budget);
      if (c.empty()) continue;
      for (std::uint32_t x : c) use[x] = 0;
      ++count;
    }
  return count;
}

// A topological order of the part without the arcs marked in `cut` (Kahn); empty if a cycle
// remains.
std::vector<Local> topological(const Part& p, const std::vector<char>& cut) {
  const std::size_t n = p.struts.size();
  std::vector<std::uint32_t> indeg(n, 0);
  for (std::uint32_t a = 0; a < p.arcs.size(); ++a)
    if (!cut[a]) ++indeg[p.arcs[a].second];
  std::vector<Local> order;
  for (Local v = 0; v < n; ++v)
    if (!indeg[v]) order.push_back(v);
  for (std::size_t k = 0; k < order.size(); ++k)
    for (std::uint32_t a : p.out[order[k]])
      if (!cut[a] && --indeg[p.arcs[a].second] == 0) order.push_back(p.arcs[a].second);
  if (order.size() != n) order.clear();
  return order;
}

void stop_after_nodes(glp_tree* tree, void* info) {
  int active = 0, current = 0, total = 0;
  glp_ios_tree_size(tree, &active, &current, &total);
  if (static_cast<std::size_t>(total) > *static_cast<const std::size_t*>(info))
    glp_ios_terminate(tree);
}

// The exact minimum by integer programming with lazily added cycle rows (GLPK: a Debian-packaged
// MIP solver whose C API is small; the cycle rows are ours, the branch and cut is GLPK's).
// GLPK keeps its environment per thread, so planners on different threads do not interfere.
// Tightens `lower` and, when it finds a better order, `order`; returns true if it ran to the end
// (lower == cost).
bool solve_exact(const Part& p, const CollisionOrderParams& params, std::vector<Local>& order,
                 std::size_t& upper, std::size_t& lower) {
  const std::size_t m = p.arcs.size();
  glp_prob* lp = glp_create_prob();
  glp_set_obj_dir(lp, GLP_MIN);
  glp_add_cols(lp, static_cast<int>(m));
  for (std::size_t j = 1; j <= m; ++j) {
    glp_set_col_bnds(lp, static_cast<int>(j), GLP_DB, 0.0, 1.0);
    glp_set_col_kind(lp, static_cast<int>(j), GLP_BV);
    glp_set_obj_coef(lp, static_cast<int>(j), 1.0);
  }
  std::vector<int> ind;
  std::vector<double> val;
  auto add_row = [&](const std::vector<std::uint32_t>& cycle) {
    const int row = glp_add_rows(lp, 1);
    ind.assign(1, 0);
    val.assign(1, 0.0);
    for (std::uint32_t a : cycle) {
      ind.push_back(static_cast<int>(a) + 1);
      val.push_back(1.0);
    }
    glp_set_row_bnds(lp, row, GLP_LO, 1.0, 0.0);
    glp_set_mat_row(lp, row, static_cast<int>(cycle.size()), ind.data(), val.data());
  };
  std::vector<std::uint32_t> parent(p.struts.size(), kNo), depth(p.struts.size());
  // Start: the shortest cycle of up to 4 relations through every arc (longer ones are added as
  // the solutions need them; starting with all of them costs more than it saves).
  std::set<std::vector<std::uint32_t>> seen;
  const std::vector<char> all(m, 1);
  auto add_cycles = [&](const std::vector<char>& use, std::size_t cap, std::size_t max_len) {
    std::size_t added = 0;
    for (std::uint32_t a = 0; a < m && added < cap; ++a) {
      if (!use[a]) continue;
      std::size_t budget = SIZE_MAX;
      auto c = shortest_cycle(p, a, use, max_len, parent, depth, budget);
      if (c.empty()) continue;
      std::vector<std::uint32_t> key = c;
      std::sort(key.begin(), key.end());
      if (!seen.insert(key).second) continue;
      add_row(c);
      ++added;
    }
    return added;
  };
  add_cycles(all, m, 4);
  bool done = false;
  std::size_t node_limit = params.exact_node_limit;
  for (int round = 0; round < params.exact_rounds && !done; ++round) {
    glp_smcp smcp;
    glp_init_smcp(&smcp);
    smcp.msg_lev = GLP_MSG_OFF;
    if (glp_simplex(lp, &smcp) != 0 || glp_get_status(lp) != GLP_OPT) break;
    lower = std::max(lower, static_cast<std::size_t>(std::ceil(glp_get_obj_val(lp) - 1e-6)));
    if (lower >= upper) {
      done = true;
      break;
    }
    glp_iocp iocp;
    glp_init_iocp(&iocp);
    iocp.msg_lev = GLP_MSG_OFF;
    iocp.cb_func = stop_after_nodes;
    iocp.cb_info = &node_limit;
    if (glp_intopt(lp, &iocp) != 0 || glp_mip_status(lp) != GLP_OPT) break;
    // Optimal over the cycles known so far: a lower bound for all of them.
    lower = std::max(lower, static_cast<std::size_t>(std::llround(glp_mip_obj_val(lp))));
    if (lower >= upper) {
      done = true;
      break;
    }
    std::vector<char> cut(m, 0), keep(m, 1);
    for (std::size_t j = 0; j < m; ++j)
      if (glp_mip_col_val(lp, static_cast<int>(j) + 1) > 0.5) cut[j] = 1, keep[j] = 0;
    std::vector<Local> topo = topological(p, cut);
    if (!topo.empty()) {  // breaking these arcs leaves no cycle: optimal
      order = std::move(topo);
      upper = order_cost(p, order);
      lower = upper;
      done = true;
      break;
    }
    if (add_cycles(keep, 300, std::size_t{1} << 30) == 0) break;
  }
  glp_delete_prob(lp);
  return done;
}

}  // namespace

CollisionOrder fewest_collisions(const BlockingGraph& blocking, const CollisionOrderParams& params,
                                 const std::vector<double>& height) {
  CollisionOrder r;
  const std::size_t m = blocking.blocks.offsets.empty() ? 0 : blocking.blocks.offsets.size() - 1;
  std::vector<Part> parts = nontrivial_parts(blocking, m);
  std::mt19937_64 rng(params.seed);
  for (const Part& p : parts) {
    CollisionPart info;
    info.struts = p.struts.size();
    info.relations = p.arcs.size();
    std::vector<Local> order = greedy_order(p);
    std::size_t upper = sift(p, order);
    std::size_t lower = cycle_packing(p, params.packing_budget);
    if (!height.empty() && lower < upper) {  // bottom-up start
      std::vector<Local> o(p.struts.size());
      std::iota(o.begin(), o.end(), Local{0});
      std::stable_sort(o.begin(), o.end(),
                       [&](Local a, Local b) { return height[p.struts[a]] < height[p.struts[b]]; });
      const std::size_t c = sift(p, o);
      if (c < upper) upper = c, order = std::move(o);
    }
    for (int k = 0; k < params.restarts && lower < upper; ++k) {
      std::vector<Local> o(p.struts.size());
      std::iota(o.begin(), o.end(), Local{0});
      std::shuffle(o.begin(), o.end(), rng);
      const std::size_t c = sift(p, o);
      if (c < upper) upper = c, order = std::move(o);
    }
    if (lower < upper && p.struts.size() <= params.exact_max_struts &&
        p.arcs.size() <= params.exact_max_relations)
      info.exact = solve_exact(p, params, order, upper, lower);
    info.planned = upper;
    info.lower_bound = std::min(lower, upper);
    std::vector<std::uint32_t> pos(order.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) pos[order[i]] = i;
    for (auto [a, b] : p.arcs)
      if (pos[a] > pos[b]) r.broken.push_back({p.struts[b], p.struts[a]});
    r.planned += info.planned;
    r.lower_bound += info.lower_bound;
    r.parts.push_back(info);
  }
  std::sort(r.broken.begin(), r.broken.end());
  return r;
}

BlockingGraph without_relations(const BlockingGraph& b,
                                const std::vector<std::pair<EdgeId, EdgeId>>& dropped) {
  const std::size_t m = b.blocks.offsets.empty() ? 0 : b.blocks.offsets.size() - 1;
  BlockingGraph r;
  r.pairs_tested = b.pairs_tested;
  r.blocks.offsets.assign(m + 1, 0);
  std::vector<std::uint32_t> in_count(m + 1, 0);
  for (EdgeId s = 0; s < m; ++s) {
    for (const EdgeId* u = b.blocks.begin(s); u != b.blocks.end(s); ++u) {
      if (std::binary_search(dropped.begin(), dropped.end(), std::make_pair(s, *u))) continue;
      r.blocks.items.push_back(*u);
      ++in_count[*u + 1];
    }
    r.blocks.offsets[s + 1] = static_cast<std::uint32_t>(r.blocks.items.size());
  }
  for (std::size_t i = 0; i < m; ++i) in_count[i + 1] += in_count[i];
  r.blocked_by.offsets = in_count;
  r.blocked_by.items.resize(r.blocks.items.size());
  std::vector<std::uint32_t> fill(in_count.begin(), in_count.end() - 1);
  for (EdgeId s = 0; s < m; ++s)
    for (const EdgeId* u = r.blocks.begin(s); u != r.blocks.end(s); ++u)
      r.blocked_by.items[fill[*u]++] = s;
  return r;
}

std::size_t count_collisions(const BlockingGraph& b, const std::vector<std::size_t>& rank) {
  std::size_t c = 0;
  for (EdgeId s = 0; s + 1 < b.blocks.offsets.size(); ++s)
    for (const EdgeId* u = b.blocks.begin(s); u != b.blocks.end(s); ++u) c += rank[s] < rank[*u];
  return c;
}

}  // namespace trellis
