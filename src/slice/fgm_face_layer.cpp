// Strategy 2 face by face (the paper's), one layer: the layer's colour faces (palette order,
// reversed every other layer), each with a ring half a bead inside it, rings inward and 100 %
// lines along the material iso-lines inside them; the material balanced on a bead raster; the
// pieces chained into beads (face by face, or island by island in path order); travel between
// beads routed inside the part.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "fgm_fill.hpp"
#include "fgm_internal.hpp"
#include "trellis/slice/link.hpp"
#include "trellis/toolpath/order.hpp"

namespace trellis::fgm {

namespace {

// One face's rings and fill lines into `lines` (the outer ring's first; returns how many those
// are), the region half a bead inside it into `inner`.
std::size_t face_paths(const ColorFace& face, const FgmOptions& o,
                       const std::optional<IsoDirections>& directions, double fixed_angle,
                       Regions& inner, std::vector<std::vector<Vec2>>& lines) {
  // One ring half a bead inside the face (its bead reaches the face's edge, not beyond),
  // then concentric rings, or 100 % rectilinear lines inside the ring.
  // Sharp corners (mitred up to 20 half-beads): the ring and the gap fill reach as far into
  // an acute corner as a round bead can without leaving the face.
  inner = offset(face.region, -o.bead_width / 2, 0.002, 20);
  auto add_rings = [&](const Regions& r) {
    for (auto ring : rings_of(r)) {
      if (ring.size() < 2) continue;
      ring.push_back(ring.front());
      lines.push_back(std::move(ring));
    }
  };
  add_rings(inner);
  const std::size_t outer_rings = lines.size();
  // Rings inward a bead apart (concentric: until none fits; rectilinear: the paper's palette
  // plates have 3 perimeters and 100 % infill, §7.5, so a face narrower than that is printed
  // along its iso-lines by rings alone). Where the next ring does not fit, the gap under a
  // bead and a quarter left in the middle gets one ring 3/4 of a bead further in (a sliver's
  // ring runs there and back: keep_uncovered keeps one way), and no lines.
  Regions last = inner;
  bool centre_filled = false;
  for (int k = 1; o.concentric || k < o.perimeters; ++k) {
    Regions r = offset(last, -o.bead_width);
    // Less than 1/8 bead beyond the next ring's centre line: its ring would run around a
    // sliver (or split into specks); the 3/4 ring covers the centre instead.
    if (r.empty() || offset(last, -1.125 * o.bead_width).empty()) {
      add_rings(offset(last, -0.75 * o.bead_width));
      centre_filled = true;
      break;
    }
    add_rings(r);
    last = std::move(r);
  }
  if (!o.concentric && !centre_filled) {
    // The lines reach into the innermost ring's bead by the overlap (what it covers already
    // is trimmed below).
    const Regions fill = offset(last, -o.bead_width * (1 - o.fill_overlap));
    // The paper's Strategy 2 prints perpendicular to the gradient: the lines run along the
    // iso-lines, or at a fixed angle, +90° a layer, if asked. A part of the fill whose
    // iso-lines keep one direction (their spread at least orient_agree) is hatched at that
    // direction; a curved one by sectors of directions, each sector's lines continued across
    // the sector's edges into lanes. They are chained into beads after the material balance.
    std::vector<std::vector<Vec2>> runs;
    auto hatch_at = [&](const Regions& r, double angle) {
      for (const auto& seg : hatch(r, angle, o.bead_width))
        if (std::hypot(seg.b.x - seg.a.x, seg.b.y - seg.a.y) >= 0.05)
          runs.push_back({seg.a, seg.b});
    };
    if (o.fixed_angle) {
      hatch_at(fill, fixed_angle);
    } else {
      for (const auto& poly : fill) {
        const Regions one{poly};
        double spread = 0, coherence = 0;
        const double angle = directions->mean_angle(one, &spread, &coherence);
        // One direction where the iso-lines keep one, or where they have none (three
        // materials' iso-lines crossing: sectors would cut the lines every way).
        if (spread >= o.orient_agree || coherence < 0.5) {
          hatch_at(one, angle);
          continue;
        }
        for (auto& lane : fgm::join_lanes(
                 fgm::sector_lines(one, *directions, o.orient_sector, o.bead_width, 0.05, angle),
                 0.75 * o.bead_width, 1.5 * o.orient_sector))
          runs.push_back(std::move(lane));
      }
    }
    for (auto& run : runs) lines.push_back(std::move(run));
  }
  return outer_rings;
}

// The raster the kept beads are painted into (null for a layer too large for one: then every
// line is kept).
std::unique_ptr<BeadRaster> balance(const std::vector<ColorFace>& faces,
                                    const std::vector<Regions>& inners,
                                    const std::vector<std::size_t>& outer_rings,
                                    const FgmOptions& o,
                                    std::vector<std::vector<std::vector<Vec2>>>& face_lines) {
  // Material balance (the paper: "no additional material or time regardless of palette
  // size"): every face's outer ring, then its fill, then the gap fill, each kept only where its
  // bead mostly covers what no bead covers yet (keep_uncovered), so the volume extruded is the
  // faces' area × layer height at any palette size: fill lines end at the ring, a line beside
  // the ring nearer than half a bead goes, a ring of a face narrower than two beads does not
  // run back over itself.
  std::unique_ptr<BeadRaster> raster = layer_raster(faces, o.bead_width);
  if (raster) {
    const double min_piece = o.bead_width;
    std::vector<std::vector<std::vector<Vec2>>> kept(faces.size());
    auto keep = [&](std::size_t fi, const std::vector<Vec2>& line) {
      for (auto& piece : keep_uncovered(line, *raster, o.bead_width, min_piece))
        kept[fi].push_back(std::move(piece));
    };
    for (std::size_t fi = 0; fi < faces.size(); ++fi)
      for (std::size_t k = 0; k < outer_rings[fi]; ++k) keep(fi, face_lines[fi][k]);
    for (std::size_t fi = 0; fi < faces.size(); ++fi)
      for (std::size_t k = outer_rings[fi]; k < face_lines[fi].size(); ++k)
        keep(fi, face_lines[fi][k]);
    if (o.gap_fill) {
      const auto gaps = gap_lines(faces, inners, *raster, o.bead_width);
      for (std::size_t fi = 0; fi < faces.size(); ++fi)
        for (const auto& line : gaps[fi]) keep(fi, line);
    }
    face_lines = std::move(kept);
  }
  return raster;
}

// The faces' pieces chained into beads, (points, colour) in print order.
std::vector<std::pair<std::vector<Vec2>, int>> chain_faces(
    const std::vector<ColorFace>& faces, const std::vector<Regions>& inners,
    std::vector<std::vector<std::vector<Vec2>>> face_lines, BeadRaster* raster, const FgmOptions& o,
    Vec2& cursor) {
  // Each face's rings whole, ring to ring, its lines into serpentines, its gap fill where it
  // is near: connectors up to three beads long inside the face (half a bead in from its edge),
  // longer ones (up to ten beads) along a boundary the lines meet at a shallow angle.
  fgm::ChainOptions chain;
  chain.max_connector = 3 * o.bead_width;
  chain.max_boundary_connector = 10 * o.bead_width;
  chain.bead = o.bead_width;
  chain.raster = raster;
  std::vector<std::pair<std::vector<Vec2>, int>> chains;  // (points, colour) in print order
  if (o.order == FgmOrder::Paths && !o.tool_changer) {
    // Path order: island by island (each polygon of a face's inner region with its pieces),
    // the next the island nearest where the last chain ended, whatever its colour (a mixing
    // hotend or a temperature change runs the look-ahead ahead of the nozzle; the palette
    // order would travel from island to island of one colour across the part).
    auto isles = fgm::islands(faces, inners, std::move(face_lines));
    std::vector<char> done(isles.size(), 0);
    for (std::size_t n = 0; n < isles.size(); ++n) {
      std::size_t pick = 0;
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t k = 0; k < isles.size(); ++k)
        if (!done[k]) {
          const double d = fgm::island_distance(isles[k], cursor);
          if (d < best) best = d, pick = k;
        }
      done[pick] = 1;
      auto& island = isles[pick];
      for (auto& c : fgm::chain_pieces(std::move(island.pieces), {island.region}, chain, cursor))
        chains.push_back({std::move(c), island.colour});
    }
    // The layer's beads reordered for the least travel (nearest neighbour, then 2-opt).
    std::vector<OrderItem> items;
    for (const auto& c : chains)
      items.push_back({{c.first.front().x, c.first.front().y, 0},
                       {c.first.back().x, c.first.back().y, 0},
                       true});
    std::vector<std::pair<std::vector<Vec2>, int>> ordered;
    for (const OrderStep& step : order_by_travel(items, {0, 0, 0})) {
      auto& c = chains[step.item];
      if (step.reversed) std::reverse(c.first.begin(), c.first.end());
      ordered.push_back(std::move(c));
    }
    chains = std::move(ordered);
  } else {
    for (std::size_t fi = 0; fi < faces.size(); ++fi)
      for (auto& c : fgm::chain_pieces(std::move(face_lines[fi]), inners[fi], chain, cursor))
        chains.push_back({std::move(c), faces[fi].color});
  }
  return chains;
}

void route_travel_inside(const LayerOutline& lo, const FgmOptions& o, Layer& layer) {
  // Travel between the beads kept inside the part where a route inside is short (the linking
  // stage's Comb: within a quarter bead outside the outline's outer bead), so the writer
  // neither retracts nor lifts for it.
  const Regions route = offset(lo.regions, -0.5 * o.bead_width);
  if (!route.empty()) {
    const Comb comb(offset(lo.regions, -0.25 * o.bead_width), route);
    for (std::size_t k = 1; k < layer.paths.size(); ++k) {
      Path& p = layer.paths[k];
      const Vec2 a = layer.paths[k - 1].points.back().xy(), b = p.points.front().xy();
      std::vector<Vec2> via;
      if (!p.joined && comb.route(a, b, 3 * std::hypot(b.x - a.x, b.y - a.y) + o.bead_width, via)) {
        p.inside = true;
        for (const Vec2 v : via) p.via.push_back({v.x, v.y, layer.z});
      }
    }
  }
}

}  // namespace

void face_layer(const Field& field, Evaluator& ev, const LayerOutline& lo, std::size_t g,
                const FgmOptions& o, Layer& layer, std::vector<int>& colours,
                std::size_t& face_count, FgmStats& shorts) {
  // Material iso-lines on their own grid (half a bead at the finest: a face narrower than
  // that cannot be printed); crossings are refined on the field.
  // Paths stay half a bead inside their face: its edges need not follow the iso-lines closer
  // than a hundredth of a band (a tighter fit only adds vertices to the rings).
  auto faces = color_faces(field, ev, lo.z, lo.regions, o.palette,
                           std::max(o.material_resolution, o.bead_width / 2), 1e-2);
  face_count = faces.size();
  // Palette order, reversed every other layer so a layer starts where the last one ended.
  if (g % 2 == 1) std::reverse(faces.begin(), faces.end());
  const double fixed_angle = o.angle_deg + (g % 2 ? 90.0 : 0.0);
  Vec2 cursor{0, 0};
  // The iso-line directions over the layer, on the material grid.
  std::optional<fgm::IsoDirections> directions;
  if (!o.fixed_angle && !faces.empty()) {
    Vec2 dlo, dhi;
    padded_box(lo.regions, 2 * o.bead_width, dlo, dhi);
    directions.emplace(ev, lo.z, dlo, dhi, std::max(o.material_resolution, o.bead_width / 2),
                       fixed_angle);
  }
  std::vector<std::vector<std::vector<Vec2>>> face_lines(faces.size());
  std::vector<Regions> inners(faces.size());
  std::vector<std::size_t> outer_rings(faces.size(), 0);  // face_lines[fi]'s first ones
  for (std::size_t fi = 0; fi < faces.size(); ++fi)
    outer_rings[fi] = face_paths(faces[fi], o, directions, fixed_angle, inners[fi], face_lines[fi]);
  const std::unique_ptr<BeadRaster> raster = balance(faces, inners, outer_rings, o, face_lines);
  const std::vector<std::pair<std::vector<Vec2>, int>> chains =
      chain_faces(faces, inners, std::move(face_lines), raster.get(), o, cursor);
  for (const auto& [line, colour] : chains) {
    Path p;
    p.role = PathRole::Infill;
    p.mixture = o.palette.mixture(colour);
    p.width = o.bead_width;
    p.height = o.layer_height;
    for (const Vec2 q : line) p.points.push_back({q.x, q.y, layer.z});
    if (!(p.length() > 0)) continue;
    layer.paths.push_back(std::move(p));
    colours.push_back(colour);
  }
  merge_short_pieces(layer.paths, colours, ev, lo.z, o.palette, o.min_segment, shorts);
  route_travel_inside(lo, o, layer);
}

}  // namespace trellis::fgm
