#include "trellis/plan/aero.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <queue>
#include <random>
#include <tuple>

#include "trellis/core/error.hpp"
#include "trellis/plan/collision_order.hpp"
#include "trellis/plan/euler.hpp"

namespace trellis {

AeroMethod aero_method_from_string(const std::string& name) {
  if (name == "dynamic") return AeroMethod::Dynamic;
  if (name == "groups") return AeroMethod::Groups;
  if (name == "periodic") return AeroMethod::Periodic;
  throw SettingError("unknown AERO method '" + name + "' (expected dynamic, groups or periodic)");
}

std::string to_string(AeroMethod m) {
  switch (m) {
    case AeroMethod::Dynamic:
      return "dynamic";
    case AeroMethod::Groups:
      return "groups";
    case AeroMethod::Periodic:
      return "periodic";
  }
  return "?";
}

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Print direction constraints: steep struts bottom-up (cone rule), user-directed struts as given.
std::vector<std::int8_t> directions(const Graph& g, const NozzleModel& nozzle, std::size_t& steep) {
  std::vector<std::int8_t> dir(g.edges.size(), 0);
  steep = 0;
  for (EdgeId e = 0; e < g.edges.size(); ++e) {
    const Edge& ed = g.edges[e];
    const Vec3 a = g.nodes[ed.a], b = g.nodes[ed.b];
    if (is_steep(a, b, nozzle)) {
      ++steep;
      dir[e] = a.z <= b.z ? 1 : -1;
    } else if (ed.directed) {
      dir[e] = 1;
    }
  }
  return dir;
}

bool reversible(const Trail& t, const std::vector<std::int8_t>& dir) {
  for (EdgeId e : t.edges)
    if (dir[e] != 0) return false;
  return true;
}

// The planner's state: what is printed, what may be printed now.
enum class Strategy { Lowest, Mean, Continue, Nearest, Unlock };

const char* to_string(Strategy s) {
  switch (s) {
    case Strategy::Lowest:
      return "lowest";
    case Strategy::Mean:
      return "mean";
    case Strategy::Continue:
      return "continue";
    case Strategy::Nearest:
      return "nearest";
    case Strategy::Unlock:
      return "unlock";
  }
  return "?";
}

class Planner {
 public:
  Planner(const Graph& g, const BlockingGraph* blocking, const std::vector<std::int8_t>& dir,
          Strategy strategy, std::uint64_t shuffle_seed, AeroResult& out, const Progress& progress)
      : g_(g),
        blocking_(blocking),
        dir_(dir),
        strategy_(strategy),
        out_(out),
        progress_(progress),
        euler_(g.nodes.size()),
        rng_(shuffle_seed),
        shuffle_(shuffle_seed != 0) {
    const std::size_t m = g.edges.size();
    printed_.assign(m, 0);
    pending_.assign(m, 0);
    int max_mat = 0;
    for (const auto& e : g.edges) max_mat = std::max(max_mat, e.material);
    available_.resize(static_cast<std::size_t>(max_mat) + 1);
    low_heap_.resize(available_.size());
    avail_count_.assign(available_.size(), 0);
    for (EdgeId e = 0; e < m; ++e) {
      pending_[e] = blocking_ ? static_cast<std::uint32_t>(blocking_->blocks.count(e)) : 0;
      if (pending_[e] == 0) make_available(e);
    }
    by_height_.resize(m);
    for (EdgeId e = 0; e < m; ++e) by_height_[e] = e;
    auto low = [&](EdgeId e) { return std::min(g.nodes[g.edges[e].a].z, g.nodes[g.edges[e].b].z); };
    std::sort(by_height_.begin(), by_height_.end(), [&](EdgeId a, EdgeId b) {
      const double la = low(a), lb = low(b);
      return la != lb ? la < lb : a < b;
    });
    const BBox3 box = g.bbox();
    pos_ = box.empty() ? Vec3{} : box.min;
  }

  void run_dynamic() {
    while (done_ < g_.edges.size()) {
      if (progress_.cancelled()) throw Cancelled("AERO planning cancelled");
      const int mat = pick_material();
      if (mat < 0) {
        force_lowest();
        continue;
      }
      // Continue the open trail if a printable strut leaves its end node: the decomposition is
      // made as if the trail were still open there.
      std::vector<Trail> trails;
      if (cur_ != MixedEuler::kNoNode && cur_material_ == mat && touches(cur_, mat)) {
        bool continued = false;
        const std::size_t stamp = unlocked_;  // what the decomposition sees
        trails = decompose(mat, cur_, &continued);
        if (continued) {
          print(std::move(trails.front()), mat, true);
          trails.erase(trails.begin());
          keep(std::move(trails), mat, stamp);
          continue;
        }
        // Not continued: the other trails still cover everything printable.
      } else if (cache_material_ == mat && cache_stamp_ == unlocked_ && !cache_.empty()) {
        // Nothing became printable since the last decomposition: its other trails are still
        // printable and minimal (for the whole printable set, or its window of it).
        trails = std::move(cache_);
        cache_material_ = -1;
      } else {
        trails = decompose(mat, MixedEuler::kNoNode, nullptr);
      }
      // A new trail: place one into the past if it fits, else pick one by the strategy.
      if (insert_into_earlier(trails, mat)) {
        cache_material_ = -1;
        continue;
      }
      const std::size_t k = choose(trails);
      const std::size_t stamp = unlocked_;
      print(std::move(trails[k]), mat, false);
      trails.erase(trails.begin() + static_cast<std::ptrdiff_t>(k));
      keep(std::move(trails), mat, stamp);
    }
  }

  void run_groups() {
    while (done_ < g_.edges.size()) {
      if (progress_.cancelled()) throw Cancelled("AERO planning cancelled");
      // The group: everything printable now, printed completely before refreshing.
      bool any = false;
      for (std::size_t mi = 0; mi < available_.size(); ++mi) {
        compact(static_cast<int>(mi));
        any |= !available_[mi].empty();
      }
      if (!any) {
        force_lowest();
        continue;
      }
      std::vector<std::pair<int, std::vector<Trail>>> group;
      for (std::size_t mi = 0; mi < available_.size(); ++mi)
        if (!available_[mi].empty())
          group.push_back({static_cast<int>(mi),
                           decompose(static_cast<int>(mi), MixedEuler::kNoNode, nullptr, true)});
      for (auto& [mat, trails] : group) {
        while (!trails.empty()) {
          const std::size_t k = choose(trails);
          Trail t = std::move(trails[k]);
          trails.erase(trails.begin() + static_cast<std::ptrdiff_t>(k));
          // Join with the previous trail when it ends where this one starts.
          const bool join =
              cur_ != MixedEuler::kNoNode && cur_material_ == mat && t.nodes.front() == cur_;
          print(std::move(t), mat, join);
        }
      }
    }
  }

  // The paper's peel groups (for the report): sizes of successive printable sets.
  static std::vector<std::size_t> peel_groups(const Graph& g, const BlockingGraph& b) {
    const std::size_t m = g.edges.size();
    std::vector<std::uint32_t> pending(m);
    std::vector<char> done(m, 0);
    std::vector<EdgeId> ready, next;
    for (EdgeId e = 0; e < m; ++e) {
      pending[e] = static_cast<std::uint32_t>(b.blocks.count(e));
      if (!pending[e]) ready.push_back(e);
    }
    std::vector<EdgeId> order(m);
    for (EdgeId e = 0; e < m; ++e) order[e] = e;
    std::sort(order.begin(), order.end(), [&](EdgeId a, EdgeId c) {
      return std::min(g.nodes[g.edges[a].a].z, g.nodes[g.edges[a].b].z) <
             std::min(g.nodes[g.edges[c].a].z, g.nodes[g.edges[c].b].z);
    });
    std::size_t cursor = 0, count = 0;
    std::vector<std::size_t> sizes;
    while (count < m) {
      if (ready.empty()) {
        while (done[order[cursor]]) ++cursor;
        ready.push_back(order[cursor]);
      }
      sizes.push_back(ready.size());
      next.clear();
      for (EdgeId e : ready) done[e] = 1;
      count += ready.size();
      for (EdgeId e : ready)
        for (const EdgeId* s = b.blocked_by.begin(e); s != b.blocked_by.end(e); ++s)
          if (!done[*s] && pending[*s] > 0 && --pending[*s] == 0) next.push_back(*s);
      ready.swap(next);
    }
    return sizes;
  }

 private:
  // Keeps the rest of a decomposition made when `stamp` struts had become printable.
  void keep(std::vector<Trail> trails, int mat, std::size_t stamp) {
    cache_ = std::move(trails);
    cache_material_ = mat;
    cache_stamp_ = stamp;
  }

  void make_available(EdgeId e) {
    ++unlocked_;
    const auto mat = static_cast<std::size_t>(g_.edges[e].material);
    available_[mat].push_back(e);
    ++avail_count_[mat];
    low_heap_[mat].push({std::min(g_.nodes[g_.edges[e].a].z, g_.nodes[g_.edges[e].b].z), e});
  }

  void compact(int mat) {
    auto& v = available_[static_cast<std::size_t>(mat)];
    v.erase(std::remove_if(v.begin(), v.end(), [&](EdgeId e) { return printed_[e] != 0; }),
            v.end());
  }

  // Current material if it still has printable struts, else the one whose nearest printable
  // strut is closest; -1 if nothing is printable.
  int pick_material() {
    if (cur_material_ >= 0 && avail_count_[static_cast<std::size_t>(cur_material_)] > 0)
      return cur_material_;
    int best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t mi = 0; mi < available_.size(); ++mi) {
      compact(static_cast<int>(mi));
      for (EdgeId e : available_[mi]) {
        const double d = std::min(distance(pos_, g_.nodes[g_.edges[e].a]),
                                  distance(pos_, g_.nodes[g_.edges[e].b]));
        if (d < best_d) {
          best_d = d;
          best = static_cast<int>(mi);
        }
      }
    }
    return best;
  }

  bool touches(NodeId v, int mat) const {
    for (const EdgeId* x = adj_.begin(v); x != adj_.end(v); ++x) {
      const EdgeId e = *x;
      if (printed_[e] || pending_[e] != 0 || g_.edges[e].material != mat) continue;
      const Edge& ed = g_.edges[e];
      if ((ed.a == v && dir_[e] >= 0) || (ed.b == v && dir_[e] <= 0)) return true;
    }
    return false;
  }

  // A minimum trail cover of what is printable now. To continue the open trail only the
  // printable struts connected to its end matter; a new trail is taken from a cover of all
  // printable struts, or, when there are more than 1024 of them, of those connected to the
  // lowest one. Either set is gathered breadth-first and capped (512 struts around the open end,
  // 1024 around the lowest), so the work per trail stays bounded on big lattices.
  std::vector<Trail> decompose(int mat, NodeId from, bool* continued, bool whole = false) {
    ++out_.decompositions;
    auto& avail = available_[static_cast<std::size_t>(mat)];
    std::vector<EdgeId>* set = &avail;
    if (!whole &&
        (avail_count_[static_cast<std::size_t>(mat)] > window_ || from != MixedEuler::kNoNode)) {
      cap_ = from != MixedEuler::kNoNode ? continue_window_ : window_;
      NodeId seed = from;
      if (seed == MixedEuler::kNoNode) {
        const EdgeId low = lowest_available(mat);
        const Edge& e = g_.edges[low];
        seed = g_.nodes[e.a].z <= g_.nodes[e.b].z ? e.a : e.b;
      }
      gather(seed, mat);
      set = &window_edges_;
    } else {
      compact(mat);
    }
    std::vector<EdgeId>& edges = *set;
    if (shuffle_) std::shuffle(edges.begin(), edges.end(), rng_);
    return euler_.decompose(g_, edges, dir_, from, continued);
  }

  // The lowest printable strut of a material (lazy heap).
  EdgeId lowest_available(int mat) {
    auto& heap = low_heap_[static_cast<std::size_t>(mat)];
    while (printed_[heap.top().second]) heap.pop();
    return heap.top().second;
  }

  // Printable struts connected to v through printable struts, breadth-first, at most window_.
  void gather(NodeId v, int mat) {
    window_edges_.clear();
    ++tick_;
    std::size_t head = 0;
    queue_.assign(1, v);
    node_seen_[v] = tick_;
    while (head < queue_.size() && window_edges_.size() < cap_) {
      const NodeId n = queue_[head++];
      for (const EdgeId* x = adj_.begin(n); x != adj_.end(n); ++x) {
        const EdgeId e = *x;
        if (printed_[e] || pending_[e] != 0 || g_.edges[e].material != mat || seen_[e] == tick_)
          continue;
        seen_[e] = tick_;
        window_edges_.push_back(e);
        const NodeId o = g_.edges[e].other(n);
        if (node_seen_[o] != tick_) {
          node_seen_[o] = tick_;
          queue_.push_back(o);
        }
      }
    }
  }

  // The next trail to print (reversed in place where allowed), by the planner's strategy:
  //  lowest     lowest trail first (by its lowest node): the print front rises evenly, so
  //             struts above become printable in the order they are needed;
  //  mean       by the mean height of the trail's nodes;
  //  continue   lowest, but a trail after which a strut leaves its end node wins ties within
  //             1 mm of height (it can be continued without travel);
  //  unlock     lowest, less 1 mm per strut the trail makes printable (opens the way up);
  //  nearest    start (or end) nearest the nozzle — the travel-length order (used by the
  //             paper's group method).
  std::size_t choose(std::vector<Trail>& trails) const {
    std::size_t best = 0;
    double best_key = std::numeric_limits<double>::infinity();
    bool best_flip = false;
    // The costlier keys (continue, unlock) look at the 64 lowest trails only.
    std::vector<std::pair<double, std::size_t>> order(trails.size());
    for (std::size_t i = 0; i < trails.size(); ++i) {
      double zmin = std::numeric_limits<double>::infinity();
      for (NodeId n : trails[i].nodes) zmin = std::min(zmin, g_.nodes[n].z);
      order[i] = {zmin, i};
    }
    constexpr std::size_t kConsidered = 64;
    if (order.size() > kConsidered &&
        (strategy_ == Strategy::Continue || strategy_ == Strategy::Unlock)) {
      std::nth_element(order.begin(), order.begin() + kConsidered, order.end());
      order.resize(kConsidered);
    }
    for (const auto& [zmin, i] : order) {
      const Trail& t = trails[i];
      double zsum = 0;
      for (NodeId n : t.nodes) zsum += g_.nodes[n].z;
      const bool can_flip = reversible(t, dir_);
      for (int f = 0; f < (can_flip ? 2 : 1); ++f) {
        const NodeId start = f ? t.nodes.back() : t.nodes.front();
        const NodeId end = f ? t.nodes.front() : t.nodes.back();
        double key = 0;
        switch (strategy_) {
          case Strategy::Lowest:
            key = zmin;
            break;
          case Strategy::Mean:
            key = zsum / static_cast<double>(t.nodes.size());
            break;
          case Strategy::Continue:
            key = zmin + (continuable(t, end) ? 0 : 1.0);
            break;
          case Strategy::Nearest:
            key = distance(pos_, g_.nodes[start]);
            break;
          case Strategy::Unlock:
            key = zmin - static_cast<double>(unlocks(t));
            break;
        }
        // Ties (same height): the nearer start.
        key += 1e-6 * distance(pos_, g_.nodes[start]);
        if (key < best_key) {
          best_key = key;
          best = i;
          best_flip = f == 1;
        }
      }
    }
    if (best_flip) trails[best].reverse();
    return best;
  }

  // How many struts become printable once t is printed: those whose pending count equals the
  // number of t's struts they wait for.
  std::size_t unlocks(const Trail& t) const {
    if (!blocking_) return 0;
    ++tick_;
    std::size_t n = 0;
    for (EdgeId e : t.edges) in_trail_[e] = tick_;
    for (EdgeId e : t.edges)
      for (const EdgeId* s = blocking_->blocked_by.begin(e); s != blocking_->blocked_by.end(e);
           ++s) {
        if (printed_[*s] || in_trail_[*s] == tick_) continue;
        if (seen_[*s] != tick_) {
          seen_[*s] = tick_;
          waits_[*s] = 0;
        }
        if (++waits_[*s] == pending_[*s]) ++n;
      }
    return n;
  }

  // After printing t, could a trail continue from `end`?
  bool continuable(const Trail& t, NodeId end) const {
    ++tick_;
    for (EdgeId e : t.edges) in_trail_[e] = tick_;
    const int mat = g_.edges[t.edges.front()].material;
    for (const EdgeId* x = adj_.begin(end); x != adj_.end(end); ++x) {
      const EdgeId e = *x;
      if (printed_[e] || in_trail_[e] == tick_ || g_.edges[e].material != mat) continue;
      const Edge& ed = g_.edges[e];
      if (!((ed.a == end && dir_[e] >= 0) || (ed.b == end && dir_[e] <= 0))) continue;
      std::uint32_t left = pending_[e];
      if (left && blocking_)
        for (const EdgeId* u = blocking_->blocks.begin(e); u != blocking_->blocks.end(e); ++u)
          if (in_trail_[*u] == tick_) --left;
      if (left == 0) return true;
    }
    return false;
  }

  void mark_printed(EdgeId e) {
    printed_[e] = 1;
    ++done_;
    --avail_count_[static_cast<std::size_t>(g_.edges[e].material)];
    if (!blocking_) return;
    for (const EdgeId* s = blocking_->blocked_by.begin(e); s != blocking_->blocked_by.end(e); ++s)
      if (!printed_[*s] && pending_[*s] > 0 && --pending_[*s] == 0) make_available(*s);
  }

  void print(Trail t, int mat, bool join) {
    for (EdgeId e : t.edges) {
      mark_printed(e);
      clock_ += 1;
      time_[e] = clock_;
    }
    if (join && !out_.trails.trails.empty()) {
      const auto j = static_cast<std::uint32_t>(out_.trails.trails.size() - 1);
      Trail& last = out_.trails.trails.back();
      erase_index(ends_at_[last.nodes.back()], j);
      last.edges.insert(last.edges.end(), t.edges.begin(), t.edges.end());
      last.nodes.insert(last.nodes.end(), t.nodes.begin() + 1, t.nodes.end());
      last.length += t.length;
      ends_at_[last.nodes.back()].push_back(j);
    } else {
      const auto j = static_cast<std::uint32_t>(out_.trails.trails.size());
      starts_at_[t.nodes.front()].push_back(j);
      ends_at_[t.nodes.back()].push_back(j);
      out_.trails.trails.push_back(std::move(t));
      out_.trail_material.push_back(mat);
    }
    cur_ = out_.trails.trails.back().nodes.back();
    cur_material_ = mat;
    pos_ = g_.nodes[cur_];
  }

  static void erase_index(std::vector<std::uint32_t>& v, std::uint32_t j) {
    v.erase(std::find(v.begin(), v.end(), j));
  }

  double first_time(std::size_t j) const { return time_[out_.trails.trails[j].edges.front()]; }
  double last_time(std::size_t j) const { return time_[out_.trails.trails[j].edges.back()]; }

  // Renumbers print times 1, 2, ... in print order (when inserted times get too close).
  void renumber() {
    clock_ = 0;
    for (const auto& t : out_.trails.trails)
      for (EdgeId e : t.edges) time_[e] = clock_ += 1;
  }

  // Going back in time: a printable trail that ends where an earlier trail starts (or starts
  // where one ends) is printed right before (after) it, if everything it needs was printed by
  // then — its struts obstruct only struts printed before that point, so nothing printed later
  // is affected. No travel is added. Returns true if a trail was placed.
  bool insert_into_earlier(std::vector<Trail>& trails, int mat) {
    if (!blocking_) return false;
    const std::size_t count = out_.trails.trails.size();
    for (auto& c : trails) {
      const bool can_flip = reversible(c, dir_);
      // Candidate places first (cheap): the latest print time any of them allows; then the
      // trail's needs, stopping at the first strut it needs that comes later than that.
      double allowed = -std::numeric_limits<double>::infinity();
      for (int f = 0; f < (can_flip ? 2 : 1); ++f) {
        const NodeId first = f ? c.nodes.back() : c.nodes.front();
        const NodeId last = f ? c.nodes.front() : c.nodes.back();
        for (std::uint32_t j : ends_at_[first])
          if (j + 1 < count && out_.trail_material[j] == mat)
            allowed = std::max(allowed, last_time(j));
        for (std::uint32_t j : starts_at_[last])
          if (out_.trail_material[j] == mat)
            allowed = std::max(allowed, j > 0 ? last_time(j - 1) : 0.0);
      }
      if (allowed == -std::numeric_limits<double>::infinity()) continue;
      double needed = -std::numeric_limits<double>::infinity();  // latest print time it needs
      for (EdgeId e : c.edges) {
        for (const EdgeId* u = blocking_->blocks.begin(e); u != blocking_->blocks.end(e); ++u)
          needed = std::max(needed, time_[*u]);
        if (needed > allowed) break;
      }
      if (needed > allowed) continue;
      for (int f = 0; f < (can_flip ? 2 : 1); ++f) {
        const NodeId first = f ? c.nodes.back() : c.nodes.front();
        const NodeId last = f ? c.nodes.front() : c.nodes.back();
        // Append after trail j (j not the open trail: that is the continuation case).
        for (std::uint32_t j : ends_at_[first]) {
          if (j + 1 >= count || out_.trail_material[j] != mat || last_time(j) < needed) continue;
          if (f) c.reverse();
          place(c, j, false);
          return true;
        }
        // Prepend before trail j.
        for (std::uint32_t j : starts_at_[last]) {
          if (out_.trail_material[j] != mat) continue;
          const double before = j > 0 ? last_time(j - 1) : 0.0;
          if (before < needed) continue;
          if (f) c.reverse();
          place(c, j, true);
          return true;
        }
      }
    }
    return false;
  }

  void place(Trail& c, std::uint32_t j, bool prepend) {
    const std::size_t count = out_.trails.trails.size();
    double lo, hi;
    if (prepend) {
      lo = j > 0 ? last_time(j - 1) : 0.0;
      hi = first_time(j);
    } else {
      lo = last_time(j);
      hi = j + 1 < count ? first_time(j + 1) : clock_ + 1;
    }
    const double step = (hi - lo) / static_cast<double>(c.edges.size() + 1);
    for (std::size_t k = 0; k < c.edges.size(); ++k) {
      mark_printed(c.edges[k]);
      time_[c.edges[k]] = lo + step * static_cast<double>(k + 1);
    }
    Trail& t = out_.trails.trails[j];
    if (prepend) {
      erase_index(starts_at_[t.nodes.front()], j);
      t.edges.insert(t.edges.begin(), c.edges.begin(), c.edges.end());
      t.nodes.insert(t.nodes.begin(), c.nodes.begin(), c.nodes.end() - 1);
      starts_at_[t.nodes.front()].push_back(j);
    } else {
      erase_index(ends_at_[t.nodes.back()], j);
      t.edges.insert(t.edges.end(), c.edges.begin(), c.edges.end());
      t.nodes.insert(t.nodes.end(), c.nodes.begin() + 1, c.nodes.end());
      ends_at_[t.nodes.back()].push_back(j);
    }
    t.length += c.length;
    ++out_.insertions;
    if (step < 1e-6) renumber();
  }

 public:
  // Local search after planning. A trail is dissolved when it can join other trails without
  // travel: as a whole (appended to a trail that ends where it starts, or prepended to one
  // that starts where it ends, earlier or later in the print), or split in two pieces that
  // each join a different trail. A piece may move to a new place in the print when all struts
  // its struts need are printed before that place and all struts that need them after it.
  // Each dissolved trail removes one travel. Sweeps until nothing changes.
  void merge_pass() {
    if (!blocking_) return;
    auto& ts = out_.trails.trails;
    const std::size_t m = g_.edges.size();
    owner_.assign(m, 0);
    pos_in_.assign(m, 0);
    for (bool changed = true; changed;) {
      changed = false;
      for (auto& v : starts_at_) v.clear();
      for (auto& v : ends_at_) v.clear();
      for (std::uint32_t j = 0; j < ts.size(); ++j) {
        starts_at_[ts[j].nodes.front()].push_back(j);
        ends_at_[ts[j].nodes.back()].push_back(j);
        for (EdgeId e : ts[j].edges) owner_[e] = j;
      }
      for (std::uint32_t k = 0; k < ts.size(); ++k)
        if (!ts[k].edges.empty() && dissolve(k)) changed = true;
      // Drop the dissolved trails.
      std::size_t w = 0;
      for (std::size_t j = 0; j < ts.size(); ++j)
        if (!ts[j].edges.empty()) {
          if (w != j) {
            ts[w] = std::move(ts[j]);
            out_.trail_material[w] = out_.trail_material[j];
          }
          ++w;
        }
      ts.resize(w);
      out_.trail_material.resize(w);
      renumber();
    }
  }

 private:
  struct Target {
    std::uint32_t j = 0;
    bool flip = false, prepend = false;
  };

  // Where the piece [b, e) of trail k could go (not onto trail `exclude`).
  bool find_target(std::uint32_t k, std::size_t b, std::size_t e, std::uint32_t exclude,
                   double needed, double deadline, bool can_flip, Target& out) const {
    const Trail& t = out_.trails.trails[k];
    const int mat = out_.trail_material[k];
    for (int f = 0; f < (can_flip ? 2 : 1); ++f) {
      const NodeId first = f ? t.nodes[e] : t.nodes[b];
      const NodeId last = f ? t.nodes[b] : t.nodes[e];
      for (std::uint32_t j : ends_at_[first]) {  // append after trail j
        if (j == k || j == exclude || out_.trail_material[j] != mat) continue;
        if (out_.trails.trails[j].edges.empty()) continue;
        const double lo = last_time(j);
        if (needed <= lo && deadline > lo) {
          out = {j, f == 1, false};
          return true;
        }
      }
      for (std::uint32_t j : starts_at_[last]) {  // prepend before trail j
        if (j == k || j == exclude || out_.trail_material[j] != mat) continue;
        if (out_.trails.trails[j].edges.empty()) continue;
        const double hi = first_time(j);
        if (needed < hi && deadline >= hi) {
          out = {j, f == 1, true};
          return true;
        }
      }
    }
    return false;
  }

  // Tries to dissolve trail k (whole, or split once); returns true if it did.
  bool dissolve(std::uint32_t k) {
    const Trail& t = out_.trails.trails[k];
    const std::size_t n = t.edges.size();
    for (std::size_t i = 0; i < n; ++i) pos_in_[t.edges[i]] = static_cast<std::uint32_t>(i);
    const double inf = std::numeric_limits<double>::infinity();
    // Per edge: latest strut it needs and earliest strut that needs it, outside the trail;
    // precedences inside the trail as (i, j) position pairs.
    std::vector<double> need(n, -inf), dead(n, inf);
    std::vector<std::pair<std::size_t, std::size_t>> inner;
    for (std::size_t i = 0; i < n; ++i) {
      const EdgeId x = t.edges[i];
      for (const EdgeId* u = blocking_->blocks.begin(x); u != blocking_->blocks.end(x); ++u) {
        if (owner_[*u] == k)
          inner.push_back(
              {std::min<std::size_t>(i, pos_in_[*u]), std::max<std::size_t>(i, pos_in_[*u])});
        else
          need[i] = std::max(need[i], time_[*u]);
      }
      for (const EdgeId* y = blocking_->blocked_by.begin(x); y != blocking_->blocked_by.end(x); ++y)
        if (owner_[*y] != k) dead[i] = std::min(dead[i], time_[*y]);
    }
    // Prefix / suffix bounds and whether a piece holds an inner precedence (then it keeps its
    // direction) or a split cuts one (then the split is not allowed).
    std::vector<double> pre_need(n + 1, -inf), pre_dead(n + 1, inf), suf_need(n + 1, -inf),
        suf_dead(n + 1, inf);
    for (std::size_t i = 0; i < n; ++i) {
      pre_need[i + 1] = std::max(pre_need[i], need[i]);
      pre_dead[i + 1] = std::min(pre_dead[i], dead[i]);
    }
    for (std::size_t i = n; i-- > 0;) {
      suf_need[i] = std::max(suf_need[i + 1], need[i]);
      suf_dead[i] = std::min(suf_dead[i + 1], dead[i]);
    }
    std::vector<int> cut(n + 2, 0);  // cut[s] > 0: a precedence crosses split s
    std::size_t first_inner_end = n + 1, last_inner_start = 0;  // for piece-internal checks
    bool any_inner = !inner.empty();
    for (auto [i, j] : inner) {
      ++cut[i + 1];
      --cut[j + 1];
      first_inner_end = std::min(first_inner_end, j);
      last_inner_start = std::max(last_inner_start, i);
    }
    for (std::size_t s = 1; s <= n; ++s) cut[s] += cut[s - 1];
    std::vector<std::int8_t> pre_dir(n + 1, 0), suf_dir(n + 1, 0);  // a one-way strut in it
    for (std::size_t i = 0; i < n; ++i) pre_dir[i + 1] = pre_dir[i] | (dir_[t.edges[i]] != 0);
    for (std::size_t i = n; i-- > 0;) suf_dir[i] = suf_dir[i + 1] | (dir_[t.edges[i]] != 0);
    Target tp, tq;
    // Whole trail.
    if (find_target(k, 0, n, UINT32_MAX, pre_need[n], pre_dead[n], !any_inner && !pre_dir[n], tp)) {
      place_piece(k, 0, n, tp);
      out_.trails.trails[k].edges.clear();
      ++out_.merges;
      return true;
    }
    // Two pieces [0, s) and [s, n).
    for (std::size_t s = 1; s < n; ++s) {
      if (cut[s] > 0) continue;
      const bool p_inner = any_inner && first_inner_end < s;    // an inner pair inside [0, s)
      const bool q_inner = any_inner && last_inner_start >= s;  // an inner pair inside [s, n)
      if (!find_target(k, 0, s, UINT32_MAX, pre_need[s], pre_dead[s], !p_inner && !pre_dir[s], tp))
        continue;
      if (!find_target(k, s, n, tp.j, suf_need[s], suf_dead[s], !q_inner && !suf_dir[s], tq))
        continue;
      place_piece(k, 0, s, tp);
      place_piece(k, s, n, tq);
      out_.trails.trails[k].edges.clear();
      ++out_.merges;
      return true;
    }
    return false;
  }

  // Moves edges [b, e) of trail k onto trail tg.j (trail k itself is cleared by the caller).
  void place_piece(std::uint32_t k, std::size_t b, std::size_t e, const Target& tg) {
    auto& ts = out_.trails.trails;
    Trail c;
    c.edges.assign(ts[k].edges.begin() + static_cast<std::ptrdiff_t>(b),
                   ts[k].edges.begin() + static_cast<std::ptrdiff_t>(e));
    c.nodes.assign(ts[k].nodes.begin() + static_cast<std::ptrdiff_t>(b),
                   ts[k].nodes.begin() + static_cast<std::ptrdiff_t>(e + 1));
    for (EdgeId x : c.edges) c.length += g_.edge_length(x);
    if (tg.flip) c.reverse();
    const std::uint32_t j = tg.j;
    // The gap next to trail j among trails that keep their times (not k, not dissolved).
    auto live = [&](std::size_t p) { return p != k && !ts[p].edges.empty(); };
    double lo, hi;
    if (tg.prepend) {
      lo = 0;
      for (std::size_t p = j; p-- > 0;)
        if (live(p)) {
          lo = last_time(p);
          break;
        }
      hi = first_time(j);
    } else {
      lo = last_time(j);
      hi = clock_ + 1;
      for (std::size_t p = j + 1; p < ts.size(); ++p)
        if (live(p)) {
          hi = first_time(p);
          break;
        }
    }
    const double step = (hi - lo) / static_cast<double>(c.edges.size() + 1);
    for (std::size_t q = 0; q < c.edges.size(); ++q) {
      time_[c.edges[q]] = lo + step * static_cast<double>(q + 1);
      owner_[c.edges[q]] = j;
    }
    Trail& t = ts[j];
    if (tg.prepend) {
      erase_index(starts_at_[t.nodes.front()], j);
      c.edges.insert(c.edges.end(), t.edges.begin(), t.edges.end());
      c.nodes.insert(c.nodes.end(), t.nodes.begin() + 1, t.nodes.end());
      c.length += t.length;
      t = std::move(c);
      starts_at_[t.nodes.front()].push_back(j);
    } else {
      erase_index(ends_at_[t.nodes.back()], j);
      t.edges.insert(t.edges.end(), c.edges.begin(), c.edges.end());
      t.nodes.insert(t.nodes.end(), c.nodes.begin() + 1, c.nodes.end());
      t.length += c.length;
      ends_at_[t.nodes.back()].push_back(j);
    }
    if (step < 1e-9 * std::max(1.0, clock_)) renumber();
  }

  // Nothing is printable: every remaining strut obstructs another remaining one. Print the one
  // that obstructs the fewest (so the fewest collisions follow), the lowest of those (the
  // collisions are counted from the finished order). (The rule is "the lowest"; the lowest
  // may only be waiting behind a cycle and cost more collisions than breaking the cycle where it is
  // cheapest.)
  void force_lowest() {
    while (printed_[by_height_[lowest_]]) ++lowest_;
    EdgeId best = by_height_[lowest_];
    for (std::size_t i = lowest_; i < by_height_.size(); ++i) {
      const EdgeId e = by_height_[i];
      if (!printed_[e] && pending_[e] < pending_[best]) best = e;
    }
    pending_[best] = 0;
    make_available(best);
  }

  const Graph& g_;
  const BlockingGraph* blocking_;
  const std::vector<std::int8_t>& dir_;
  Strategy strategy_;
  AeroResult& out_;
  const Progress& progress_;
  MixedEuler euler_;
  std::vector<char> printed_;
  std::vector<std::uint32_t> pending_;
  std::vector<std::vector<EdgeId>> available_;  // per material, lazily compacted
  using LowHeap = std::priority_queue<std::pair<double, EdgeId>,
                                      std::vector<std::pair<double, EdgeId>>, std::greater<>>;
  std::vector<LowHeap> low_heap_;         // per material: printable struts by lowest end
  std::vector<std::size_t> avail_count_;  // per material: printable struts not yet printed
  std::size_t window_ = 1024, continue_window_ = 512, cap_ = 1024;
  std::vector<EdgeId> window_edges_;
  std::vector<NodeId> queue_;
  std::vector<EdgeId> by_height_;
  Adjacency adj_{g_};
  mutable std::vector<std::uint32_t> in_trail_ = std::vector<std::uint32_t>(g_.edges.size(), 0);
  mutable std::vector<std::uint32_t> seen_ = std::vector<std::uint32_t>(g_.edges.size(), 0);
  mutable std::vector<std::uint32_t> waits_ = std::vector<std::uint32_t>(g_.edges.size(), 0);
  std::vector<std::uint32_t> node_seen_ = std::vector<std::uint32_t>(g_.nodes.size(), 0);

  mutable std::uint32_t tick_ = 0;
  std::size_t lowest_ = 0, done_ = 0, unlocked_ = 0;
  std::vector<std::uint32_t> owner_, pos_in_;  // merge pass: trail of each strut, place in it
  std::vector<Trail> cache_;                   // the rest of the last decomposition
  int cache_material_ = -1;
  std::size_t cache_stamp_ = 0;  // unlocked_ when it was made
  std::vector<double> time_ = std::vector<double>(g_.edges.size(), 0.0);
  double clock_ = 0;
  std::vector<std::vector<std::uint32_t>> starts_at_ =
      std::vector<std::vector<std::uint32_t>>(g_.nodes.size());
  std::vector<std::vector<std::uint32_t>> ends_at_ =
      std::vector<std::vector<std::uint32_t>>(g_.nodes.size());
  std::mt19937_64 rng_;
  bool shuffle_;
  NodeId cur_ = MixedEuler::kNoNode;
  int cur_material_ = -1;
  Vec3 pos_;
};

}  // namespace

namespace {

// The lattice renumbered in a canonical order (nodes by x, then y, then z, at 1 nm; struts by their
// new end ids), so the plan depends on the geometry, not on the order of the input file.
struct Canonical {
  Graph graph;
  std::vector<NodeId> node_from;  // canonical node -> input node
  std::vector<EdgeId> edge_from;  // canonical strut -> input strut
};

Canonical canonical(const Graph& g) {
  Canonical c;
  const std::size_t n = g.nodes.size(), m = g.edges.size();
  c.node_from.resize(n);
  for (NodeId i = 0; i < n; ++i) c.node_from[i] = i;
  // Coordinates compared at 1 nm so float noise in the input does not change the order.
  auto grid = [](double v) { return std::llround(v * 1e6); };
  std::stable_sort(c.node_from.begin(), c.node_from.end(), [&](NodeId a, NodeId b) {
    const Vec3 p = g.nodes[a], q = g.nodes[b];
    return std::make_tuple(grid(p.x), grid(p.y), grid(p.z)) <
           std::make_tuple(grid(q.x), grid(q.y), grid(q.z));
  });
  std::vector<NodeId> to(n);
  for (NodeId i = 0; i < n; ++i) to[c.node_from[i]] = i;
  c.graph.nodes.resize(n);
  for (NodeId i = 0; i < n; ++i) c.graph.nodes[i] = g.nodes[c.node_from[i]];
  c.edge_from.resize(m);
  for (EdgeId e = 0; e < m; ++e) c.edge_from[e] = e;
  auto key = [&](EdgeId e) {
    const NodeId a = to[g.edges[e].a], b = to[g.edges[e].b];
    return std::make_pair(std::min(a, b), std::max(a, b));
  };
  std::stable_sort(c.edge_from.begin(), c.edge_from.end(),
                   [&](EdgeId a, EdgeId b) { return key(a) < key(b); });
  c.graph.edges.resize(m);
  for (EdgeId e = 0; e < m; ++e) {
    Edge ed = g.edges[c.edge_from[e]];
    ed.a = to[ed.a];
    ed.b = to[ed.b];
    if (!ed.directed && ed.b < ed.a) std::swap(ed.a, ed.b);  // a directed strut stays a -> b
    c.graph.edges[e] = ed;
  }
  return c;
}

// `fixed`: the trails are given (the periodic method's), only counted here.
AeroResult plan_canonical(const Graph& g, const AeroParams& params, const PeriodicTrails* fixed,
                          const RunContext& context);

// The periodic method's trails, made on the input (its errors name the input's struts), in the
// canonical ids.
PeriodicTrails canonical_periodic(const Graph& input, const Canonical& c,
                                  const PeriodicParams& params) {
  PeriodicTrails pt = periodic_trails(input, params);
  std::vector<NodeId> node_to(c.node_from.size());
  for (NodeId i = 0; i < node_to.size(); ++i) node_to[c.node_from[i]] = i;
  std::vector<EdgeId> edge_to(c.edge_from.size());
  for (EdgeId e = 0; e < edge_to.size(); ++e) edge_to[c.edge_from[e]] = e;
  for (auto& t : pt.trails.trails) {
    for (auto& n : t.nodes) n = node_to[n];
    for (auto& e : t.edges) e = edge_to[e];
  }
  return pt;
}

}  // namespace

std::size_t aero_auto_tries(std::size_t struts) {
  return std::clamp<std::size_t>(200000 / std::max<std::size_t>(1, struts), 1, 8);
}

AeroResult plan_aero(const Graph& input, const AeroParams& params, Diagnostics& diag,
                     const RunContext& context) {
  if (input.edges.empty()) throw GeometryError("the lattice has no struts to plan");
  params.nozzle.validate();
  const Canonical c = canonical(input);
  std::optional<PeriodicTrails> fixed;
  if (params.method == AeroMethod::Periodic) fixed = canonical_periodic(input, c, params.periodic);
  AeroResult r = plan_canonical(c.graph, params, fixed ? &*fixed : nullptr, context);
  // Back to the input's ids.
  for (auto& t : r.trails.trails) {
    for (auto& n : t.nodes) n = c.node_from[n];
    for (auto& e : t.edges) e = c.edge_from[e];
  }
  for (auto& v : r.violations) v.edge = c.edge_from[v.edge];
  if (r.collisions_planned > 0) {
    std::string which;
    for (std::size_t i = 0; i < r.violations.size() && i < 20; ++i)
      which += (i ? ", " : "") + std::to_string(r.violations[i].edge);
    if (r.violations.size() > 20) which += ", ...";
    diag.warn("collision_unavoidable",
              std::to_string(r.collisions_planned) + " nozzle collision(s) planned (" +
                  (r.collisions_proven_minimal()
                       ? std::string("proven minimal")
                       : "no order has fewer than " + std::to_string(r.collisions_lower_bound)) +
                  "): struts " + which + " are printed before struts they obstruct");
  }
  if (fixed) {
    // A cell path is printed as written: say where it goes against the cone rule.
    std::size_t down = 0;
    for (const auto& t : r.trails.trails)
      for (std::size_t k = 0; k < t.edges.size(); ++k) {
        const Vec3 a = input.nodes[t.nodes[k]], b = input.nodes[t.nodes[k + 1]];
        down += a.z > b.z && is_steep(a, b, params.nozzle);
      }
    if (down)
      diag.warn("cell_path_top_down", std::to_string(down) +
                                          " strut(s) within the nozzle cone are printed top-down: "
                                          "the periodic cell path is printed as written");
  }
  for (EdgeId e = 0; e < input.edges.size(); ++e) {
    const Edge& ed = input.edges[e];
    if (ed.directed && input.nodes[ed.a].z > input.nodes[ed.b].z &&
        is_steep(input.nodes[ed.a], input.nodes[ed.b], params.nozzle))
      diag.warn("direction_overridden",
                "strut " + std::to_string(e) +
                    " is directed top-down but lies within the nozzle cone: printed bottom-up");
  }
  return r;
}

namespace {

// Each strut's place in the print order.
std::vector<std::size_t> print_rank(const Graph& g, const PathSet& trails) {
  std::vector<std::size_t> rank(g.edges.size(), 0);
  std::size_t k = 0;
  for (const auto& t : trails.trails)
    for (EdgeId e : t.edges) rank[e] = k++;
  return rank;
}

AeroResult plan_canonical(const Graph& g, const AeroParams& params, const PeriodicTrails* fixed,
                          const RunContext& context) {
  AeroResult r;
  const auto t0 = Clock::now();
  const std::vector<std::int8_t> dir = directions(g, params.nozzle, r.steep_struts);
  {
    MixedEuler euler(g.nodes.size());
    int max_mat = 0;
    for (const auto& e : g.edges) max_mat = std::max(max_mat, e.material);
    std::vector<std::vector<EdgeId>> per(static_cast<std::size_t>(max_mat) + 1);
    for (EdgeId e = 0; e < g.edges.size(); ++e)
      per[static_cast<std::size_t>(g.edges[e].material)].push_back(e);
    for (const auto& edges : per) r.lower_bound_trails += euler.lower_bound(g, edges, dir);
  }
  BlockingGraph blocking;
  if (params.collisions) {
    context.report("collision model", 0);
    blocking = blocking_graph(g, params.nozzle, context.threads);
    r.blocking_relations = blocking.relations();
    // Struts that obstruct each other: whichever goes first is hit, so each pair costs at least
    // one collision in any order (blocks lists are sorted).
    for (EdgeId a = 0; a < g.edges.size(); ++a)
      for (const EdgeId* u = blocking.blocks.begin(a); u != blocking.blocks.end(a); ++u)
        if (*u > a && std::binary_search(blocking.blocks.begin(*u), blocking.blocks.end(*u), a))
          ++r.mutual_pairs;
    r.pairs_tested = blocking.pairs_tested;
    r.group_sizes = Planner::peel_groups(g, blocking);
  } else {
    r.group_sizes = {g.edges.size()};
  }
  r.groups = r.group_sizes.size();
  r.seconds_blocking = since(t0);
  // Fewest collisions: the relations an optimal (or locally optimal) order breaks are dropped,
  // so the planner works on a relation without cycles and never has to force a strut.
  BlockingGraph reduced;
  const BlockingGraph* plan_with = params.collisions ? &blocking : nullptr;
  if (params.collisions) {
    const auto t = Clock::now();
    context.report("fewest collisions", 0);
    CollisionOrderParams op = params.order;
    op.seed = params.seed;
    std::vector<double> height(g.edges.size());
    for (EdgeId e = 0; e < g.edges.size(); ++e)
      height[e] = g.nodes[g.edges[e].a].z + g.nodes[g.edges[e].b].z;
    const CollisionOrder order = fewest_collisions(blocking, op, height);
    r.collision_parts = order.parts;
    r.collisions_lower_bound = order.lower_bound;
    if (params.fewest_collisions) {
      reduced = without_relations(blocking, order.broken);
      plan_with = &reduced;
    }
    r.seconds_order = since(t);
  }
  const auto t1 = Clock::now();
  // Dynamic: a portfolio of runs — each trail-selection strategy as is, then with the
  // printable struts shuffled before every decomposition (Hierholzer's trails depend on that
  // order) — run in parallel, the best plan kept: fewest collisions, then trails, then travel,
  // then the lowest run index, so the result does not depend on thread timing.
  std::vector<Strategy> strategies = {Strategy::Nearest};
  std::size_t runs = 1;
  if (params.method == AeroMethod::Dynamic && params.collisions) {
    strategies = {Strategy::Lowest, Strategy::Unlock, Strategy::Continue, Strategy::Mean};
    runs =
        params.tries > 0 ? static_cast<std::size_t>(params.tries) : aero_auto_tries(g.edges.size());
  }
  // Each run's plan is compared with the best so far as it finishes and dropped unless better,
  // so memory holds one plan per thread, not one per try; the lowest run index breaks ties.
  auto key = [](const AeroResult& x) {
    return std::make_tuple(x.collisions_planned, x.trails.trails.size(), x.travel_length);
  };
  std::optional<AeroResult> best;
  std::size_t best_run = 0;
  std::mutex best_mutex;
  std::atomic<std::size_t> finished{0};
  tbb::task_arena arena(context.threads > 0 ? context.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, runs, [&](std::size_t k) {
      if (context.cancelled()) return;
      AeroResult trial = r;
      const Strategy strategy = strategies[k % strategies.size()];
      const std::uint64_t seed =
          k < strategies.size() ? 0 : params.seed * 1000003ULL + k;  // 0 = no shuffle
      Progress quiet;  // cancellation only: the portfolio reports progress per run
      quiet.cancel = context.progress.cancel;
      if (fixed) {
        trial.trails = fixed->trails;
        trial.trail_material = fixed->material;
        trial.strategy = "cell path";
      } else {
        Planner planner(g, plan_with, dir, strategy, seed, trial, quiet);
        if (params.method == AeroMethod::Groups || !params.collisions) {
          planner.run_groups();
        } else {
          planner.run_dynamic();
          planner.merge_pass();
        }
        trial.strategy = std::string(to_string(strategy)) + (seed ? "+shuffle" : "");
      }
      if (params.collisions)
        trial.collisions_planned = count_collisions(blocking, print_rank(g, trial.trails));
      const auto& ts = trial.trails.trails;
      trial.travel_moves = ts.empty() ? 0 : ts.size() - 1;
      for (std::size_t j = 1; j < ts.size(); ++j)
        trial.travel_length +=
            distance(g.nodes[ts[j - 1].nodes.back()], g.nodes[ts[j].nodes.front()]);
      {
        std::lock_guard lock(best_mutex);
        if (!best || std::make_tuple(key(trial), k) < std::make_tuple(key(*best), best_run)) {
          best = std::move(trial);
          best_run = k;
        }
      }
      context.report("tries", static_cast<double>(++finished) / static_cast<double>(runs));
    });
  });
  context.check("AERO planning");
  r = std::move(*best);
  if (params.collisions) {
    // The struts printed before struts they obstruct: one collision per such pair.
    const std::vector<std::size_t> rank = print_rank(g, r.trails);
    for (EdgeId s = 0; s < g.edges.size(); ++s) {
      std::size_t n = 0;
      for (const EdgeId* u = blocking.blocks.begin(s); u != blocking.blocks.end(s); ++u)
        n += rank[s] < rank[*u];
      if (n) r.violations.push_back({s, n});
    }
  }
  r.runs = runs;
  r.seconds_planning = since(t1);
  for (const auto& t : r.trails.trails)
    r.max_trail_edges = std::max(r.max_trail_edges, t.edges.size());
  context.report("tries", 1);
  return r;
}

}  // namespace

Toolpath aero_toolpath(const Graph& g, const AeroResult& r, const std::string& source) {
  Toolpath tp;
  tp.source = source;
  Layer layer;
  layer.z = g.bbox().min.z;
  for (std::size_t i = 0; i < r.trails.trails.size(); ++i) {
    const Trail& t = r.trails.trails[i];
    Path p;
    p.role = PathRole::Strut;
    p.tool = r.trail_material[i];
    p.points.reserve(t.nodes.size());
    for (NodeId n : t.nodes) p.points.push_back(g.nodes[n]);
    layer.paths.push_back(std::move(p));
  }
  tp.layers.push_back(std::move(layer));
  return tp;
}

}  // namespace trellis
