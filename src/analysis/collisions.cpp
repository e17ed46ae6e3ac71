#include "trellis/analysis/collisions.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <unordered_map>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

constexpr std::uint32_t kNone = UINT32_MAX;

// Nearest design node within `snap` of a point (hash grid of cell 2·snap).
class NodeSnap {
 public:
  NodeSnap(const Graph& g, double snap) : g_(g), snap_(snap), cell_(std::max(2 * snap, 1e-9)) {
    for (NodeId n = 0; n < g.nodes.size(); ++n) cells_[key(g.nodes[n])].push_back(n);
  }
  std::uint32_t find(Vec3 p) const {
    const auto cx = cell(p.x), cy = cell(p.y), cz = cell(p.z);
    std::uint32_t best = kNone;
    double best_d = snap_;
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          auto it = cells_.find(pack(cx + dx, cy + dy, cz + dz));
          if (it == cells_.end()) continue;
          for (NodeId n : it->second) {
            const double d = distance(p, g_.nodes[n]);
            if (d <= best_d) {
              best_d = d;
              best = n;
            }
          }
        }
    return best;
  }

 private:
  long long cell(double v) const { return static_cast<long long>(std::floor(v / cell_)); }
  static std::uint64_t pack(long long x, long long y, long long z) {
    return (static_cast<std::uint64_t>(x & 0x1FFFFF) << 42) |
           (static_cast<std::uint64_t>(y & 0x1FFFFF) << 21) |
           static_cast<std::uint64_t>(z & 0x1FFFFF);
  }
  std::uint64_t key(Vec3 p) const { return pack(cell(p.x), cell(p.y), cell(p.z)); }
  const Graph& g_;
  double snap_, cell_;
  std::unordered_map<std::uint64_t, std::vector<NodeId>> cells_;
};

}  // namespace

CollisionCheck check_collisions(const Graph& design, const Toolpath& toolpath,
                                const CheckOptions& options) {
  options.nozzle.validate();
  if (!(options.snap > 0) || !std::isfinite(options.snap))
    throw SettingError("the snap distance must be positive");
  CollisionCheck c;
  c.struts = design.edges.size();
  // Every printed segment in print order, with its design nodes and strut.
  struct Seg {
    std::size_t path, index, layer;
    std::uint32_t na, nb;
    long long strut;
  };
  std::vector<Vec3> ends;
  std::vector<Seg> segs;
  // A planar design (a 2D lattice, every node at one z) is printed layer by layer at the layers'
  // heights: each layer's segments are matched in the design's plane, and every strut is due
  // once per printed layer.
  const bool planar = !design.nodes.empty() &&
                      std::all_of(design.nodes.begin(), design.nodes.end(), [&](const Vec3& n) {
                        return std::abs(n.z - design.nodes.front().z) <= 1e-9;
                      });
  std::size_t printed_layers = 0;
  for (const auto& layer : toolpath.layers) {
    const std::size_t before = segs.size();
    for (const auto& path : layer.paths) {
      for (std::size_t i = 0; i + 1 < path.points.size(); ++i) {
        if (distance(path.points[i], path.points[i + 1]) <= 0) continue;
        ends.push_back(path.points[i]);
        ends.push_back(path.points[i + 1]);
        segs.push_back({c.paths, i, printed_layers, kNone, kNone, -1});
      }
      ++c.paths;
    }
    if (segs.size() > before) ++printed_layers;
  }
  // A design of planar layers stacked (GIPPO parts of many layers: every strut level, as many
  // levels as printed layers): printed layer k is matched in the plane of level k, as a single
  // planar design is (the nozzle prints a layer one layer height above its design plane).
  std::vector<double> levels;
  const bool flat_struts = std::all_of(
      design.edges.begin(), design.edges.end(),
      [&](const Edge& e) { return std::abs(design.nodes[e.a].z - design.nodes[e.b].z) <= 1e-9; });
  if (!planar && flat_struts) {
    for (const Vec3& n : design.nodes) levels.push_back(n.z);
    std::sort(levels.begin(), levels.end());
    levels.erase(std::unique(levels.begin(), levels.end(),
                             [](double a, double b) { return std::abs(a - b) <= 1e-9; }),
                 levels.end());
    if (levels.size() != printed_layers) levels.clear();
  }
  const int due = planar ? static_cast<int>(std::max<std::size_t>(printed_layers, 1)) : 1;
  auto in_plane = [&](Vec3 p, std::size_t layer) {
    if (planar) p.z = design.nodes.front().z;
    if (!levels.empty()) p.z = levels[layer];
    return p;
  };
  c.segments = segs.size();
  const NodeSnap snap(design, options.snap);
  std::unordered_map<std::uint64_t, EdgeId> strut_of;
  strut_of.reserve(design.edges.size() * 2);
  auto pair_key = [](std::uint32_t a, std::uint32_t b) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
  };
  for (EdgeId e = 0; e < design.edges.size(); ++e)
    strut_of[pair_key(design.edges[e].a, design.edges[e].b)] = e;
  std::vector<int> times(design.edges.size(), 0);
  for (std::size_t i = 0; i < segs.size(); ++i) {
    Seg& s = segs[i];
    s.na = snap.find(in_plane(ends[2 * i], s.layer));
    s.nb = snap.find(in_plane(ends[2 * i + 1], s.layer));
    if (s.na != kNone && s.nb != kNone) {
      auto it = strut_of.find(pair_key(s.na, s.nb));
      if (it != strut_of.end()) s.strut = it->second;
    }
  }
  // A strut printed as a polyline (laid on a surface, its points between the two nodes at no
  // node): the run of a path's segments from node to node is that strut, printed once.
  std::vector<char> continued(segs.size(), 0);
  for (std::size_t i = 0; i < segs.size(); ++i) {
    if (segs[i].strut >= 0 || segs[i].na == kNone || segs[i].nb != kNone) continue;
    std::size_t j = i;
    while (segs[j].nb == kNone && j + 1 < segs.size() && segs[j + 1].path == segs[i].path) ++j;
    if (segs[j].nb != kNone)
      if (const auto it = strut_of.find(pair_key(segs[i].na, segs[j].nb)); it != strut_of.end())
        for (std::size_t k = i; k <= j; ++k) segs[k].strut = it->second, continued[k] = k > i;
    i = j;
  }
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const Seg& s = segs[i];
    if (s.strut < 0) {
      ++c.off_design_segments;
      continue;
    }
    if (!continued[i]) ++times[static_cast<std::size_t>(s.strut)];
    const Vec3 a = ends[2 * i], b = ends[2 * i + 1];
    if (is_steep(a, b, options.nozzle) && b.z < a.z)
      c.top_down.push_back({s.path, static_cast<EdgeId>(s.strut)});
  }
  for (EdgeId e = 0; e < design.edges.size(); ++e) {
    if (times[e] < due) c.missing.push_back(e);  // planar: missing from some layer
    if (times[e] > due) c.repeated.push_back(e);
    if (times[e] == due) ++c.printed_once;
  }
  // Replay: each segment's tip sweep against every segment printed before it.
  const FootprintIndex index(ends, options.nozzle.radius);
  // Measured: 25,000 moves piled on one 10 mm span, 1.25e9 candidate visits in 1.35 s of CPU,
  // most of them the cheap ones (below the tip); one that tests the nozzle costs more: 5 ns.
  Estimate e;
  e.seconds = index.visits() * 5e-9;
  e.what = fmt::format("replaying {} segments against the nozzle ({:.3g} candidate pairs)",
                       segs.size(), index.visits());
  e.change = "the print (check it in parts: a layer range, or fewer paths)";
  check_budget(e, options.budget);
  std::vector<std::uint32_t> stamp(segs.size(), 0);
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const Seg& s = segs[i];
    const Vec3 qa = ends[2 * i], qb = ends[2 * i + 1];
    const double qz = std::min(qa.z, qb.z) + options.nozzle.tip_clearance;
    std::vector<std::uint32_t> hits;
    index.for_candidates(qa, qb, stamp, static_cast<std::uint32_t>(i + 1), [&](std::uint32_t j) {
      if (j >= i) return;
      const Seg& t = segs[j];
      if (s.strut >= 0 && t.strut == s.strut) return;  // the same strut again: a repeat
      const Vec3 pa = ends[2 * j], pb = ends[2 * j + 1];
      if (std::max(pa.z, pb.z) <= qz) return;
      ++c.pairs_tested;
      Vec3 shared[2];
      int n = 0;
      if (t.na != kNone && (t.na == s.na || t.na == s.nb)) shared[n++] = design.nodes[t.na];
      if (t.nb != kNone && (t.nb == s.na || t.nb == s.nb)) shared[n++] = design.nodes[t.nb];
      Contact contact;
      if (!nozzle_hits(options.nozzle, qa, qb, pa, pb, shared, n, &contact)) return;
      ++c.collisions;
      if (c.hits.size() < options.max_listed)
        c.hits.push_back(
            {s.path, s.index, s.strut, t.strut, t.path, t.index, contact.tip, contact.point});
    });
  }
  return c;
}

std::string collision_check_json(const CollisionCheck& c, const CheckOptions& options) {
  using nlohmann::ordered_json;
  ordered_json j;
  j["ok"] = c.ok();
  j["nozzle"] = {{"radius_mm", options.nozzle.radius},
                 {"tip_clearance_mm", options.nozzle.tip_clearance},
                 {"node_clearance_mm", options.nozzle.node_clearance},
                 {"cone_half_angle_deg", options.nozzle.cone_half_angle_deg},
                 {"snap_mm", options.snap}};
  j["paths"] = c.paths;
  j["segments"] = c.segments;
  j["struts"] = c.struts;
  j["struts_printed_once"] = c.printed_once;
  j["missing_struts"] = c.missing;
  j["repeated_struts"] = c.repeated;
  j["off_design_segments"] = c.off_design_segments;
  j["collisions"] = c.collisions;
  ordered_json hits = ordered_json::array();
  auto pt = [](Vec3 p) { return std::vector<double>{p.x, p.y, p.z}; };
  for (const auto& h : c.hits)
    hits.push_back({{"path", h.path},
                    {"segment", h.segment},
                    {"strut", h.strut},
                    {"hit_strut", h.hit_strut},
                    {"hit_path", h.hit_path},
                    {"tip", pt(h.tip)},
                    {"point", pt(h.point)}});
  j["collision_list"] = std::move(hits);
  ordered_json td = ordered_json::array();
  for (const auto& [path, strut] : c.top_down) td.push_back({{"path", path}, {"strut", strut}});
  j["steep_struts_printed_top_down"] = std::move(td);
  j["pairs_tested"] = c.pairs_tested;
  return j.dump(2) + "\n";
}

}  // namespace trellis
