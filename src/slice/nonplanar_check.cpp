// Checks of a non-planar toolpath against its surface: each layer's distance from the surface
// (measured without normals, as an independent check of the offsets) and how much of the
// footprint its beads cover.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include "nonplanar_internal.hpp"
#include "trellis/geom/polygon.hpp"

namespace trellis {

using namespace nonplanar_detail;

namespace {

// Distance from q to the surface z = f(x, y), by a grid search around q then a shrinking pattern
// search (no normals used: an independent measure for the normal-offset check).
double distance_to_surface(const HeightField::Eval& f, Vec3 q, double radius) {
  auto g = [&](Vec2 p) {  // minus the squared distance, to climb
    const double z = f(p.x, p.y);
    if (!std::isfinite(z)) return -1e300;
    return -((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) + (z - q.z) * (z - q.z));
  };
  // Samples about 0.05 mm apart (the nearest point may sit on a crease or at a corner of the
  // footprint), then climbs from the best eight that lie apart; close to the surface (chords)
  // from two.
  const double r = radius + 0.05;
  const int n = std::clamp(static_cast<int>(std::ceil(r / 0.05)), 4, 32);
  std::vector<std::pair<double, Vec2>> samples;
  samples.reserve(static_cast<std::size_t>((2 * n + 1) * (2 * n + 1)));
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j) {
      const Vec2 p{q.x + r * i / n, q.y + r * j / n};
      samples.push_back({g(p), p});
    }
  double best = -1e300;
  for (const auto& [v, p] : diverse_starts(samples, radius > 0.2 ? 8 : 2, r / 4))
    best = std::max(best, climb(g, p, v, r / n, 1e-7));
  return std::sqrt(-best);
}

}  // namespace

SurfaceDeviation surface_deviation(const Toolpath& tp, const HeightField& surface,
                                   const NonplanarParams& prm) {
  SurfaceDeviation out;
  std::mutex m;
  tbb::enumerable_thread_specific<HeightField::Eval> evals([&] { return surface.evaluator(); });
  tbb::parallel_for(std::size_t{0}, tp.layers.size(), [&](std::size_t k) {
    auto& f = evals.local();
    const double off = static_cast<double>(k) * prm.layer_height;
    // Vertices: vertical mode exactly |z − f − k·h|; otherwise (and for chord midpoints) the
    // distance to the surface by minimisation, minus k·h.
    auto dev = [&](Vec3 q, bool chord) {
      if (prm.offset == OffsetMode::Vertical) {
        const double z = f(q.x, q.y);
        if (!std::isfinite(z)) return 1e300;
        if (!chord) return std::abs(q.z - z - off);
        q.z -= off;
        return distance_to_surface(f, q, std::abs(q.z - z));
      }
      return std::abs(distance_to_surface(f, q, off) - off);
    };
    SurfaceDeviation local;
    // Vertical mode: the distance from a chord midpoint to any surface point bounds its distance
    // to the surface from above — to the point below it (the vertical gap) and to the surface
    // point under its foot on the tangent plane (tight on slopes). Midpoints are visited by
    // falling bound and the minimisation stops once no bound can beat the largest distance
    // found: the same maximum, a fraction of the work.
    std::vector<std::pair<double, Vec3>> mids;
    for (const auto& p : tp.layers[k].paths)
      for (std::size_t i = 0; i < p.points.size(); ++i) {
        const double d = dev(p.points[i], false);
        if (d > local.max_point) local.max_point = d, local.worst = p.points[i];
        if (i == 0) continue;
        const Vec3 mid = (p.points[i - 1] + p.points[i]) * 0.5;
        double bound = 1e300;
        if (prm.offset == OffsetMode::Vertical) {
          const double z = f(mid.x, mid.y);
          if (std::isfinite(z)) {
            bound = std::abs(mid.z - off - z);
            const double h = 1e-3;
            const double fx = (f(mid.x + h, mid.y) - f(mid.x - h, mid.y)) / (2 * h);
            const double fy = (f(mid.x, mid.y + h) - f(mid.x, mid.y - h)) / (2 * h);
            if (std::isfinite(fx) && std::isfinite(fy)) {
              const Vec3 q{mid.x, mid.y, mid.z - off};
              const double len = std::sqrt(fx * fx + fy * fy + 1);
              const Vec3 n{-fx / len, -fy / len, 1 / len};
              const double along = (q.z - z) * n.z;  // signed distance to the tangent plane
              const Vec3 foot = q - n * along;
              const double zf = f(foot.x, foot.y);
              if (std::isfinite(zf)) bound = std::min(bound, distance(q, Vec3{foot.x, foot.y, zf}));
            }
          }
        }
        mids.emplace_back(bound, mid);
      }
    std::stable_sort(mids.begin(), mids.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    for (const auto& [bound, mid] : mids) {
      if (bound <= local.max_chord) break;
      const double c = dev(mid, true);
      if (c > local.max_chord) local.max_chord = c, local.worst_chord = mid;
    }
    std::lock_guard lock(m);
    if (local.max_point > out.max_point) out.max_point = local.max_point, out.worst = local.worst;
    if (local.max_chord > out.max_chord)
      out.max_chord = local.max_chord, out.worst_chord = local.worst_chord;
  });
  return out;
}

double footprint_coverage(const Toolpath& tp, std::size_t layer, const HeightField& surface,
                          double width, double pixel) {
  if (layer >= tp.layers.size()) return 0;
  const BBox2 box = surface.domain();
  BeadRaster raster(box, pixel);
  const long nx = raster.nx(), ny = raster.ny();
  for (const auto& p : tp.layers[layer].paths)
    for (std::size_t i = 1; i < p.points.size(); ++i)
      raster.paint(p.points[i - 1].xy(), p.points[i].xy(), width / 2);
  std::atomic<long> inside{0}, hit{0};
  tbb::enumerable_thread_specific<HeightField::Eval> evals([&] { return surface.evaluator(); });
  tbb::parallel_for(0L, ny, [&](long j) {
    auto& f = evals.local();
    long in = 0, h = 0;
    for (long i = 0; i < nx; ++i) {
      if (!std::isfinite(f(box.min.x + (i + 0.5) * pixel, box.min.y + (j + 0.5) * pixel))) continue;
      ++in;
      h += raster.covered(i, j);
    }
    inside += in, hit += h;
  });
  return inside > 0 ? static_cast<double>(hit) / static_cast<double>(inside) : 0;
}

}  // namespace trellis
