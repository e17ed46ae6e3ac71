#include "pbf_chords.hpp"

#include <algorithm>
#include <cmath>

namespace trellis::pbf_detail {

namespace {

double dist(Vec2 a, Vec2 b) {
  return std::sqrt(dist2(a, b));
}

// A polyline with its cumulative arc length.
class Walk {
 public:
  explicit Walk(const std::vector<Vec2>& l) : l_(l), s_(l.size(), 0.0) {
    for (std::size_t k = 1; k < l.size(); ++k) s_[k] = s_[k - 1] + dist(l[k - 1], l[k]);
  }
  double length() const { return s_.empty() ? 0 : s_.back(); }
  // The point at arc length `arc`.
  Vec2 at(double arc) const {
    const std::size_t k = segment(arc);
    const double len = s_[k + 1] - s_[k];
    const double t = len > 0 ? std::clamp((arc - s_[k]) / len, 0.0, 1.0) : 0.0;
    return l_[k] + (l_[k + 1] - l_[k]) * t;
  }
  // The first point after arc length `from` at distance r from c (leaving the disc around c),
  // as its arc length; false if the line ends inside the disc.
  bool leave_disc(Vec2 c, double r, double from, double* arc) const {
    for (std::size_t k = segment(from); k + 1 < l_.size(); ++k) {
      const double s0 = std::max(from, s_[k]);
      const Vec2 b = l_[k + 1];
      if (dist2(b, c) < r * r) continue;  // (squared: no root for the points inside)
      const Vec2 a = at_in(k, s0);
      const Vec2 d = b - a, e = a - c;
      const double A = d.x * d.x + d.y * d.y, B = 2 * (d.x * e.x + d.y * e.y),
                   C = e.x * e.x + e.y * e.y - r * r;
      if (!(A > 0)) continue;
      const double t =
          std::clamp((-B + std::sqrt(std::max(0.0, B * B - 4 * A * C))) / (2 * A), 0.0, 1.0);
      *arc = s0 + t * (s_[k + 1] - s0);
      return true;
    }
    return false;
  }

 private:
  std::size_t segment(double arc) const {
    const auto it = std::upper_bound(s_.begin(), s_.end(), arc);
    const auto k = static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, it - s_.begin() - 1));
    return std::min(k, l_.size() - 2);
  }
  Vec2 at_in(std::size_t k, double arc) const {
    const double len = s_[k + 1] - s_[k];
    const double t = len > 0 ? std::clamp((arc - s_[k]) / len, 0.0, 1.0) : 0.0;
    return l_[k] + (l_[k + 1] - l_[k]) * t;
  }
  const std::vector<Vec2>& l_;
  std::vector<double> s_;
};

// q on the curve at distance r from c: Newton steps on the curve and the circle together (φ = 0
// and |q − c|² = r², linearised at q: one evaluation of φ and its gradient a step); they cross
// at a wide angle when r is small against the curvature radius, so the error after a step is
// about the square of the step over the curvature radius: a step under 1e-5 mm (usually the
// first or second from the line's point) leaves ~1e-10 mm, and is the last.
// If that does not converge (the two run nearly parallel, or the steps jump to another branch
// where the curve turns within r, e.g. a cell not much larger than SL), the line's own point q
// is kept: a chord never leaves the neighbourhood of the line it stands for.
Vec2 on_curve_at(Vec2 c, double r, Vec2 q, const Curve& curve) {
  const Vec2 q0 = q;
  bool converged = false;
  for (int it = 0; it < 6 && !converged; ++it) {
    Vec2 g;
    const double f = curve.field(q, &g);
    const Vec2 e = q - c;
    // g·δ = −f and e·δ = (r² − e·e)/2 (the circle, linearised).
    const double det = g.x * e.y - g.y * e.x;
    if (!(std::abs(det) > 1e-9 * std::sqrt((g.x * g.x + g.y * g.y) * (e.x * e.x + e.y * e.y))))
      return q0;  // tangent, no gradient, or not finite
    const double b1 = -f, b2 = 0.5 * (r * r - (e.x * e.x + e.y * e.y));
    const Vec2 step{(b1 * e.y - g.y * b2) / det, (g.x * b2 - b1 * e.x) / det};
    q = q + step;
    converged = std::abs(step.x) + std::abs(step.y) < 1e-5;
  }
  const double d = dist(c, q), moved = dist(q, q0);
  return converged && std::isfinite(d) && std::abs(d - r) <= 0.25 * r + 1e-6 &&
                 moved <= std::min(r, curve.reach)
             ? q
             : q0;
}

void open_chords(const std::vector<Vec2>& line, double sl, double gap, double phase,
                 const Curve& curve, std::vector<std::vector<Vec2>>& out) {
  if (line.size() < 2) return;
  const Walk w(line);
  if (!(w.length() > 1e-6)) return;
  const double period = sl + gap;
  Vec2 s = project(curve, line.front());
  double s_arc = 0;
  double len = sl;
  if (phase > 0 && phase < sl) {
    len = sl - phase;  // the first chord, cut short by the pattern's start before the line
  } else if (phase >= sl) {
    const double g = period - phase;  // the first gap, partly before the line
    double arc = 0;
    if (g > 1e-9) {
      if (!w.leave_disc(s, g, 0, &arc)) return;
      s = on_curve_at(s, g, w.at(arc), curve);
      s_arc = arc;
    }
  }
  const Vec2 end = project(curve, line.back());
  // Each chord advances along the line by at least half its length: where the projection jumps
  // to another branch of the curve (a cell not much larger than SL), the disc test alone could
  // stand still and emit the same chord millions of times (found by fuzz_job_run).
  for (;;) {
    double arc = 0;
    if (!w.leave_disc(s, len, s_arc, &arc)) {
      if (dist(s, end) > 1e-6) out.push_back({s, end});  // the last chord, short
      return;
    }
    if (arc < s_arc + 0.5 * len) {
      arc = s_arc + len;
      if (arc >= w.length()) {
        if (dist(s, end) > 1e-6) out.push_back({s, end});
        return;
      }
    }
    const Vec2 e = on_curve_at(s, len, w.at(arc), curve);
    out.push_back({s, e});
    len = sl;
    if (gap > 0) {
      double next = 0;
      if (!w.leave_disc(e, gap, arc, &next)) return;
      s = on_curve_at(e, gap, w.at(next), curve);
      s_arc = next;
    } else {
      s = e;
      s_arc = arc;
    }
  }
}

}  // namespace

Vec2 project(const Curve& curve, Vec2 q) {
  const Vec2 q0 = q;
  for (int it = 0; it < 2; ++it) {
    Vec2 g;
    const double f = curve.field(q, &g);
    const double gg = g.x * g.x + g.y * g.y;
    if (!(gg > 0)) break;
    const Vec2 step = g * (f / gg);
    q = q - step;
    if (std::abs(step.x) + std::abs(step.y) < 1e-7) break;
  }
  const double moved = dist(q, q0);
  return std::isfinite(moved) && moved <= curve.reach ? q : q0;
}

std::vector<Vec2> trim_arc(const std::vector<Vec2>& line, double cut, bool from_start) {
  if (line.size() < 2 || cut <= 0) return line;
  // In place of a reversed copy: point i counted from the end the cut starts at.
  const std::size_t n = line.size();
  auto pt = [&](std::size_t i) { return from_start ? line[i] : line[n - 1 - i]; };
  // The arc length s_i up to each point; j: the first point past the cut (s_j > cut).
  double s = 0, s_before = 0, s_after = 0;
  std::size_t j = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double next = s + dist(pt(i - 1), pt(i));
    if (j == 0 && next > cut) {
      j = i;
      s_before = s;
      s_after = next;
    }
    s = next;
  }
  std::vector<Vec2> out;
  if (s <= cut) return out;
  // The point at arc length `cut`, on the segment from point j − 1 to j.
  const double len = s_after - s_before;
  const double t = len > 0 ? std::clamp((cut - s_before) / len, 0.0, 1.0) : 0.0;
  out.reserve(n - j + 1);
  out.push_back(pt(j - 1) + (pt(j) - pt(j - 1)) * t);
  for (std::size_t i = j; i < n; ++i) out.push_back(pt(i));
  if (!from_start) std::reverse(out.begin(), out.end());
  return out;
}

void chord_vectors(const std::vector<Vec2>& line, bool closed, double sl, double gap, double phase,
                   const Curve& curve, std::vector<std::vector<Vec2>>& out) {
  if (!closed || line.size() < 3) {
    open_chords(line, sl, gap, phase, curve, out);
    return;
  }
  // A loop: start `phase` along it, go round once, stop `gap` (along the loop) before the start.
  const Walk w(line);
  const double total = w.length();
  if (!(total > 1e-6)) return;
  const double start = std::fmod(phase, total);
  std::vector<Vec2> ring;
  ring.push_back(w.at(start));
  double acc = 0;
  std::vector<Vec2> before;
  for (std::size_t k = 1; k < line.size(); ++k) {
    acc += dist(line[k - 1], line[k]);
    if (acc > start)
      ring.push_back(line[k]);
    else
      before.push_back(line[k]);
  }
  ring.insert(ring.end(), before.begin(), before.end());
  ring.push_back(ring.front());
  open_chords(trim_arc(ring, gap, false), sl, gap, 0, curve, out);
}

}  // namespace trellis::pbf_detail
