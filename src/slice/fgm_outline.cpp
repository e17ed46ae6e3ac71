// Strategy 2 in path order: each island filled as one piece (src/slice/fgm_outline.hpp).
#include "fgm_outline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "trellis/slice/link.hpp"

namespace trellis::fgm {

namespace {

double dist(Vec2 a, Vec2 b) {
  return std::hypot(b.x - a.x, b.y - a.y);
}

double length(const std::vector<Vec2>& line) {
  double len = 0;
  for (std::size_t k = 1; k < line.size(); ++k) len += dist(line[k - 1], line[k]);
  return len;
}

std::uint64_t cell_key(long i, long j) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) |
         static_cast<std::uint32_t>(j);
}

// The fill's lines: the potential's level lines a bead apart clipped to the fill; hatch lines
// at `angle` where there is no potential.
std::vector<std::vector<Vec2>> fill_lines(const Regions& fill, const IsoPotential* potential,
                                          double angle, double phase, double bead) {
  std::vector<std::vector<Vec2>> lines;
  if (!potential || potential->flat()) {
    for (const auto& seg : hatch(fill, angle, bead))
      if (dist(seg.a, seg.b) >= 0.05) lines.push_back({seg.a, seg.b});
    return lines;
  }
  for (auto& piece : clip_polylines(potential->level_lines(bead, phase), fill)) {
    std::vector<Vec2> line;
    for (const Vec2 q : piece)
      if (line.empty() || dist(line.back(), q) > 1e-9) line.push_back(q);
    if (line.size() >= 2 && length(line) >= 0.05) lines.push_back(std::move(line));
  }
  return lines;
}

}  // namespace

void LineFlow::add(const std::vector<Vec2>& line, const IsoPotential& potential) {
  for (std::size_t k = 1; k < line.size(); ++k) {
    const Vec2 a = line[k - 1], b = line[k];
    const Vec2 g = potential.gradient((a + b) * 0.5);
    const double slope = std::hypot(g.x, g.y);
    const double flow = slope > 0 ? std::clamp(1 / slope, kMinFlow, kMaxFlow) : kMaxFlow;
    segments_.push_back({a, b, flow});
  }
  indexed_ = false;
}

double LineFlow::at(Vec2 a, Vec2 b) const {
  if (segments_.empty()) return 1;
  if (!indexed_) {
    cells_.clear();
    for (std::size_t s = 0; s < segments_.size(); ++s) {
      const Segment& e = segments_[s];
      const long i0 = static_cast<long>(std::floor(std::min(e.a.x, e.b.x))),
                 i1 = static_cast<long>(std::floor(std::max(e.a.x, e.b.x)));
      const long j0 = static_cast<long>(std::floor(std::min(e.a.y, e.b.y))),
                 j1 = static_cast<long>(std::floor(std::max(e.a.y, e.b.y)));
      for (long j = j0; j <= j1; ++j)
        for (long i = i0; i <= i1; ++i)
          cells_[cell_key(i, j)].push_back(static_cast<std::uint32_t>(s));
    }
    indexed_ = true;
  }
  const Vec2 m = (a + b) * 0.5;
  const auto it =
      cells_.find(cell_key(static_cast<long>(std::floor(m.x)), static_cast<long>(std::floor(m.y))));
  if (it == cells_.end()) return 1;
  constexpr double kOn = 1e-7;  // mm: a point of the segment (cut points are on it to rounding)
  auto on = [](const Segment& e, Vec2 p) {
    return distance_to_segment({p.x, p.y, 0}, {e.a.x, e.a.y, 0}, {e.b.x, e.b.y, 0}) <= kOn;
  };
  for (const std::uint32_t s : it->second) {
    const Segment& e = segments_[s];
    if (on(e, a) && on(e, b)) return e.flow;
  }
  return 1;
}

OutlineBeads outline_beads(const Regions& outline, const IsoPotential* potential, double angle,
                           double phase, const FgmOptions& o, double z, Vec2& cursor) {
  const double w = o.bead_width;
  OutlineBeads out;
  OutlineStats& st = out.stats;
  struct Island {
    Polygon2 poly;
    std::vector<std::vector<Vec2>> rings, fill;
  };
  std::vector<Island> isles;
  const bool levels = potential && !potential->flat();
  for (const auto& poly : outline) {
    if (poly.outer.size() < 3) continue;
    Island& is = isles.emplace_back();
    is.poly = poly;
    const Regions island{poly};
    // The rings half a bead, a bead and a half, … inside the outline (around each hole too).
    int rings = 0;
    for (int k = 0; k < o.perimeters; ++k) {
      const Regions r = offset(island, -(k + 0.5) * w);
      if (r.empty()) break;
      for (auto ring : rings_of(r)) {
        if (ring.size() < 3) continue;
        ring.push_back(ring.front());
        is.rings.push_back(std::move(ring));
      }
      ++rings;
    }
    // The fill reaches fill_overlap of a bead short of the innermost ring's inner edge: the
    // serpentines' connectors run along its edge, half over the ring.
    const Regions fill = offset(island, -(rings * w + 0.5 * w - o.fill_overlap * w));
    if (!fill.empty()) {
      const auto lines = fill_lines(fill, potential, angle, phase, w);
      st.lines += lines.size();
      if (levels)
        for (const auto& line : lines) out.flow.add(line, *potential);
      is.fill = connect_fill(lines, fill, 8 * w);
    }
    st.rings += is.rings.size();
    st.serpentines += is.fill.size();
  }
  st.islands = isles.size();
  // Islands nearest first; in each, rings outside in from the outer ring's seam, then the fill
  // from where the last ring ended.
  ChainOptions chain;
  chain.max_connector = 3 * w;
  chain.bead = w;
  std::vector<std::vector<Vec2>> beads;
  std::vector<char> done(isles.size(), 0);
  for (std::size_t n = 0; n < isles.size(); ++n) {
    std::size_t pick = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < isles.size(); ++k) {
      if (done[k]) continue;
      for (const Vec2 v : isles[k].poly.outer)
        if (dist(v, cursor) < best) best = dist(v, cursor), pick = k;
    }
    done[pick] = 1;
    Island& is = isles[pick];
    if (!is.rings.empty()) {
      const auto& outer = is.rings.front();
      const std::vector<Vec2> open(outer.begin(), outer.end() - 1);
      cursor = open[seam_vertex(open, Seam::Aligned, cursor, 1, 0)];
    }
    std::vector<std::vector<Vec2>> pieces = std::move(is.rings);
    for (auto& s : is.fill) pieces.push_back(std::move(s));
    // Connectors stay where a bead centre may go: half a bead inside the outline.
    const Regions inner = offset(Regions{is.poly}, -0.5 * w + 1e-3);
    for (auto& b : chain_pieces(std::move(pieces), inner, chain, cursor))
      beads.push_back(std::move(b));
  }
  st.beads = beads.size();
  for (const auto& line : beads) {
    Path p;
    p.role = PathRole::Infill;
    p.width = w;
    p.height = o.layer_height;
    for (const Vec2 q : line) p.points.push_back({q.x, q.y, z});
    if (p.length() > 0) out.paths.push_back(std::move(p));
  }
  // Travel between beads inside the part where a route inside is short (the linking stage's
  // Comb, within a quarter bead outside the outer ring's bead), so the writer does not retract.
  const Regions route = offset(outline, -0.5 * w);
  if (!route.empty()) {
    const Comb comb(offset(outline, -0.25 * w), route);
    for (std::size_t k = 1; k < out.paths.size(); ++k) {
      Path& p = out.paths[k];
      const Vec2 a = out.paths[k - 1].points.back().xy(), b = p.points.front().xy();
      std::vector<Vec2> via;
      if (comb.route(a, b, 3 * dist(a, b) + w, via)) {
        p.inside = true;
        for (const Vec2 v : via) p.via.push_back({v.x, v.y, z});
      }
    }
  }
  return out;
}

void apply_flow(std::vector<Piece>& pieces, const LineFlow& flow, double bead) {
  if (flow.empty()) return;
  constexpr double kQuantum = 0.05, kMinRun = 2.0;
  std::vector<Piece> out;
  out.reserve(pieces.size());
  std::vector<double> seg;
  for (auto& piece : pieces) {
    const auto& pts = piece.path.points;
    const std::size_t n = pts.size();
    seg.assign(n > 1 ? n - 1 : 0, 1.0);
    for (std::size_t k = 0; k + 1 < n; ++k)
      seg[k] = std::round(flow.at(pts[k].xy(), pts[k + 1].xy()) / kQuantum) * kQuantum;
    // Runs of one flow; a run under kMinRun takes the flow of the run before it (the first,
    // of the run after).
    struct Run {
      std::size_t from, to;  // segments [from, to)
      double flow, length;
    };
    std::vector<Run> runs;
    for (std::size_t k = 0; k < seg.size(); ++k) {
      const double len = distance(pts[k], pts[k + 1]);
      if (!runs.empty() && runs.back().flow == seg[k]) {
        runs.back().to = k + 1, runs.back().length += len;
      } else {
        runs.push_back({k, k + 1, seg[k], len});
      }
    }
    std::vector<Run> merged;
    for (const Run& r : runs) {
      if (!merged.empty() && (r.length < kMinRun || merged.back().flow == r.flow)) {
        merged.back().to = r.to, merged.back().length += r.length;
      } else if (!merged.empty() && merged.back().length < kMinRun) {
        merged.back().to = r.to, merged.back().length += r.length, merged.back().flow = r.flow;
      } else {
        merged.push_back(r);
      }
    }
    if (merged.size() <= 1) {
      const double f = merged.empty() ? 1.0 : merged.front().flow;
      piece.path.flow = f == 1.0 ? 0.0 : f;
      piece.path.width = bead * f;
      out.push_back(std::move(piece));
      continue;
    }
    Path proto = std::move(piece.path);
    const std::vector<Vec3> all = std::move(proto.points);
    proto.points.clear();
    for (std::size_t r = 0; r < merged.size(); ++r) {
      Piece part{proto, piece.color};
      part.path.points.assign(all.begin() + static_cast<long>(merged[r].from),
                              all.begin() + static_cast<long>(merged[r].to) + 1);
      part.path.flow = merged[r].flow == 1.0 ? 0.0 : merged[r].flow;
      part.path.width = bead * merged[r].flow;
      if (r > 0) {
        part.path.joined = true;
        part.path.via.clear();
        part.path.inside = false;
      }
      out.push_back(std::move(part));
    }
  }
  pieces = std::move(out);
}

}  // namespace trellis::fgm
