#include "trellis/plan/aero.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <tuple>
#include <nlohmann/json.hpp>

#include "trellis/core/error.hpp"
#include "trellis/plan/euler.hpp"

namespace trellis {

AeroMethod aero_method_from_string(const std::string& name) {
  if (name == "dynamic") return AeroMethod::Dynamic;
  if (name == "groups") return AeroMethod::Groups;
  throw SettingError("unknown AERO method '" + name + "' (expected dynamic or groups)");
}

std::string to_string(AeroMethod m) {
  return m == AeroMethod::Dynamic ? "dynamic" : "groups";
}

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Print direction constraints: steep struts bottom-up (cone rule), user-directed struts as given.
std::vector<std::int8_t> directions(const Graph& g, const NozzleModel& nozzle, std::size_t& steep,
                                    Diagnostics& diag) {
  std::vector<std::int8_t> dir(g.edges.size(), 0);
  steep = 0;
  for (EdgeId e = 0; e < g.edges.size(); ++e) {
    const Edge& ed = g.edges[e];
    const Vec3 a = g.nodes[ed.a], b = g.nodes[ed.b];
    if (is_steep(a, b, nozzle)) {
      ++steep;
      dir[e] = a.z <= b.z ? 1 : -1;
      if (ed.directed && dir[e] < 0)
        diag.warn("direction_overridden",
                  "strut " + std::to_string(e) +
                      " is directed top-down but lies within the nozzle cone: printed bottom-up");
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
enum class Strategy { Lowest, Mean, Continue, Nearest };

const char* to_string(Strategy s) {
  switch (s) {
    case Strategy::Lowest: return "lowest";
    case Strategy::Mean: return "mean";
    case Strategy::Continue: return "continue";
    case Strategy::Nearest: return "nearest";
  }
  return "?";
}

class Planner {
 public:
  Planner(const Graph& g, const BlockingGraph* blocking, const std::vector<std::int8_t>& dir,
          Strategy strategy, AeroResult& out, const Progress& progress)
      : g_(g),
        blocking_(blocking),
        dir_(dir),
        strategy_(strategy),
        out_(out),
        progress_(progress),
        euler_(g.nodes.size()) {
    const std::size_t m = g.edges.size();
    printed_.assign(m, 0);
    pending_.assign(m, 0);
    int max_mat = 0;
    for (const auto& e : g.edges) max_mat = std::max(max_mat, e.material);
    available_.resize(static_cast<std::size_t>(max_mat) + 1);
    for (EdgeId e = 0; e < m; ++e) {
      pending_[e] = blocking_ ? static_cast<std::uint32_t>(blocking_->blocks.count(e)) : 0;
      if (pending_[e] == 0) make_available(e);
    }
    by_height_.resize(m);
    for (EdgeId e = 0; e < m; ++e) by_height_[e] = e;
    auto low = [&](EdgeId e) {
      return std::min(g.nodes[g.edges[e].a].z, g.nodes[g.edges[e].b].z);
    };
    std::sort(by_height_.begin(), by_height_.end(), [&](EdgeId a, EdgeId b) {
      const double la = low(a), lb = low(b);
      return la != lb ? la < lb : a < b;
    });
    const BBox3 box = g.bbox();
    pos_ = box.empty() ? Vec3{} : box.min;
  }

  void run_dynamic() {
    while (done_ < g_.edges.size()) {
      if (progress_.cancelled()) throw Error("AERO planning cancelled");
      const int mat = pick_material();
      if (mat < 0) {
        force_lowest();
        continue;
      }
      // Continue the open trail if a printable strut leaves its end node: the decomposition is
      // made as if the trail were still open there.
      if (cur_ != MixedEuler::kNoNode && cur_material_ == mat && touches(cur_, mat)) {
        bool continued = false;
        auto trails = decompose(mat, cur_, &continued);
        if (continued) {
          print(std::move(trails.front()), mat, true);
          continue;
        }
      }
      // Otherwise a new trail: decompose everything printable now and pick one.
      auto trails = decompose(mat, MixedEuler::kNoNode, nullptr);
      const std::size_t k = nearest(trails);
      print(std::move(trails[k]), mat, false);
    }
  }

  void run_groups() {
    while (done_ < g_.edges.size()) {
      if (progress_.cancelled()) throw Error("AERO planning cancelled");
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
          group.push_back({static_cast<int>(mi), decompose(static_cast<int>(mi), MixedEuler::kNoNode, nullptr)});
      for (auto& [mat, trails] : group) {
        while (!trails.empty()) {
          const std::size_t k = nearest(trails);
          Trail t = std::move(trails[k]);
          trails.erase(trails.begin() + static_cast<std::ptrdiff_t>(k));
          // Join with the previous trail when it ends where this one starts.
          const bool join = cur_ != MixedEuler::kNoNode && cur_material_ == mat &&
                            t.nodes.front() == cur_;
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
  void make_available(EdgeId e) {
    available_[static_cast<std::size_t>(g_.edges[e].material)].push_back(e);
  }

  void compact(int mat) {
    auto& v = available_[static_cast<std::size_t>(mat)];
    v.erase(std::remove_if(v.begin(), v.end(), [&](EdgeId e) { return printed_[e] != 0; }), v.end());
  }

  // Current material if it still has printable struts, else the one whose nearest printable
  // strut is closest; -1 if nothing is printable.
  int pick_material() {
    if (cur_material_ >= 0) {
      compact(cur_material_);
      if (!available_[static_cast<std::size_t>(cur_material_)].empty()) return cur_material_;
    }
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
    for (EdgeId e : available_[static_cast<std::size_t>(mat)]) {
      if (printed_[e]) continue;
      const Edge& ed = g_.edges[e];
      if ((ed.a == v && dir_[e] >= 0) || (ed.b == v && dir_[e] <= 0)) return true;
    }
    return false;
  }

  std::vector<Trail> decompose(int mat, NodeId from, bool* continued) {
    compact(mat);
    ++out_.decompositions;
    return euler_.decompose(g_, available_[static_cast<std::size_t>(mat)], dir_, from, continued);
  }

  // The next trail to print (reversed in place where allowed), by the planner's strategy:
  //  lowest     lowest trail first (by its lowest node): the print front rises evenly, so
  //             struts above become printable in the order they are needed;
  //  mean       by the mean height of the trail's nodes;
  //  continue   lowest, but a trail after which a strut leaves its end node wins ties within
  //             1 mm of height (it can be continued without travel);
  //  nearest    start (or end) nearest the nozzle — the travel-length order.
  std::size_t nearest(std::vector<Trail>& trails) const {
    std::size_t best = 0;
    double best_key = std::numeric_limits<double>::infinity();
    bool best_flip = false;
    for (std::size_t i = 0; i < trails.size(); ++i) {
      const Trail& t = trails[i];
      double zmin = std::numeric_limits<double>::infinity(), zsum = 0;
      for (NodeId n : t.nodes) {
        zmin = std::min(zmin, g_.nodes[n].z);
        zsum += g_.nodes[n].z;
      }
      const bool can_flip = reversible(t, dir_);
      for (int f = 0; f < (can_flip ? 2 : 1); ++f) {
        const NodeId start = f ? t.nodes.back() : t.nodes.front();
        const NodeId end = f ? t.nodes.front() : t.nodes.back();
        double key = 0;
        switch (strategy_) {
          case Strategy::Lowest: key = zmin; break;
          case Strategy::Mean: key = zsum / static_cast<double>(t.nodes.size()); break;
          case Strategy::Continue: key = zmin + (continuable(t, end) ? 0 : 1.0); break;
          case Strategy::Nearest: key = distance(pos_, g_.nodes[start]); break;
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
    if (!blocking_) return;
    for (const EdgeId* s = blocking_->blocked_by.begin(e); s != blocking_->blocked_by.end(e); ++s)
      if (!printed_[*s] && pending_[*s] > 0 && --pending_[*s] == 0) make_available(*s);
  }

  void print(Trail t, int mat, bool join) {
    for (EdgeId e : t.edges) mark_printed(e);
    if (join && !out_.trails.trails.empty()) {
      Trail& last = out_.trails.trails.back();
      last.edges.insert(last.edges.end(), t.edges.begin(), t.edges.end());
      last.nodes.insert(last.nodes.end(), t.nodes.begin() + 1, t.nodes.end());
      last.length += t.length;
    } else {
      if (!out_.trails.trails.empty()) {
        ++out_.travel_moves;
        out_.travel_length += distance(pos_, g_.nodes[t.nodes.front()]);
      }
      out_.trails.trails.push_back(std::move(t));
      out_.trail_material.push_back(mat);
    }
    cur_ = out_.trails.trails.back().nodes.back();
    cur_material_ = mat;
    pos_ = g_.nodes[cur_];
  }

  // Nothing is printable: print the lowest remaining strut (bottom-up) and record it.
  void force_lowest() {
    while (printed_[by_height_[lowest_]]) ++lowest_;
    const EdgeId e = by_height_[lowest_];
    std::size_t obstructs = 0;
    for (const EdgeId* u = blocking_->blocks.begin(e); u != blocking_->blocks.end(e); ++u)
      obstructs += printed_[*u] ? 0 : 1;
    out_.violations.push_back({e, obstructs});
    pending_[e] = 0;
    make_available(e);
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
  std::vector<EdgeId> by_height_;
  Adjacency adj_{g_};
  mutable std::vector<std::uint32_t> in_trail_ = std::vector<std::uint32_t>(g_.edges.size(), 0);
  mutable std::uint32_t tick_ = 0;
  std::size_t lowest_ = 0, done_ = 0;
  NodeId cur_ = MixedEuler::kNoNode;
  int cur_material_ = -1;
  Vec3 pos_;
};

}  // namespace

AeroResult plan_aero(const Graph& g, const AeroParams& params, Diagnostics& diag) {
  if (g.edges.empty()) throw GeometryError("the lattice has no struts to plan");
  params.nozzle.validate();
  AeroResult r;
  const auto t0 = Clock::now();
  const std::vector<std::int8_t> dir = directions(g, params.nozzle, r.steep_struts, diag);
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
    params.progress("collision model", 0);
    blocking = blocking_graph(g, params.nozzle, params.threads);
    r.blocking_relations = blocking.relations();
    r.pairs_tested = blocking.pairs_tested;
    r.group_sizes = Planner::peel_groups(g, blocking);
  } else {
    r.group_sizes = {g.edges.size()};
  }
  r.groups = r.group_sizes.size();
  r.seconds_blocking = since(t0);
  const auto t1 = Clock::now();
  // Dynamic: a small portfolio of trail-selection strategies, the best plan kept (fewest
  // violations, then trails, then travel). Each run is deterministic.
  std::vector<Strategy> strategies = {Strategy::Nearest};
  if (params.method == AeroMethod::Dynamic && params.collisions)
    strategies = {Strategy::Lowest, Strategy::Mean, Strategy::Continue, Strategy::Nearest};
  const AeroResult base = r;
  bool have = false;
  for (std::size_t k = 0; k < strategies.size(); ++k) {
    params.progress("plan", static_cast<double>(k) / static_cast<double>(strategies.size()));
    AeroResult trial = base;
    Planner planner(g, params.collisions ? &blocking : nullptr, dir, strategies[k], trial,
                    params.progress);
    if (params.method == AeroMethod::Groups || !params.collisions)
      planner.run_groups();
    else
      planner.run_dynamic();
    trial.strategy = to_string(strategies[k]);
    auto key = [](const AeroResult& x) {
      return std::make_tuple(x.violations.size(), x.trails.trails.size(), x.travel_length);
    };
    if (!have || key(trial) < key(r)) r = std::move(trial);
    have = true;
  }
  r.seconds_planning = since(t1);
  for (const auto& t : r.trails.trails) r.max_trail_edges = std::max(r.max_trail_edges, t.edges.size());
  if (!r.violations.empty()) {
    for (const auto& v : r.violations)
      diag.warn("collision_unavoidable",
                "no strut could be printed without obstructing a remaining one: printed strut " +
                    std::to_string(v.edge) + " (the lowest) anyway; it obstructs " +
                    std::to_string(v.obstructs) + " later strut(s)");
  }
  params.progress("plan", 1);
  return r;
}

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

std::string aero_report_json(const AeroResult& r, const AeroParams& p, const Diagnostics& diag,
                             const AeroReportInput& in) {
  nlohmann::ordered_json j;
  j["planner"] = "aero";
  j["method"] = to_string(p.method);
  j["strategy"] = r.strategy;
  j["collision_model"] = p.collisions;
  j["nozzle"] = {{"radius_mm", p.nozzle.radius},
                 {"tip_clearance_mm", p.nozzle.tip_clearance},
                 {"node_clearance_mm", p.nozzle.node_clearance},
                 {"cone_half_angle_deg", p.nozzle.cone_half_angle_deg}};
  j["input"] = in.lattice;
  j["nodes"] = in.nodes;
  j["struts"] = in.edges;
  j["groups"] = r.groups;
  j["group_sizes"] = r.group_sizes;
  j["trails"] = r.trails.trails.size();
  j["lower_bound_trails"] = r.lower_bound_trails;
  j["travel_moves"] = r.travel_moves;
  j["travel_length_mm"] = r.travel_length;
  j["max_trail_edges"] = r.max_trail_edges;
  j["print_length_mm"] = r.trails.total_length();
  j["steep_struts_bottom_up"] = r.steep_struts;
  j["blocking_relations"] = r.blocking_relations;
  j["pairs_tested"] = r.pairs_tested;
  if (in.checked_collisions >= 0) j["collisions"] = in.checked_collisions;
  j["struts_printed_once"] = in.checked_once;
  nlohmann::ordered_json v = nlohmann::ordered_json::array();
  for (const auto& x : r.violations) v.push_back({{"strut", x.edge}, {"obstructs", x.obstructs}});
  j["violations"] = std::move(v);
  j["seconds"] = {{"collision_model", r.seconds_blocking},
                  {"planning", r.seconds_planning},
                  {"total", in.seconds}};
  nlohmann::ordered_json w;
  w["count"] = diag.total();
  w["by_kind"] = diag.counts();
  std::vector<std::string> messages;
  for (const auto& m : diag.messages()) messages.push_back(m.kind + ": " + m.text);
  w["messages"] = messages;
  j["warnings"] = std::move(w);
  return j.dump(2) + "\n";
}

}  // namespace trellis
