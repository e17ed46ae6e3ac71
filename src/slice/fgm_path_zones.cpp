// Path order (FgmOrder::Paths): the zones a layer's paths are cut at (colour bands, with
// zippering the overlap bands around each band edge), the cutting of one layer's paths, and
// Strategy 2's islands filled whole and cut the same way.
#include <algorithm>
#include <cmath>

#include "fgm_internal.hpp"
#include "fgm_outline.hpp"

namespace trellis::fgm {

PathZones path_zones(Evaluator& ev, double z, Vec2 zlo, Vec2 zhi, const FgmOptions& o,
                     double beta) {
  const double res = std::max(o.material_resolution, o.bead_width / 2);
  PathZones pz;
  const int d = o.palette.divisions();
  for (int k = 1; k < d; ++k) {
    if (beta > 0) {
      pz.levels.push_back(o.palette.level(k) - beta / 2);
      pz.levels.push_back(o.palette.level(k) + beta / 2);
    } else {
      pz.levels.push_back(o.palette.level(k));
    }
  }
  if (o.palette.materials == 3) {
    pz.zones.resize(static_cast<std::size_t>(o.palette.colors));
    for (int c = 0; c < o.palette.colors; ++c) pz.zones[static_cast<std::size_t>(c)] = {c, c, 0};
    for (std::size_t m = 0; m < 3; ++m)
      pz.below[m] = below_sets(ev, z, zlo, zhi, m, pz.levels, res, 1e-4);
  } else {
    for (std::size_t k = 0; k <= pz.levels.size(); ++k) {
      const int c = beta > 0 ? static_cast<int>(k / 2) : static_cast<int>(k);
      pz.zones.push_back({c, beta > 0 && k % 2 ? c + 1 : c, 0});  // odd with β: overlap c | c+1
    }
    pz.below[0] = below_sets(ev, z, zlo, zhi, 0, pz.levels, res, 1e-4);
  }
  return pz;
}

// One layer in path order (FgmOrder::Paths): the planar paths cut where they cross the zones'
// edges (the contours of the sets below[m][k] = {fraction m <= level k}), each run coloured by
// the design at its middle (two materials: the zone between the levels; three: the palette's
// triangle), short runs merged along their bead, a tool changer's pieces grouped by tool.
std::vector<Piece> path_order_layer(const Layer& planar, const std::vector<Regions> (&below)[3],
                                    const std::vector<double>& levels, std::vector<Zone>& zones,
                                    Evaluator& ev, double z, std::size_t g, const FgmOptions& o,
                                    Vec2 zlo, Vec2 zhi, FgmStats& shorts) {
  std::vector<std::vector<Vec2>> rings;
  for (const auto& sets : below)
    for (const Regions& r : sets)
      for (auto& ring : rings_of(r)) rings.push_back(std::move(ring));
  fgm::EdgeGrid edges(rings, zlo, zhi);
  const bool three = o.palette.materials == 3;
  const std::size_t nm = ev.field().materials().size();
  std::vector<Vec3> q;
  std::vector<double> f, fk;
  auto zones_at = [&](const std::vector<Vec2>& p, std::vector<int>& out) {
    q.resize(p.size());
    for (std::size_t k = 0; k < p.size(); ++k) q[k] = {p[k].x, p[k].y, z};
    f.resize(p.size() * nm);
    ev.fractions(q.data(), q.size(), f.data());
    out.resize(p.size());
    for (std::size_t k = 0; k < p.size(); ++k) {
      const double* fr = f.data() + k * nm;
      if (three) {
        fk.assign(fr, fr + nm);
        out[k] = o.palette.color_of(fk);
      } else {
        const double v = nm == 0 ? 0.0 : fr[0];
        out[k] =
            static_cast<int>(std::lower_bound(levels.begin(), levels.end(), v) - levels.begin());
      }
    }
  };
  auto colour_of = [&](int zone) {
    Zone& zn = zones[static_cast<std::size_t>(zone)];
    return zn.count++ % 2 ? zn.b : zn.a;
  };
  auto pieces = fgm::split_paths(planar.paths, edges, zones_at, colour_of, o.palette);
  if (o.min_segment > 0)
    // The faces' edges follow the iso-lines to 1e-4 of a band (below_sets): a run that only
    // grazes the next band is within the bound to that tolerance.
    fgm::merge_short_runs(pieces, ev, z, o.palette, o.min_segment, 1e-4 * o.palette.band(), shorts);
  if (o.tool_changer && !pieces.empty()) {
    Vec2 cursor = pieces.front().path.points.front().xy();
    fgm::group_by_tool(pieces, g % 2 == 1, cursor);
  }
  shorts.short_kept = shorts.short_beads = 0;
  if (o.min_segment > 0)
    for (std::size_t k = 0; k < pieces.size(); ++k) {
      const bool short_piece = pieces[k].path.length() < o.min_segment;
      const bool bead =
          !pieces[k].path.joined && (k + 1 == pieces.size() || !pieces[k + 1].path.joined);
      shorts.short_kept += short_piece;
      shorts.short_beads += short_piece && bead;
    }
  return pieces;
}

// Strategy 2 in path order, one layer: each island filled whole (fgm_outline.hpp), the beads
// cut where they cross the colour zones' edges into joined pieces with their colour's mixture
// (path_order_layer, Strategy 1's cutter; no zippering).
void outline_layer(Evaluator& ev, const LayerOutline& lo, std::size_t g, const FgmOptions& o,
                   Layer& layer, std::vector<int>& colours, std::size_t& faces, FgmStats& shorts) {
  const double res = std::max(o.material_resolution, o.bead_width / 2);
  fgm::OutlineBeads beads = fgm::layer_beads(ev, lo, g, o);
  Layer uncut;
  uncut.z = layer.z;
  uncut.paths = std::move(beads.paths);
  if (uncut.paths.empty()) return;
  BBox3 box;
  for (const auto& p : uncut.paths)
    for (const auto& q : p.points) box.add({q.x, q.y, 0});
  const Vec2 zlo{box.min.x - 2 * res, box.min.y - 2 * res};
  const Vec2 zhi{box.max.x + 2 * res, box.max.y + 2 * res};
  PathZones pz = path_zones(ev, lo.z, zlo, zhi, o, 0);
  FgmOptions po = o;
  po.zipper = 0;
  auto pieces =
      path_order_layer(uncut, pz.below, pz.levels, pz.zones, ev, lo.z, g, po, zlo, zhi, shorts);
  fgm::apply_flow(pieces, beads.flow, o.bead_width);
  for (auto& piece : pieces) {
    colours.push_back(piece.color);
    layer.paths.push_back(std::move(piece.path));
  }
  for (const auto& zone : pz.zones) faces += zone.count > 0;
}

}  // namespace trellis::fgm
