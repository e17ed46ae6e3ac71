// Strategy 2 in path order: each island filled as one piece (src/slice/fgm_outline.hpp).
#include "fgm_outline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <unordered_map>

#include "loop_bridge.hpp"
#include "trellis/slice/link.hpp"

namespace trellis::fgm {

namespace {

// Open fill pieces and closed level lines shorter than this many beads are left out: the corners
// of the fill, the innermost arc of a family cut by the edge and the specks round an extreme of
// the material, which neither pair nor bridge into anything (a speck of a layer's area, an
// extrusion start each).
constexpr double kDropOpen = 8;

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

// Level lines clipped to the fill. Clipping returns open paths cut at their extremes along its
// sweep (and a closed line as open pieces): pieces whose ends meet, two at a point, are one line
// again (a closed one, first == last, when it comes round); level lines never meet one another,
// so two ends at a point are such a cut.
std::vector<std::vector<Vec2>> clip_levels(const std::vector<std::vector<Vec2>>& levels,
                                           const Regions& fill) {
  const auto pieces = clip_polylines(levels, fill);
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> ends;  // point -> end keys 2i, 2i+1
  auto key_of = [](Vec2 p) {
    const auto q = [](double v) {
      return static_cast<std::uint32_t>(static_cast<std::int64_t>(std::llround(v * 1e6)));
    };
    return (static_cast<std::uint64_t>(q(p.x)) << 32) | q(p.y);
  };
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    if (pieces[i].size() < 2) continue;
    ends[key_of(pieces[i].front())].push_back(2 * i);
    ends[key_of(pieces[i].back())].push_back(2 * i + 1);
  }
  auto mate = [&](std::size_t e) -> std::size_t {
    const auto& v = ends[key_of(e % 2 ? pieces[e / 2].back() : pieces[e / 2].front())];
    if (v.size() != 2) return SIZE_MAX;
    return v[0] == e ? v[1] : v[0];
  };
  std::vector<char> used(pieces.size(), 0);
  auto take = [&](std::size_t start) {
    // From piece end `start` (entering there) through the pieces joined to it.
    std::vector<Vec2> line;
    for (std::size_t e = start; e != SIZE_MAX && !used[e / 2];) {
      used[e / 2] = 1;
      const auto& p = pieces[e / 2];
      const std::size_t skip = line.empty() ? 0 : 1;
      if (e % 2 == 0)
        line.insert(line.end(), p.begin() + static_cast<long>(skip), p.end());
      else
        line.insert(line.end(), p.rbegin() + static_cast<long>(skip), p.rend());
      e = mate(e ^ 1);
    }
    return line;
  };
  std::vector<std::vector<Vec2>> joined;
  for (std::size_t i = 0; i < pieces.size(); ++i)
    for (const std::size_t e : {2 * i, 2 * i + 1})
      if (!used[i] && pieces[i].size() >= 2 && mate(e) == SIZE_MAX) joined.push_back(take(e));
  for (std::size_t i = 0; i < pieces.size(); ++i)
    if (!used[i] && pieces[i].size() >= 2) {
      auto loop = take(2 * i);
      loop.back() = loop.front();
      joined.push_back(std::move(loop));
    }
  std::vector<std::vector<Vec2>> lines;
  for (auto& piece : joined) {
    const bool closed = dist(piece.front(), piece.back()) < 1e-9;
    std::vector<Vec2> line;
    for (const Vec2 q : piece)
      if (line.empty() || dist(line.back(), q) > 1e-9) line.push_back(q);
    if (closed && line.size() > 1 && line.back() != line.front()) line.push_back(line.front());
    if (line.size() >= 2 && length(line) >= 0.05) lines.push_back(std::move(line));
  }
  return lines;
}

double to_polyline(Vec2 p, const std::vector<Vec2>& line) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 1; k < line.size(); ++k)
    best = std::min(best, distance_to_segment({p.x, p.y, 0}, {line[k - 1].x, line[k - 1].y, 0},
                                              {line[k].x, line[k].y, 0}));
  return best;
}

Vec2 midpoint(const std::vector<Vec2>& line) {
  const double half = 0.5 * length(line);
  double s = 0;
  for (std::size_t k = 1; k < line.size(); ++k) {
    const double l = dist(line[k - 1], line[k]);
    if (s + l >= half && l > 0) return line[k - 1] + (line[k] - line[k - 1]) * ((half - s) / l);
    s += l;
  }
  return line.front();
}

// 1/|∇g| along a line (the spacing of the level lines there, in beads), its mean over samples.
double mean_spread(const std::vector<Vec2>& line, const IsoPotential& g) {
  double sum = 0;
  int n = 0;
  for (std::size_t k = 1; k < line.size(); k += std::max<std::size_t>(1, line.size() / 16)) {
    const Vec2 d = g.gradient((line[k - 1] + line[k]) * 0.5);
    const double slope = std::hypot(d.x, d.y);
    sum += slope > 0 ? 1 / slope : 4.0;
    ++n;
  }
  return n ? sum / n : 1.0;
}

// The fill of one island: closed lines and racetracks (loops) and the open rest, each open one's
// flow factor (1, or 3/4 and 1/2 around a line put into an odd run).
struct FillPieces {
  std::vector<std::vector<Vec2>> closed;       // closed level lines
  std::vector<std::vector<Vec2>> loops, rest;  // racetracks, open lines left over
  std::vector<std::vector<Vec2>> open;         // every open line (for the flows), with its factor
  std::vector<double> factor;
};

// The level lines a bead apart clipped to the fill, closed ones kept, open ones paired into
// racetracks. A run of an odd number of lines side by side would leave one line open (a bead
// of its own): a line half a level between the two of the run that lie furthest apart is put in
// (g's level line there), the three extruding 3/4, 1/2 and 3/4 of the flow their spacing asks,
// so the run pairs whole and the area stays covered once.
FillPieces level_fill(const Regions& fill, const IsoPotential& g, double phase, double w) {
  FillPieces out;
  for (auto& line : clip_levels(g.level_lines(w, phase), fill)) {
    if (line.size() > 3 && dist(line.front(), line.back()) < 1e-9)
      out.closed.push_back(std::move(line));
    else
      out.open.push_back(std::move(line));
  }
  out.factor.assign(out.open.size(), 1.0);
  std::vector<std::vector<std::size_t>> odd;
  std::vector<std::vector<Vec2>> rest;
  auto loops = pair_fill(out.open, fill, 8 * w, &rest, &odd);
  bool added = false;
  for (const auto& run : odd) {
    std::size_t pick = SIZE_MAX;
    double widest = 0;
    for (std::size_t m = 0; m + 1 < run.size(); ++m) {
      const double spread = mean_spread(out.open[run[m]], g) + mean_spread(out.open[run[m + 1]], g);
      if (spread > widest) widest = spread, pick = m;
    }
    if (pick == SIZE_MAX) continue;
    const auto& a = out.open[run[pick]];
    const auto& b = out.open[run[pick + 1]];
    const Vec2 ma = midpoint(a), mb = midpoint(b);
    const double ka = g.value(ma) / w - phase, kb = g.value(mb) / w - phase;
    if (std::abs(std::abs(ka - kb) - 1) > 0.25) continue;  // not neighbouring levels
    const auto k = static_cast<std::int64_t>(std::llround(std::min(ka, kb)));
    // The component of the half level between the two.
    std::vector<Vec2> best;
    double best_d = std::numeric_limits<double>::infinity();
    for (auto& c : clip_levels(g.level_lines(w, phase + 0.5, &k), fill)) {
      if (dist(c.front(), c.back()) < 1e-9) continue;
      const Vec2 mc = midpoint(c);
      const double d = to_polyline(mc, a) + to_polyline(mc, b);
      if (d < best_d) best_d = d, best = std::move(c);
    }
    if (best.empty() || best_d > 1.5 * dist(ma, mb) + 4 * w) continue;
    out.factor[run[pick]] *= 0.75;
    out.factor[run[pick + 1]] *= 0.75;
    out.open.push_back(std::move(best));
    out.factor.push_back(0.5);
    added = true;
  }
  if (added) {
    rest.clear();
    loops = pair_fill(out.open, fill, 8 * w, &rest);
  }
  out.loops = std::move(loops);
  out.rest = std::move(rest);
  return out;
}

}  // namespace

void LineFlow::add(const std::vector<Vec2>& line, const IsoPotential& potential, double factor) {
  for (std::size_t k = 1; k < line.size(); ++k) {
    const Vec2 a = line[k - 1], b = line[k];
    const Vec2 g = potential.gradient((a + b) * 0.5);
    const double slope = std::hypot(g.x, g.y);
    const double flow =
        slope > 0 ? std::clamp(factor / slope, kMinFlow, kMaxFlow) : kMaxFlow * factor;
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

namespace {

// Lines at `angle` a bead apart through `region`, paired into loops and the rest joined into
// serpentines, as strands for the bridging.
void add_hatch(const Regions& region, double angle, double w, std::vector<Strand>& strands,
               OutlineStats& st) {
  std::vector<std::vector<Vec2>> lines, rest;
  for (const auto& seg : hatch(region, angle, w))
    if (dist(seg.a, seg.b) >= 0.05) lines.push_back({seg.a, seg.b});
  st.lines += lines.size();
  for (auto& loop : pair_fill(lines, region, 8 * w, &rest))
    strands.push_back({std::move(loop), true});
  for (auto& chain : connect_fill(rest, region, 8 * w))
    if (length(chain) >= kDropOpen * w) strands.push_back({std::move(chain), false});
}

}  // namespace

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
    // The outermost ones are the part's surface and stay whole loops; the others may be
    // bridged into the fill.
    std::vector<Strand> strands;
    int rings = 0;
    for (int k = 0; k < o.perimeters; ++k) {
      const Regions r = offset(island, -(k + 0.5) * w);
      if (r.empty()) break;
      for (auto ring : rings_of(r)) {
        if (ring.size() < 3) continue;
        ring.push_back(ring.front());
        if (k == 0)
          is.rings.push_back(std::move(ring));
        else
          strands.push_back({std::move(ring), true, true});
      }
      ++rings;
    }
    // The fill reaches the innermost ring's bead (its serpentines' turns run along the edge, half
    // over the ring).
    const Regions fill = offset(island, -(rings * w));
    if (!fill.empty() && levels) {
      FillPieces pieces = level_fill(fill, *potential, phase, w);
      std::vector<std::vector<Vec2>> drawn = pieces.closed;  // (before they move into strands)
      drawn.insert(drawn.end(), pieces.open.begin(), pieces.open.end());
      for (const auto& line : pieces.closed) out.flow.add(line, *potential, 1.0);
      for (std::size_t k = 0; k < pieces.open.size(); ++k)
        out.flow.add(pieces.open[k], *potential, pieces.factor[k]);
      st.lines += pieces.closed.size() + pieces.open.size();
      for (auto& loop : pieces.closed)
        if (length(loop) >= kDropOpen * w) strands.push_back({std::move(loop), true});
      for (auto& loop : pieces.loops)
        if (length(loop) >= kDropOpen * w) strands.push_back({std::move(loop), true});
      for (auto& chain : connect_fill(pieces.rest, fill, 8 * w))
        if (length(chain) >= kDropOpen * w) strands.push_back({std::move(chain), false});
      // Where g is flat no level line passes: a fraction clamped at 0 or 1 over part of the
      // island (three materials: a corner of the triangle), or a design constant there. What
      // lies further than a bead from every line and is wider than two beads is hatched at the
      // layer's angle like an island without a gradient: its beads meet the level lines' beads
      // (a line extruding more where the lines spread overlaps them by up to half a bead; under
      // 2 % of the coverage checked in test_fgm_outline). Level lines spread to three beads at
      // most near a saddle: no such gap there.
      const Regions gap = fill_gaps(fill, drawn, w);
      if (!gap.empty()) add_hatch(gap, angle, w, strands, st);
    } else if (!fill.empty()) {
      // No gradient: lines at the angle, paired and joined the same way.
      add_hatch(fill, angle, w, strands, st);
    }
    BridgeOptions bo;
    bo.spacing = w;
    bo.far = 2.5;  // level lines spread up to 2.5 beads (low |∇g|: flows widen them)
    BridgeStats bs;
    for (auto& s : bridge_strands(strands, bo, &bs)) is.fill.push_back(std::move(s.points));
    st.serpentines += is.fill.size();
    st.rings += is.rings.size();
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
      // The outer ring starts at its aligned seam; where the fill is open (an odd run that no
      // line could even out), next to that chain's first end instead, so the walls run into it.
      const auto& outer = is.rings.front();
      const std::vector<Vec2> open(outer.begin(), outer.end() - 1);
      const auto chain = std::find_if(is.fill.begin(), is.fill.end(), [](const auto& f) {
        return dist(f.front(), f.back()) > 1e-9;
      });
      if (chain == is.fill.end()) {
        cursor = open[seam_vertex(open, Seam::Aligned, cursor, 1, 0)];
      } else {
        double best = std::numeric_limits<double>::infinity();
        const Vec2 e = chain->front();
        for (std::size_t k = 1; k < outer.size(); ++k) {
          const Vec2 a = outer[k - 1], d = outer[k] - a;
          const double l2 = d.x * d.x + d.y * d.y;
          const double t =
              l2 > 0 ? std::clamp(((e.x - a.x) * d.x + (e.y - a.y) * d.y) / l2, 0.0, 1.0) : 0.0;
          const Vec2 q = a + d * t;
          if (dist(q, e) < best) best = dist(q, e), cursor = q;
        }
      }
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

OutlineBeads layer_beads(Evaluator& ev, const LayerOutline& layer, std::size_t g,
                         const FgmOptions& o) {
  Vec2 cursor{0, 0};
  const double z = static_cast<double>(g + 1) * o.layer_height;
  const double angle = o.angle_deg + (g % 2 ? 90.0 : 0.0);
  if (layer.regions.empty()) return {};
  std::optional<IsoPotential> potential;
  if (!o.fixed_angle) {
    // The outline's box, two beads of margin.
    Vec2 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    Vec2 hi{-lo.x, -lo.y};
    for (const auto& poly : layer.regions)
      for (const Vec2 q : poly.outer)
        lo = {std::min(lo.x, q.x), std::min(lo.y, q.y)},
        hi = {std::max(hi.x, q.x), std::max(hi.y, q.y)};
    const double pad = 2 * o.bead_width;
    potential.emplace(ev, layer.z, Vec2{lo.x - pad, lo.y - pad}, Vec2{hi.x + pad, hi.y + pad},
                      std::max(o.material_resolution, o.bead_width / 2));
  }
  return outline_beads(layer.regions, potential ? &*potential : nullptr, angle, g % 2 ? 0.5 : 0.0,
                       o, z, cursor);
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
