#include "trellis/analysis/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/profile.hpp"

namespace trellis {

void CountingSink::extrude(Vec3 a, Vec3 b, double e, double feed) {
  const double len = distance(a, b);
  ++counts.extrusion_moves;
  const Vec3 gap = a - last_;
  const bool run_starts = state_ != State::Extruding || dot(gap, gap) > 1e-18;
  if (run_starts) {
    close_path();
    ++counts.extrusion_starts;
  }
  if (run_starts || attribute_changed_) {
    // A new path of the IR: the same layer rule as the IR builder (gcode_reader.cpp).
    ++counts.toolpath_paths;
    attribute_changed_ = false;
    if (counts.layers == 0 || layer_pending_ || (!commented_ && std::abs(a.z - layer_z_) > 1e-4)) {
      ++counts.layers;
      layer_z_ = a.z;
      layer_pending_ = false;
      counts.per_layer.push_back({a.z, 0, std::exchange(early_retractions_, 0), 0, 0});
    }
  }
  if (run_starts) ++counts.per_layer.back().starts;
  path_length_ += len;
  ++path_edges_;
  if (state_ == State::Travelling && extruded_) {
    // A run of non-extruding moves between two extrusions is one travel move.
    ++counts.travel_moves;
    counts.travel_length += pending_;
    ++counts.per_layer.back().travel_moves;
    counts.per_layer.back().travel_length += pending_;
  }
  pending_ = 0;
  state_ = State::Extruding;
  extruded_ = true;
  last_ = b;
  counts.extruded_length += len;
  counts.filament += e;
  if (part_ >= 0) {
    auto& p = counts.parts[static_cast<std::size_t>(part_)];
    p.extruded_length += len;
    p.filament += e;
  }
}

void CountingSink::prime(Vec3 a, Vec3 b, double e, double) {
  counts.prime_length += distance(a, b);
  counts.prime_filament += e;
}

void CountingSink::time_sink_heater(int heater, double celsius, bool wait) {
  if (!wait) return time_.set_target(heater, celsius);
  if (heater == kAllHeaters) return time_.wait_all();
  time_.wait_for(heater, celsius);
}

void CountingSink::object(std::string_view label) {
  attribute_changed_ = true;
  part_ = -1;
  time_.set_tag(-1);
  if (label.empty()) return;
  const auto it = std::find_if(counts.parts.begin(), counts.parts.end(),
                               [&](const GcodeCounts::Part& p) { return p.label == label; });
  part_ = it - counts.parts.begin();
  if (it == counts.parts.end()) counts.parts.push_back({std::string(label)});
  time_.set_tag(static_cast<int>(part_));
}

void CountingSink::travel(Vec3 a, Vec3 b, double feed) {
  state_ = State::Travelling;
  pending_ += distance_xy(a, b);
}

void CountingSink::close_path() {
  if (path_edges_ == 0) return;
  ++counts.paths;
  const double w = path_length_ * static_cast<double>(path_edges_);
  counts.weighted += w;
  if (path_edges_ + 1 >= long_nodes_) {
    counts.long_length += path_length_;
    counts.long_weighted += w;
  }
  path_length_ = 0;
  path_edges_ = 0;
}

void CountingSink::finish() {
  close_path();
  counts.print_time_s = time_.seconds();
  counts.heating_s = time_.heating_s();
  const auto& tags = time_.tag_seconds();
  for (std::size_t i = 0; i < counts.parts.size(); ++i)
    counts.parts[i].print_time_s = i < tags.size() ? tags[i] : 0.0;
}

bool continues_run(const Path* prev, const Path& p) {
  // (A laser's scan vectors are paths each: power is on, not extrusion.)
  return prev && !prev->points.empty() && !p.points.empty() && !(p.power > 0) &&
         distance(prev->points.back(), p.points.front()) <= 1e-9 && (p.joined || p.via.empty());
}

std::size_t run_count(const Toolpath& toolpath) {
  std::size_t n = 0;
  const Path* prev = nullptr;
  for (const auto& l : toolpath.layers)
    for (const auto& p : l.paths) {
      if (p.points.size() < 2) continue;
      n += !continues_run(prev, p);
      prev = &p;
    }
  return n;
}

GcodeCounts toolpath_counts(const Toolpath& toolpath) {
  CountingSink sink;
  bool first = true;
  Vec3 at;
  for (const auto& layer : toolpath.layers) {
    sink.layer_change(layer.z);
    for (const auto& p : layer.paths) {
      sink.role(p.role);
      // A path that starts where the last one ended continues its run, as the writer prints it
      // (no travel between them: machine/gcode_writer.cpp).
      const bool moves =
          !p.points.empty() && (!p.via.empty() || distance_xy(at, p.points.front()) >= 1e-9 ||
                                std::abs(at.z - p.points.front().z) >= 1e-9);
      if (!first && !p.joined && moves) {
        for (const Vec3& v : p.via) sink.travel(at, v, 0), at = v;
        sink.travel(at, p.points.front(), 0);
      }
      for (std::size_t i = 1; i < p.points.size(); ++i) {
        sink.motion(p.points[i - 1], p.points[i], 0, p.speed);
        sink.extrude(p.points[i - 1], p.points[i], 0, p.speed);
      }
      if (!p.points.empty()) at = p.points.back(), first = false;
    }
  }
  sink.finish();
  return sink.counts;
}

void CountingSink::retract() {
  ++counts.retractions;
  if (counts.per_layer.empty())
    ++early_retractions_;
  else
    ++counts.per_layer.back().retractions;
  if (state_ == State::Extruding) state_ = State::Idle;
}

namespace {

struct Seg {
  Vec2 a, b;
  std::size_t path;
};

// Uniform grid of segment ids over the plane.
class SegmentGrid {
 public:
  // Each segment goes into the cells within one cell of it, found by walking along it (so a
  // long segment costs its length in cells, not its bounding box).
  SegmentGrid(const std::vector<Seg>& segs, double cell) : segs_(segs), cell_(cell) {
    for (std::size_t i = 0; i < segs.size(); ++i) {
      const Seg& s = segs[i];
      const double len = std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
      const int steps = static_cast<int>(std::ceil(len / (cell / 2))) + 1;
      for (int k = 0; k <= steps; ++k) {
        const double t = static_cast<double>(k) / steps;
        const long cx = key(s.a.x + (s.b.x - s.a.x) * t), cy = key(s.a.y + (s.b.y - s.a.y) * t);
        for (long dx = -1; dx <= 1; ++dx)
          for (long dy = -1; dy <= 1; ++dy) {
            auto& v = cells_[hash(cx + dx, cy + dy)];
            if (v.empty() || v.back() != i) v.push_back(i);
          }
      }
    }
  }
  template <class Fn>
  void near(Vec2 p, Fn fn) const {
    auto it = cells_.find(hash(key(p.x), key(p.y)));
    if (it == cells_.end()) return;
    for (std::size_t i : it->second) fn(i, segs_[i]);
  }

 private:
  long key(double v) const { return static_cast<long>(std::floor(v / cell_)); }
  static long long hash(long x, long y) { return static_cast<long long>(x) * 2654435761LL + y; }
  const std::vector<Seg>& segs_;
  double cell_;
  std::unordered_map<long long, std::vector<std::size_t>> cells_;
};

double seg_distance(Vec2 p, const Seg& s) {
  return distance_to_segment({p.x, p.y, 0}, {s.a.x, s.a.y, 0}, {s.b.x, s.b.y, 0});
}

double abs_cos(const Seg& s, Vec2 dir) {
  const double dx = s.b.x - s.a.x, dy = s.b.y - s.a.y, l = std::hypot(dx, dy);
  return l > 0 ? std::abs((dx * dir.x + dy * dir.y) / l) : 0;
}

// Radius around each design node where struts necessarily overlap: w / (2 sin(θ/2)) for the
// smallest angle θ between its struts, within [w/2, 3w].
std::vector<double> node_zones(const Graph& g, const std::vector<EdgeId>& edges, double w) {
  std::unordered_map<NodeId, std::vector<Vec2>> dirs;
  for (EdgeId e : edges) {
    const Vec3 a = g.nodes[g.edges[e].a], b = g.nodes[g.edges[e].b];
    const double l = distance_xy(a, b);
    if (l <= 0) continue;
    dirs[g.edges[e].a].push_back({(b.x - a.x) / l, (b.y - a.y) / l});
    dirs[g.edges[e].b].push_back({(a.x - b.x) / l, (a.y - b.y) / l});
  }
  std::vector<double> zone(g.nodes.size(), w / 2);
  for (const auto& [n, d] : dirs) {
    double min_angle = std::numbers::pi;
    for (std::size_t i = 0; i < d.size(); ++i)
      for (std::size_t j = i + 1; j < d.size(); ++j)
        min_angle = std::min(min_angle,
                             std::acos(std::clamp(d[i].x * d[j].x + d[i].y * d[j].y, -1.0, 1.0)));
    zone[n] = std::clamp(w / (2 * std::sin(std::max(min_angle, 1e-3) / 2)), w / 2, 3 * w);
  }
  return zone;
}

void analyse_layer(const Graph& g, const std::vector<EdgeId>& edges, const Layer& layer,
                   const AnalysisParams& p, LayerAnalysis& out) {
  const double w = p.width;
  std::vector<Seg> printed, design;
  for (std::size_t pi = 0; pi < layer.paths.size(); ++pi)
    for (std::size_t k = 1; k < layer.paths[pi].points.size(); ++k)
      printed.push_back({layer.paths[pi].points[k - 1].xy(), layer.paths[pi].points[k].xy(), pi});
  for (EdgeId e : edges)
    design.push_back({g.nodes[g.edges[e].a].xy(), g.nodes[g.edges[e].b].xy(), e});
  // Cells of about a bead, but at most ~512 across the layer (bounded work on absurd inputs).
  BBox3 box;
  for (const auto& q : printed) box.add({q.a.x, q.a.y, 0}), box.add({q.b.x, q.b.y, 0});
  for (const auto& q : design) box.add({q.a.x, q.a.y, 0}), box.add({q.b.x, q.b.y, 0});
  const double extent = box.empty() ? 0 : std::max(box.max.x - box.min.x, box.max.y - box.min.y);
  const double cell = std::max({w, 0.25, extent / 512});
  // Samples a quarter bead apart, but at most ~8192 across the layer (the same for any print
  // under 800 mm at a 0.4 mm bead; bounded work on a read-back move metres long).
  const double step = std::max(w / 4, extent / 8192);
  const SegmentGrid pgrid(printed, cell), dgrid(design, cell);
  const auto zone = node_zones(g, edges, w);
  std::vector<std::size_t> seen;
  for (std::size_t di = 0; di < design.size(); ++di) {
    const Seg& d = design[di];
    const Edge& e = g.edges[d.path];
    const double len = std::hypot(d.b.x - d.a.x, d.b.y - d.a.y);
    out.nominal_length += len;
    if (len <= 0) continue;
    const Vec2 dir{(d.b.x - d.a.x) / len, (d.b.y - d.a.y) / len};
    double from = zone[e.a], to = len - zone[e.b];
    if (to <= from) from = to = len / 2;  // short strut: test its midpoint only
    const int n = std::max(1, static_cast<int>(std::ceil((to - from) / step)));
    int covered = 0;
    for (int k = 0; k <= n; ++k) {
      const double t = from + (to - from) * k / n;
      const Vec2 q{d.a.x + dir.x * t, d.a.y + dir.y * t};
      seen.clear();
      pgrid.near(q, [&](std::size_t, const Seg& s) {
        if (seg_distance(q, s) <= w / 2 && abs_cos(s, dir) >= p.parallel_cos &&
            std::find(seen.begin(), seen.end(), s.path) == seen.end())
          seen.push_back(s.path);
      });
      if (!seen.empty()) ++covered;
      if (seen.size() > 1) {
        const double piece = (to - from) / n;
        out.double_length += piece * static_cast<double>(seen.size() - 1);
        out.doubles.push_back({{q.x - dir.x * piece / 2, q.y - dir.y * piece / 2},
                               {q.x + dir.x * piece / 2, q.y + dir.y * piece / 2}});
      }
    }
    if (static_cast<double>(covered) / (n + 1) < p.min_covered) out.missing.push_back(d.path);
  }
  for (const auto& s : printed) {
    const double len = std::hypot(s.b.x - s.a.x, s.b.y - s.a.y);
    out.extruded_length += len;
    const int n = std::max(1, static_cast<int>(std::ceil(len / step)));
    for (int k = 0; k < n; ++k) {
      const double t = (k + 0.5) / n;
      const Vec2 q{s.a.x + (s.b.x - s.a.x) * t, s.a.y + (s.b.y - s.a.y) * t};
      bool near = false;
      dgrid.near(q, [&](std::size_t, const Seg& d) { near |= seg_distance(q, d) <= w / 2 + 1e-6; });
      if (!near) out.off_design_length += len / n;
    }
  }
  out.design_edges = edges.size();
  out.missing_edges = out.missing.size();
}

}  // namespace

Analysis analyze(const Toolpath& printed_in, const GcodeCounts& counts, const Graph* design,
                 const AnalysisParams& p) {
  if (!(p.width > 0)) throw SettingError("bead width must be > 0 mm");
  Analysis a;
  a.printed = printed_in;  // the one copy: aligned in place, kept for pictures
  Toolpath& printed = a.printed;
  if (design) {
    // Slicers place parts on the bed: move the print's XY centre onto the design's, on request or
    // when most of the print lies outside the design's XY box.
    BBox3 pb;
    for (const auto& l : printed.layers)
      for (const auto& path : l.paths)
        for (const auto& q : path.points) pb.add(q);
    const BBox3 db = design->bbox();
    if (!pb.empty() && !db.empty()) {
      // Outside: less than half of the extruded length (by segment midpoints) lies in the
      // design's XY box grown by a bead width; a few stray deposits do not count.
      double inside = 0, total = 0;
      for (const auto& l : printed.layers)
        for (const auto& path : l.paths)
          for (std::size_t k = 1; k < path.points.size(); ++k) {
            const Vec3 m = (path.points[k - 1] + path.points[k]) * 0.5;
            const double len = distance_xy(path.points[k - 1], path.points[k]);
            total += len;
            if (m.x >= db.min.x - p.width && m.x <= db.max.x + p.width &&
                m.y >= db.min.y - p.width && m.y <= db.max.y + p.width)
              inside += len;
          }
      const bool outside = total > 0 && inside < 0.5 * total;
      if (p.align_centers || (p.auto_align && outside)) {
        const double dx = db.center().x - pb.center().x, dy = db.center().y - pb.center().y;
        for (auto& l : printed.layers)
          for (auto& path : l.paths)
            for (auto& q : path.points) q = {q.x + dx, q.y + dy, q.z};
        a.shift = {dx, dy};
        a.auto_aligned = !p.align_centers;
      }
    }
  }
  a.counts = counts;
  // Eq. 1-3 over the printed paths, from the streaming sums.
  a.paths = counts.paths;
  a.edges_real = counts.extrusion_moves;
  a.extruded_length = counts.extruded_length;
  if (a.paths && a.extruded_length > 0) {
    a.score = counts.weighted / (a.extruded_length * static_cast<double>(a.paths));
    a.lts = 100 * counts.long_length / a.extruded_length;
    a.oe = 100 * counts.long_weighted / (a.extruded_length * static_cast<double>(a.edges_real));
  }
  a.score_corrected = a.score;
  if (!design) return a;
  a.has_design = true;
  // Design levels (planar struts grouped by z), matched to printed layers by nozzle height.
  std::vector<std::pair<double, std::vector<EdgeId>>> levels;
  for (EdgeId e = 0; e < design->edges.size(); ++e) {
    const double z = design->nodes[design->edges[e].a].z;
    auto it = std::find_if(levels.begin(), levels.end(),
                           [&](auto& l) { return std::abs(l.first - z) < 1e-6; });
    if (it == levels.end())
      levels.push_back({z, {e}});
    else
      it->second.push_back(e);
  }
  // Each level's least number of paths (its struts alone, as a graph).
  std::vector<std::size_t> level_bound;
  for (const auto& [z, edges] : levels) {
    Graph g;
    std::unordered_map<NodeId, NodeId> index;
    auto node = [&](NodeId n) {
      auto [it, fresh] = index.try_emplace(n, static_cast<NodeId>(g.nodes.size()));
      if (fresh) g.nodes.push_back(design->nodes[n]);
      return it->second;
    };
    for (EdgeId e : edges) {
      Edge copy = design->edges[e];
      copy.a = node(copy.a);
      copy.b = node(copy.b);
      g.edges.push_back(copy);
    }
    level_bound.push_back(lower_bound_paths(g));
  }
  std::vector<bool> used(levels.size(), false);
  for (const auto& layer : printed.layers) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < levels.size(); ++i)
      if (std::abs(levels[i].first + p.layer_height - layer.z) <
          std::abs(levels[best].first + p.layer_height - layer.z))
        best = i;
    LayerAnalysis la;
    la.z = layer.z;
    analyse_layer(*design, levels[best].second, layer, p, la);
    la.lower_bound = level_bound[best];
    if (used[best]) la.nominal_length = 0;  // count each design level's length once
    used[best] = true;
    a.layers.push_back(std::move(la));
  }
  for (std::size_t i = 0; i < levels.size(); ++i)
    if (!used[i]) {  // a design level never printed: all of it is missing
      LayerAnalysis la;
      la.z = levels[i].first + p.layer_height;
      for (EdgeId e : levels[i].second) la.nominal_length += design->edge_length(e);
      la.missing = levels[i].second;
      la.design_edges = la.missing_edges = la.missing.size();
      la.lower_bound = level_bound[i];
      a.layers.push_back(std::move(la));
    }
  for (const auto& l : a.layers) {
    a.nominal_length += l.nominal_length;
    a.double_length += l.double_length;
    a.off_design_length += l.off_design_length;
    a.design_edges += l.design_edges;
    a.missing_edges += l.missing_edges;
  }
  a.edges_nominal = design->edges.size();
  a.extrusion_ratio = a.nominal_length > 0 ? a.extruded_length / a.nominal_length : 0;
  // Paper: Eq. 1 corrected by EdgesReal/EdgesNominal, so extra (split or doubled) segments do
  // not inflate the score.
  if (a.edges_real > 0)
    a.score_corrected = a.score / (static_cast<double>(a.edges_real) / a.edges_nominal);
  return a;
}

Analysis analyze_gcode_file(const std::string& path, const Graph* design,
                            const AnalysisParams& params, const GcodeReadOptions& read,
                            Diagnostics& diag) {
  CountingSink counter(params.long_nodes, params.acceleration);
  GcodeReadOptions options = read;
  if (params.acceleration > 0 && options.limits.acceleration == 0)
    options.limits.acceleration = params.acceleration;
  const GcodeReadOptions& read_with = options;
  Toolpath tp;
  const bool deposited = !read.commanded_mixtures;
  if (!design && !params.keep_printed) {
    // Counts only: constant memory whatever the file size.
    scan_gcode_file(path, counter, read_with, diag);
    // Mixtures as deposited need the IR (paths cut where they change): a second pass, for our
    // graded files with a look-ahead only (its warnings were counted in the first).
    if (deposited && counter.counts.mixture_lookahead > 0) {
      Diagnostics again;
      tp = read_gcode_file(path, read_with, again).toolpath;
    }
  } else {
    // One pass feeding both the counter and the IR builder (the design comparison needs the IR).
    tp = read_gcode_file(path, read_with, diag, &counter).toolpath;
  }
  counter.finish();
  if (deposited && counter.counts.mixture_lookahead > 0)
    counter.counts.toolpath_paths = tp.path_count();
  Analysis a = analyze(tp, counter.counts, design, params);
  a.name = path;
  return a;
}

std::string comparison_table(const std::vector<Analysis>& runs) {
  std::string out;
  char buf[512];
  std::snprintf(buf, sizeof buf, "%-36s %8s %8s %8s %9s %8s %9s %7s %7s %7s\n", "file", "ratio",
                "double", "off", "missing", "starts", "travel", "retr", "score", "score_c");
  out += buf;
  for (const auto& a : runs) {
    std::string name = a.name.size() > 36 ? "…" + a.name.substr(a.name.size() - 35) : a.name;
    std::snprintf(buf, sizeof buf,
                  "%-36s %8.3f %8.2f %8.2f %4zu/%-4zu %8zu %9.1f %7zu %7.3f %7.3f\n", name.c_str(),
                  a.extrusion_ratio, a.double_length, a.off_design_length, a.missing_edges,
                  a.design_edges, a.counts.extrusion_starts, a.counts.travel_length,
                  a.counts.retractions, a.score, a.score_corrected);
    out += buf;
  }
  return out;
}

}  // namespace trellis
