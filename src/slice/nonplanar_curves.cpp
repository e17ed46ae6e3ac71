// Curves on the (offset) surface: the normal offset as the upper envelope of balls (a compass
// search over the disc), curves sampled within a chord tolerance and split where the footprint
// ends, and connectors that hug a hole's edge.
#include <algorithm>
#include <cmath>

#include "nonplanar_internal.hpp"

namespace trellis::nonplanar_detail {

// Starts of a multi-start search: the best samples (value, point), at most `count`, each at
// least `separation` from the ones chosen before (the best few often sit on one hill).
std::vector<std::pair<double, Vec2>> diverse_starts(std::vector<std::pair<double, Vec2>>& samples,
                                                    std::size_t count, double separation) {
  std::sort(samples.begin(), samples.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::pair<double, Vec2>> out;
  for (const auto& s : samples) {
    if (out.size() == count || s.first <= -1e299) break;
    bool far = true;
    for (const auto& o : out)
      far = far && std::hypot(s.second.x - o.second.x, s.second.y - o.second.y) >= separation;
    if (far) out.push_back(s);
  }
  return out;
}

// Height above XY point p of the surface offset by d along its normals: the upper envelope of
// balls of radius d centred on the surface, max over |q − p| <= d of f(q) + sqrt(d² − |q − p|²).
// Equal to the normal offset where the surface bends gently, and still exact in valleys sharper
// than d (where plain normal offsets cross over each other). Polar samples of the disc, then a
// compass search from the best, and from the next best that lie away from it: on folded
// surfaces the maximum can sit on a crease or at the footprint's edge, off the first hill.
double envelope_height(const HeightField::Eval& f, Vec2 p, double d) {
  const double z0 = f(p.x, p.y);
  if (!std::isfinite(z0) || d <= 0) return z0;
  auto value = [&](Vec2 q) {
    const double r2 = (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y);
    if (r2 > d * d) return -1e300;
    const double z = f(q.x, q.y);
    return std::isfinite(z) ? z + std::sqrt(d * d - r2) : -1e300;
  };
  constexpr int kRadii = 6, kAngles = 16;
  // Unit offsets of the polar samples, computed once.
  static const auto ring = [] {
    std::array<Vec2, kRadii * kAngles> u{};
    for (int i = 1; i <= kRadii; ++i)
      for (int j = 0; j < kAngles; ++j) {
        const double r = static_cast<double>(i) / kRadii, a = 2 * std::numbers::pi * j / kAngles;
        u[static_cast<std::size_t>((i - 1) * kAngles + j)] = {r * std::cos(a), r * std::sin(a)};
      }
    return u;
  }();
  std::array<std::pair<double, Vec2>, kRadii * kAngles + 1> samples;
  samples[0] = {z0 + d, p};
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const Vec2 q = p + ring[i] * d;
    samples[i + 1] = {value(q), q};
  }
  // The best sample's hill first; of the next three best samples, those away from it start
  // searches of their own (on smooth surfaces they sit on the same hill and are skipped).
  std::partial_sort(samples.begin(), samples.begin() + 4, samples.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  const Vec2 first = samples[0].second;
  double vb = climb(value, first, samples[0].first, d / kRadii, 1e-7);
  for (int k = 1; k < 4; ++k) {
    const auto& [v, q] = samples[static_cast<std::size_t>(k)];
    if (v > -1e299 && std::hypot(q.x - first.x, q.y - first.y) > d / 3)
      vb = std::max(vb, climb(value, q, v, d / kRadii, 1e-7));
  }
  return vb;
}

// Samples the curve c(s) = surface point above a + (b − a)·s for s in [s0, s1] where it exists:
// pieces split where the footprint ends (ends found by bisection), each refined until the curve
// at the quarter points of every chord is within `tol` of it.
std::vector<std::vector<Vec3>> sample_curve(const SurfacePoint& sp, Vec2 a, Vec2 b, double tol,
                                            double base_step, std::size_t* jumps) {
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  std::vector<std::vector<Vec3>> pieces;
  if (len <= 0) return pieces;
  auto at = [&](double s) { return sp(a + (b - a) * (s / len)); };
  // At most 20,000 base samples per curve (the refinement adds points where the surface bends),
  // so a curve metres long cannot take millions of evaluations.
  base_step = std::max(base_step, len / 20000);
  const int n = std::max(1, static_cast<int>(std::ceil(len / base_step)));
  std::vector<double> ss(static_cast<std::size_t>(n) + 1);
  std::vector<Vec3> ps(ss.size());
  for (int i = 0; i <= n; ++i) {
    ss[static_cast<std::size_t>(i)] = len * i / n;
    ps[static_cast<std::size_t>(i)] = at(ss[static_cast<std::size_t>(i)]);
  }
  const double min_step = 1e-5;
  std::vector<Vec3> cur;
  // A chord steeper than 100:1 that still rises by more than the tolerance when narrowed to
  // 0.1 µm (bisection keeping the half with the larger rise) is a jump, not a steep slope: a
  // continuous surface's rise vanishes with the interval.
  auto is_jump = [&](double s0, Vec3 p0, double s1, Vec3 p1) {
    if (!(std::abs(p1.z - p0.z) > tol && std::abs(p1.z - p0.z) > 100 * (s1 - s0))) return false;
    for (int k = 0; k < 60 && s1 - s0 > 1e-7; ++k) {
      const double sm = 0.5 * (s0 + s1);
      const Vec3 pm = at(sm);
      if (!is_finite(pm)) return false;
      if (std::abs(pm.z - p0.z) >= std::abs(p1.z - pm.z))
        s1 = sm, p1 = pm;
      else
        s0 = sm, p0 = pm;
    }
    return std::abs(p1.z - p0.z) > tol;
  };
  // Refines between (s0,p0) and (s1,p1), appending points after p0 up to p1.
  auto refine = [&](auto&& self, double s0, Vec3 p0, double s1, Vec3 p1, int depth) -> void {
    if (s1 - s0 > min_step && depth < 40) {
      const double sm = 0.5 * (s0 + s1);
      const Vec3 pm = at(sm);
      bool split = !is_finite(pm);
      if (!split) {
        for (double f : {0.25, 0.5, 0.75}) {
          const Vec3 q = f == 0.5 ? pm : at(s0 + (s1 - s0) * f);
          if (!is_finite(q) || distance_to_segment(q, p0, p1) > tol) {
            split = true;
            break;
          }
        }
      }
      if (split && is_finite(pm)) {
        self(self, s0, p0, sm, pm, depth + 1);
        self(self, sm, pm, s1, p1, depth + 1);
        return;
      }
    }
    if (is_jump(s0, p0, s1, p1)) {
      // The surface jumps here (a discontinuous height function): split the path instead of
      // printing a bridge through the air.
      if (jumps) ++*jumps;
      if (cur.size() >= 2 && distance(cur.front(), cur.back()) > 1e-4) pieces.push_back(cur);
      cur.clear();
    }
    cur.push_back(p1);
  };
  // Bisection for the footprint edge between a finite and a missing sample.
  auto edge = [&](double s_in, double s_out) {
    for (int k = 0; k < 60 && std::abs(s_out - s_in) > 1e-7; ++k) {
      const double m = 0.5 * (s_in + s_out);
      if (is_finite(at(m)))
        s_in = m;
      else
        s_out = m;
    }
    return s_in;
  };
  auto close = [&] {
    if (cur.size() >= 2 && distance(cur.front(), cur.back()) > 1e-4) pieces.push_back(cur);
    cur.clear();
  };
  double prev_s = 0;
  Vec3 prev = ps[0];
  if (is_finite(prev)) cur.push_back(prev);
  for (std::size_t i = 1; i < ss.size(); ++i) {
    const Vec3 p = ps[i];
    const bool fin_prev = is_finite(prev), fin = is_finite(p);
    if (fin_prev && fin) {
      refine(refine, prev_s, prev, ss[i], p, 0);
    } else if (fin_prev && !fin) {
      const double e = edge(prev_s, ss[i]);
      if (e > prev_s) refine(refine, prev_s, prev, e, at(e), 0);
      close();
    } else if (!fin_prev && fin) {
      const double e = edge(ss[i], prev_s);
      cur.push_back(at(e));
      if (ss[i] > e) refine(refine, e, cur.back(), ss[i], p, 0);
    }
    prev_s = ss[i];
    prev = p;
  }
  close();
  return pieces;
}

// A connector from a to b (ends of pieces on neighbouring lines, both on the footprint's edge)
// whose straight way crosses a hole: each sample inside the hole is pushed along `away` (the
// lines' direction, away from the hole) to just inside the hole's edge (by `margin`), so the
// connector hugs the edge in
// the strip between the two lines, where no other line runs. Empty if it cannot.
std::vector<Vec3> hug_connector(const SurfacePoint& sp, Vec3 a, Vec3 b, Vec2 away, double step,
                                double reach, double margin) {
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  const int n = std::max(2, static_cast<int>(std::ceil(len / step)));
  std::vector<Vec3> out{a};
  for (int i = 1; i < n; ++i) {
    const Vec2 q = a.xy() + (b.xy() - a.xy()) * (static_cast<double>(i) / n);
    Vec3 p = sp(q);
    if (!is_finite(p)) {
      double lo = 0, hi = step;  // inside at lo; march out to a finite hi, then bisect
      while (hi <= reach && !is_finite(sp(q + away * hi))) lo = hi, hi *= 2;
      if (hi > reach) return {};
      for (int k = 0; k < 50 && hi - lo > 1e-7; ++k) {
        const double m = 0.5 * (lo + hi);
        (is_finite(sp(q + away * m)) ? hi : lo) = m;
      }
      // A margin inside the footprint, so chords between edge points (sagitta step²/8R) stay on it.
      p = sp(q + away * (hi + margin));
      if (!is_finite(p)) return {};
    }
    out.push_back(p);
  }
  out.push_back(b);
  // Every chord must stay over the footprint (the self-check's test); otherwise travel.
  for (std::size_t i = 1; i < out.size(); ++i)
    if (!is_finite(sp((out[i - 1].xy() + out[i].xy()) * 0.5))) return {};
  return out;
}

// Whether the footprint goes on past the end `a` of a piece (coming from `before`): a hole, not
// the outer edge. Marches on in steps of `step` until the domain ends.
bool hole_ahead(const SurfacePoint& sp, Vec3 a, Vec3 before, const BBox2& box, double step) {
  Vec2 t{a.x - before.x, a.y - before.y};
  const double len = std::hypot(t.x, t.y);
  if (len <= 0) return false;
  t = t * (1 / len);
  for (Vec2 q = a.xy() + t * step;
       q.x >= box.min.x && q.x <= box.max.x && q.y >= box.min.y && q.y <= box.max.y;
       q = q + t * step)
    if (is_finite(sp(q))) return true;
  return false;
}

}  // namespace trellis::nonplanar_detail
