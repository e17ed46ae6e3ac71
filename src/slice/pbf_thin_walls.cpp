// Thin walls of a PBF layer: the mid-curve φ = 0 densified onto the mid-surface, the wall
// thickness measured across the sheet along it, its pieces where the sheet is a thin wall (the
// inverted joint measure negative) and their contour scan vectors (chords of SL, LHD apart).
#include <algorithm>
#include <cmath>
#include <limits>

#include "pbf_chords.hpp"
#include "pbf_internal.hpp"

namespace trellis::pbf_detail {

namespace {

// The mid-curve comes from the coarse grid: puts a point, projected onto φ = 0 by a Newton step
// along ∇φ, in the middle of every chord (chord error / 4).
void densify_on_mid_surface(Ctx& ctx, double z, std::vector<std::vector<Vec2>>& lines) {
  std::vector<Vec3> mids;
  for (const auto& l : lines)
    for (std::size_t k = 0; k + 1 < l.size(); ++k) {
      const Vec2 c = (l[k] + l[k + 1]) * 0.5;
      mids.push_back({c.x, c.y, z});
    }
  std::vector<double> fm(mids.size());
  std::vector<Vec3> gm(mids.size());
  if (!mids.empty()) {  // one batch each (TPMS: analytic gradients)
    ctx.phi.values(mids.data(), fm.data(), mids.size());
    ctx.phi.gradients(mids.data(), gm.data(), mids.size());
  }
  std::size_t next_mid = 0;
  for (auto& l : lines) {
    std::vector<Vec2> dense;
    dense.reserve(2 * l.size());
    for (std::size_t k = 0; k + 1 < l.size(); ++k, ++next_mid) {
      dense.push_back(l[k]);
      const Vec2 c{mids[next_mid].x, mids[next_mid].y};
      const double f = fm[next_mid];
      const Vec3 g = gm[next_mid];
      const double gg = g.x * g.x + g.y * g.y;  // in the plane of the layer
      dense.push_back(gg > 0 ? c - Vec2{g.x, g.y} * (f / gg) : c);
    }
    dense.push_back(l.back());
    l = std::move(dense);
  }
}

// A thin-wall stretch of the mid-curve: a loop (closed) or a piece between switches to a joint
// or to the part's outer boundary (then the track stops short of it).
struct ThinPiece {
  std::vector<Vec2> points;
  bool closed = false;
  bool boundary_start = false, boundary_end = false;
};

// Splits mid-curve lines (open ones first, loops from first_loop on, each loop's last point its
// first) where the inverted joint measure changes sign; each switch is bisected along its chord
// and classed by the part's value just past it. The measure is sampled in batches: all lines'
// points at once, then every switch's bisection step together, then the parts past them.
std::vector<ThinPiece> thin_pieces(Ctx& ctx, JointSection& thin,
                                   const std::vector<std::vector<Vec2>>& lines,
                                   std::size_t first_loop, double z, double refine) {
  std::vector<std::size_t> at(lines.size() + 1, 0);  // line li's points from at[li]
  for (std::size_t li = 0; li < lines.size(); ++li)
    at[li + 1] = at[li] + (lines[li].size() >= 2 ? lines[li].size() : 0);
  std::vector<Vec2> all(at.back());
  for (std::size_t li = 0; li < lines.size(); ++li)
    if (lines[li].size() >= 2) std::copy(lines[li].begin(), lines[li].end(), all.begin() + at[li]);
  std::vector<double> tv(all.size());
  if (!all.empty()) thin.sample(all.data(), tv.data(), all.size());
  // The switches in order along the lines, bisected together (bisect_together, in mm along
  // each one's chord from its first point) while the bracket is longer than `refine` (at most 30
  // halvings); lo stays on the side of the measure before the switch.
  struct Switch {
    Vec2 a, u;     // the chord's first point and direction
    bool leaving;  // the measure was negative before it
    Vec2 at(double t) const { return a + u * t; }
  };
  std::vector<Switch> sw;
  std::vector<Bracket> br;
  for (std::size_t li = 0; li < lines.size(); ++li)
    for (std::size_t k = at[li] + 1; k < at[li + 1]; ++k)
      if ((tv[k] < 0) != (tv[k - 1] < 0)) {
        const double len = std::sqrt(dist2(all[k - 1], all[k]));
        const Vec2 u = len > 0 ? (all[k] - all[k - 1]) * (1 / len) : Vec2{};
        sw.push_back({all[k - 1], u, tv[k - 1] < 0});
        br.push_back({0, len});
      }
  std::vector<Vec2> mids;
  bisect_together(
      br, refine, 30,
      [&](const std::vector<std::size_t>& act, const std::vector<double>& mid,
          std::vector<double>& out) {
        mids.resize(act.size());
        for (std::size_t k = 0; k < act.size(); ++k) mids[k] = sw[act[k]].at(mid[k]);
        thin.sample(mids.data(), out.data(), mids.size());
        // As "on lo's side": the measure's sign before the switch (a leaving switch: negative).
        for (std::size_t k = 0; k < act.size(); ++k)
          out[k] = (out[k] < 0) == sw[act[k]].leaving ? -1.0 : 1.0;
      },
      [](double v) { return v < 0; });
  std::vector<Vec3> past(sw.size());
  for (std::size_t s = 0; s < sw.size(); ++s) {
    const Vec2 q = sw[s].at(sw[s].leaving ? br[s].hi : br[s].lo);
    past[s] = {q.x, q.y, z};
  }
  std::vector<double> past_part(sw.size());
  if (!past.empty()) ctx.part.values(past.data(), past_part.data(), past.size());

  std::vector<ThinPiece> pieces;
  std::size_t next_switch = 0;
  // The piece being built: its points gathered in one buffer, then copied out at their number.
  std::vector<Vec2> cur;
  bool cur_start = false;
  auto emit = [&](bool boundary_end) {
    if (cur.size() < 2) return;
    ThinPiece p;
    p.points.assign(cur.begin(), cur.end());
    p.boundary_start = cur_start;
    p.boundary_end = boundary_end;
    pieces.push_back(std::move(p));
  };
  for (std::size_t li = 0; li < lines.size(); ++li) {
    const auto& l = lines[li];
    if (l.size() < 2) continue;
    const bool loop = li >= first_loop;
    const double* v_at = tv.data() + at[li];
    const std::size_t first_piece = pieces.size();
    bool switched = false;
    cur.clear();
    cur_start = false;
    if (v_at[0] < 0) {
      cur.push_back(l[0]);
      cur_start = !loop;  // an open mid-curve ends where the part does
    }
    double prev = v_at[0];
    for (std::size_t k = 1; k < l.size(); ++k) {
      const double v = v_at[k];
      if ((v < 0) != (prev < 0)) {
        switched = true;
        const std::size_t s = next_switch++;
        const Vec2 x = sw[s].at(0.5 * (br[s].lo + br[s].hi));
        const bool boundary = past_part[s] >= 0;
        if (prev < 0) {
          cur.push_back(x);
          emit(boundary);
          cur.clear();
          cur_start = false;
        } else {
          cur.assign(1, x);
          cur_start = boundary;
        }
      }
      if (v < 0) cur.push_back(l[k]);
      prev = v;
    }
    if (prev < 0) emit(!loop);
    if (!loop || v_at[0] >= 0 || prev >= 0 || pieces.size() == first_piece) continue;
    if (!switched) {
      pieces.back().closed = true;  // the whole loop is thin
    } else if (pieces.size() - first_piece >= 2) {
      // The last piece runs on into the first across the loop's seam: one piece.
      ThinPiece last = std::move(pieces.back());
      pieces.pop_back();
      ThinPiece& f = pieces[first_piece];
      last.points.insert(last.points.end(), f.points.begin() + 1, f.points.end());
      last.boundary_end = f.boundary_end;
      f = std::move(last);
    }
  }
  return pieces;
}

// Wall thickness measured across the sheet at mid-curve points inside the part (every 32nd
// point): from φ = 0 along ±∇φ to where Φ = 0 on each side, all rays bisected together.
void measure_wall_thickness(Ctx& ctx, const PbfDesign& design, double c_const, double z,
                            const std::vector<std::vector<Vec2>>& lines, PbfLayer& L) {
  L.t_min = std::numeric_limits<double>::infinity();
  L.t_max = 0;
  std::vector<Vec3> tp;  // mid-curve points sampled for thickness
  for (const auto& l : lines)
    for (std::size_t k = 0; k < l.size(); k += 32) tp.push_back({l[k].x, l[k].y, z});
  std::vector<double> tpart(tp.size());
  std::vector<Vec3> tgrad(tp.size());
  if (!tp.empty()) {
    ctx.part.values(tp.data(), tpart.data(), tp.size());
    ctx.phi.gradients(tp.data(), tgrad.data(), tp.size());
  }
  // Two rays per point inside the part (up and down ∇φ), reaching twice the nominal.
  struct Ray {
    Vec3 p, n;
  };
  std::vector<Ray> rays;
  std::vector<Bracket> br;
  for (std::size_t k = 0; k < tp.size(); ++k) {
    if (tpart[k] >= 0) continue;
    const double gn = norm(tgrad[k]);
    if (!(gn > 0)) continue;
    const Vec3 n = tgrad[k] * (1.0 / gn);
    const double nominal = design.thickness > 0
                               ? design.thickness
                               : 2 * std::abs(ctx.c ? ctx.c->value(tp[k]) : c_const) / gn;
    rays.push_back({tp[k], n});
    rays.push_back({tp[k], n * -1.0});
    br.push_back({0, 2 * nominal});
    br.push_back({0, 2 * nominal});
  }
  std::vector<Vec3> rp(rays.size());
  std::vector<double> rv(rays.size());
  for (std::size_t r = 0; r < rays.size(); ++r) rp[r] = rays[r].p + rays[r].n * br[r].hi;
  if (!rp.empty()) ctx.sheet.values(rp.data(), rv.data(), rp.size());
  std::vector<char> reached(rays.size());
  for (std::size_t r = 0; r < rays.size(); ++r) {
    reached[r] = rv[r] >= 0;  // else no sheet boundary within reach
    if (!reached[r]) br[r] = {0, 0};
  }
  bisect_together(
      br, 1e-6, 40,
      [&](const std::vector<std::size_t>& act, const std::vector<double>& mid,
          std::vector<double>& out) {
        rp.resize(act.size());
        for (std::size_t k = 0; k < act.size(); ++k)
          rp[k] = rays[act[k]].p + rays[act[k]].n * mid[k];
        ctx.sheet.values(rp.data(), out.data(), rp.size());
      },
      [](double v) { return v < 0; });
  for (std::size_t r = 0; r + 1 < rays.size(); r += 2) {
    if (!reached[r] || !reached[r + 1]) continue;  // no boundary within twice the nominal
    const double t = 0.5 * (br[r].lo + br[r].hi) + 0.5 * (br[r + 1].lo + br[r + 1].hi);
    L.t_min = std::min(L.t_min, t);
    L.t_max = std::max(L.t_max, t);
    L.t_sum += t;
    ++L.t_count;
  }
  if (L.t_count == 0) L.t_min = 0;
}

}  // namespace

void thin_wall_contours(const Plan& p, Ctx& ctx, JointSection& thin, const ClassTiles* ct,
                        std::size_t i, double z, PbfLayer& L) {
  const PbfOptions& o = p.o;
  const double bc = o.beam_compensation;
  MidSection mid(ctx, z);
  const ContourSet m =
      counted(march_squares(mid, p.lo, p.hi, 0.0, tiled(p.mo_mid, ct, &ClassTiles::mid)), L);
  std::vector<std::vector<Vec2>> lines = m.lines.open;
  const std::size_t first_loop = lines.size();
  for (auto l : m.lines.loops) {
    l.push_back(l.front());
    lines.push_back(std::move(l));
  }
  densify_on_mid_surface(ctx, z, lines);
  measure_wall_thickness(ctx, p.design, p.c_const, z, lines, L);
  const std::vector<ThinPiece> pieces = p.thin_walls_possible
                                            ? thin_pieces(ctx, thin, lines, first_loop, z, o.refine)
                                            : std::vector<ThinPiece>{};
  const double period = o.segment_length + o.segment_gap;
  const double phase = std::fmod(o.contour_shift * static_cast<double>(i), 1.0) * period;
  // φ and its gradient in the layer; the traced line lies within a grid cell of φ = 0, so a
  // Newton step that goes further than 4 cells (a near-zero gradient: a cell not much
  // larger than the grid) is not kept.
  const Curve curve{[&](Vec2 q, Vec2* grad) {
                      Vec3 g;
                      const double f = ctx.phi.value_gradient({q.x, q.y, z}, &g);
                      *grad = {g.x, g.y};
                      return f;
                    },
                    4 * o.resolution};
  for (const auto& piece : pieces) {
    // A track ending at the part's outer boundary stops the beam compensation before it.
    const std::vector<Vec2>* pts = &piece.points;
    std::vector<Vec2> trimmed;
    if (piece.boundary_start) pts = &(trimmed = trim_arc(*pts, bc, true));
    if (piece.boundary_end) pts = &(trimmed = trim_arc(*pts, bc, false));
    chord_vectors(*pts, piece.closed, o.segment_length, o.segment_gap, phase, curve, L.contours);
  }
  for (const auto& v : L.contours)
    for (std::size_t k = 1; k < v.size(); ++k)
      L.contour_length += std::hypot(v[k].x - v[k - 1].x, v[k].y - v[k - 1].y);
}

}  // namespace trellis::pbf_detail
