// Hatch vectors of a PBF layer: on the direct route the joints' scan lines with their ends
// refined on the joint field, or (R67 without compensation) zero-finding along every scan line;
// with beam compensation the section hatched on its inward offset, less the thin walls.
#include <algorithm>
#include <cmath>
#include <utility>

#include "pbf_internal.hpp"

namespace trellis::pbf_detail {

namespace {

// A hatch vector's end on the joints' outline, to be refined on the joint field along the line
// (dir points into the vector).
struct HatchEnd {
  Vec2 p, dir;
  double half_length;
};

// Refines hatch ends, all of a layer together: the root near p, inside towards +dir, within a
// bracket that never reaches past the vector's middle (thin sheets) and that is shrunk until
// its outer end is outside; an end without a clean bracket keeps the polygon's point.
std::vector<Vec2> refine_ends(JointSection& joint, const std::vector<HatchEnd>& ends, double delta,
                              double tol) {
  const std::size_t n = ends.size();
  std::vector<Bracket> br(n);
  std::vector<double> flo(n), fhi(n);
  std::vector<Vec2> pts;
  std::vector<double> vals;
  std::vector<std::pair<std::size_t, bool>> which;  // (end, is hi)
  auto at = [&](std::size_t i, double t) { return ends[i].p + ends[i].dir * t; };
  auto sample_listed = [&]() {
    vals.resize(pts.size());
    if (!pts.empty()) joint.sample(pts.data(), vals.data(), pts.size());
    for (std::size_t k = 0; k < which.size(); ++k)
      (which[k].second ? fhi : flo)[which[k].first] = vals[k];
  };
  for (std::size_t i = 0; i < n; ++i) {
    br[i] = {-delta, std::min(delta, ends[i].half_length)};
    pts.push_back(at(i, br[i].lo));
    which.emplace_back(i, false);
    pts.push_back(at(i, br[i].hi));
    which.emplace_back(i, true);
  }
  sample_listed();
  std::vector<int> tries_lo(n, 0), tries_hi(n, 0);
  for (int round = 0; round < 8; ++round) {
    pts.clear();
    which.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (flo[i] < 0 && tries_lo[i] < 8) {
        ++tries_lo[i];
        pts.push_back(at(i, br[i].lo *= 0.5));
        which.emplace_back(i, false);
      }
      if (fhi[i] >= 0 && tries_hi[i] < 8) {
        ++tries_hi[i];
        pts.push_back(at(i, br[i].hi *= 0.5));
        which.emplace_back(i, true);
      }
    }
    if (pts.empty()) break;
    sample_listed();
  }
  std::vector<std::size_t> ok;  // ends with a clean bracket
  std::vector<Bracket> okb;
  for (std::size_t i = 0; i < n; ++i)
    if (flo[i] >= 0 && fhi[i] < 0) {
      ok.push_back(i);
      okb.push_back(br[i]);
    }
  bisect_together(
      okb, tol, 200,
      [&](const std::vector<std::size_t>& act, const std::vector<double>& mid,
          std::vector<double>& out) {
        pts.resize(act.size());
        for (std::size_t k = 0; k < act.size(); ++k) pts[k] = at(ok[act[k]], mid[k]);
        joint.sample(pts.data(), out.data(), pts.size());
      },
      [](double v) { return v >= 0; });
  std::vector<Vec2> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = ends[i].p;
  for (std::size_t k = 0; k < ok.size(); ++k) out[ok[k]] = at(ok[k], 0.5 * (okb[k].lo + okb[k].hi));
  return out;
}

// Inside intervals of the part (< 0) along the scan line q(s) = origin + s·u, s in [s0, s1], by
// zero-finding: the part's interval bound discards stretches that cannot reach the sheet;
// the rest is split down to `leaf`, whose ends are sampled; a sign change is bisected to `tol`;
// a leaf with both ends outside is probed at its middle, so a crossing wider than half a leaf is
// always found.
class LineZeros {
 public:
  LineZeros(Ctx& ctx, double z, double leaf, double tol)
      : ctx_(ctx), z_(z), leaf_(leaf), tol_(tol) {}
  std::vector<std::pair<double, double>> run(Vec2 origin, Vec2 u, double s0, double s1) {
    o_ = origin;
    u_ = u;
    roots_.clear();
    const double f0 = f(s0), f1 = f(s1);
    visit(s0, s1, f0, f1, 0);
    // Roots in order; inside between an entering and the next leaving root.
    std::vector<std::pair<double, double>> out;
    bool inside = f0 < 0;
    double start = s0;
    std::sort(roots_.begin(), roots_.end());
    for (double r : roots_) {
      if (inside)
        out.emplace_back(start, r);
      else
        start = r;
      inside = !inside;
    }
    if (inside) out.emplace_back(start, s1);
    return out;
  }

 private:
  double f(double s) {
    const Vec2 q = o_ + u_ * s;
    return ctx_.part.value({q.x, q.y, z_});
  }
  Interval bound(double a, double b) {
    BBox3 box;
    const Vec2 p = o_ + u_ * a, q = o_ + u_ * b;
    box.add({p.x, p.y, z_});
    box.add({q.x, q.y, z_});
    return ctx_.part.bound(box);
  }
  void root(double a, double b, double fa) {
    while (b - a > tol_) {
      const double m = 0.5 * (a + b);
      if ((f(m) < 0) == (fa < 0))
        a = m;
      else
        b = m;
    }
    roots_.push_back(0.5 * (a + b));
  }
  void visit(double a, double b, double fa, double fb, int depth) {
    // Stretches that cannot reach the part are dropped (bounds are not worth it on the last
    // levels, where sampling is as cheap).
    if (b - a > 4 * leaf_ && bound(a, b).lo > 0) return;
    if (b - a <= leaf_ || depth > 40) {
      if ((fa < 0) != (fb < 0)) {
        root(a, b, fa);
      } else if (fa >= 0) {
        const double m = 0.5 * (a + b), fm = f(m);
        if (fm < 0) {
          root(a, m, fa);
          root(m, b, fm);
        }
      }
      return;
    }
    const double m = 0.5 * (a + b), fm = f(m);
    visit(a, m, fa, fm, depth + 1);
    visit(m, b, fm, fb, depth + 1);
  }
  Ctx& ctx_;
  double z_, leaf_, tol_;
  Vec2 o_, u_;
  std::vector<double> roots_;
};

// R67 without compensation over the whole sheet, where walls can be thinner than the grid:
// zero-finding along every scan line (direction u, spaced along v), across the domain box.
template <class Add>
void scan_line_hatches(const Plan& p, Ctx& ctx, double z, Vec2 u, Vec2 v, Vec2 ho, Add add_vector) {
  const PbfOptions& o = p.o;
  const Vec2 lo = p.lo, hi = p.hi;
  double t0 = 1e300, t1 = -1e300, s0 = 1e300, s1 = -1e300;
  for (const Vec2 c : {lo, hi, Vec2{lo.x, hi.y}, Vec2{hi.x, lo.y}}) {
    t0 = std::min(t0, c.x * v.x + c.y * v.y);
    t1 = std::max(t1, c.x * v.x + c.y * v.y);
    s0 = std::min(s0, c.x * u.x + c.y * u.y);
    s1 = std::max(s1, c.x * u.x + c.y * u.y);
  }
  // Leaves of two grid cells, probed at their middle: crossings wider than one cell are
  // always found.
  LineZeros zeros(ctx, z, 2 * o.resolution, o.refine);
  const double off = ho.x * v.x + ho.y * v.y;  // the lines' phase across them
  const auto k0 = static_cast<long long>(std::ceil((t0 - off) / o.hatch_distance));
  const auto k1 = static_cast<long long>(std::floor((t1 - off) / o.hatch_distance));
  for (long long k = k0; k <= k1; ++k) {
    const Vec2 origin = v * (static_cast<double>(k) * o.hatch_distance + off);
    for (const auto& [a, b] : zeros.run(origin, u, s0, s1))
      add_vector(origin + u * a, origin + u * b);
  }
}

}  // namespace

std::vector<Segment2> hatch_layer(const Plan& p, Ctx& ctx, JointSection& joint, const Regions& S,
                                  const Regions& T, const Regions& hatch_region, Vec2 ho, double z,
                                  PbfLayer& L) {
  const PbfOptions& o = p.o;
  const double bc = o.beam_compensation;
  // Hatch vectors: with beam compensation they end on the inward offset (each at the
  // compensation from the boundary); without, on the field.
  const double ang = L.hatch_angle * kDeg;
  const Vec2 u{std::cos(ang), std::sin(ang)}, v{-std::sin(ang), std::cos(ang)};
  auto add_vector = [&](Vec2 a, Vec2 b) {
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (len <= 1e-6) return;
    L.hatches.push_back({a, b});
    L.hatch_length += len;
  };
  // The whole section hatched with the compensation: the R67 baseline, and the hybrid path's
  // joints once the thin walls are taken out.
  const std::vector<Segment2> S_hatch =
      bc > 0 ? hatch_inset(S, {}, L.hatch_angle, o.hatch_distance, bc, ho)
             : hatch(S, L.hatch_angle, o.hatch_distance, ho);
  if (bc > 0) {
    const std::vector<Segment2> segs =
        o.hybrid ? trim_hatch(S_hatch, T, L.hatch_angle, o.hatch_distance, bc, true, ho) : S_hatch;
    for (const auto& seg : segs) add_vector(seg.a, seg.b);
  } else if (o.stl_route) {
    for (const auto& seg : hatch(hatch_region, L.hatch_angle, o.hatch_distance, ho))
      add_vector(seg.a, seg.b);
  } else if (o.hybrid) {
    // Joints are wider than a thin wall (thin_multiple · D) by definition, so their outline on
    // the grid cannot miss one: its scan lines seed each crossing, refined on the field.
    const std::vector<Segment2> segs = hatch(hatch_region, L.hatch_angle, o.hatch_distance, ho);
    std::vector<HatchEnd> ends;
    ends.reserve(2 * segs.size());
    for (const auto& seg : segs) {
      const double half = 0.5 * std::hypot(seg.b.x - seg.a.x, seg.b.y - seg.a.y);
      ends.push_back({seg.a, u, half});
      ends.push_back({seg.b, u * -1.0, half});
    }
    const std::vector<Vec2> r = refine_ends(joint, ends, 2 * o.resolution, o.refine);
    for (std::size_t k = 0; k < segs.size(); ++k) add_vector(r[2 * k], r[2 * k + 1]);
  } else {
    scan_line_hatches(p, ctx, z, u, v, ho, add_vector);
  }
  return S_hatch;
}

}  // namespace trellis::pbf_detail
