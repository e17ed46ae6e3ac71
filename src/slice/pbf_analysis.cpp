#include "trellis/slice/pbf_analysis.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "trellis/core/error.hpp"
#include "trellis/slice/slice.hpp"

namespace trellis {

LaserAnalysis analyze_laser_toolpath(const Toolpath& tp, const Field& part,
                                     const LaserAnalysisOptions& o) {
  if (part.empty()) throw GeometryError("laser analysis needs a design");
  if (!(o.sample > 0) || !(o.resolution > 0) || !(o.melt_pool > 0))
    throw SettingError("sample step, resolution and melt-pool width must be > 0");
  const BBox3 e = part.extent();
  const double z0 = std::isnan(o.z0) ? e.min.z : o.z0;
  LaserAnalysis a;
  a.layers.resize(tp.layers.size());
  // Design heights: the middle of each layer (its thickness from the previous layer's z).
  std::vector<double> zs(tp.layers.size());
  for (std::size_t i = 0; i < tp.layers.size(); ++i) {
    const double prev = i > 0 ? tp.layers[i - 1].z
                              : (tp.layers.size() > 1 ? 2 * tp.layers[0].z - tp.layers[1].z : 0.0);
    const double h = tp.layers[i].z - prev;
    zs[i] = z0 + tp.layers[i].z - 0.5 * h;
  }
  FieldSliceOptions so;
  so.resolution = o.resolution;
  const std::vector<LayerOutline> sections = slice_field(part, zs, so);
  tbb::enumerable_thread_specific<Evaluator> evals([&] { return Evaluator(part); });
  tbb::parallel_for(std::size_t{0}, tp.layers.size(), [&](std::size_t i) {
    Evaluator& ev = evals.local();
    const Layer& layer = tp.layers[i];
    LaserLayerAnalysis& L = a.layers[i];
    L.z = layer.z;
    L.design_z = zs[i];
    L.area = area(sections[i].regions);
    ScanClock clock(o.timing);
    std::vector<Vec2> pts;
    for (const Path& p : layer.paths) {
      if (p.points.size() < 2) continue;
      pts.clear();
      for (const auto& q : p.points) pts.push_back({q.x, q.y});
      const bool hatch = p.role == PathRole::Hatch || p.role == PathRole::Infill;
      clock.mark(pts.data(), pts.size(),
                 p.speed > 0 ? p.speed : (hatch ? o.timing.hatch_speed : o.timing.contour_speed));
      ++L.vectors;
      bool outside = false;
      for (std::size_t k = 1; k < pts.size(); ++k) {
        const Vec2 s = pts[k - 1], t = pts[k];
        const double len = std::hypot(t.x - s.x, t.y - s.y);
        (hatch ? L.hatch_length : L.contour_length) += len;
        const int n = std::max(1, static_cast<int>(std::ceil(len / o.sample)));
        for (int j = (k == 1 ? 0 : 1); j <= n; ++j) {
          const Vec2 q = s + (t - s) * (static_cast<double>(j) / n);
          const Vec3 p3{q.x, q.y, zs[i]};
          const double v = ev.value(p3);
          if (v <= 0) continue;
          const Vec3 g = ev.gradient(p3);
          const double gn = std::sqrt(g.x * g.x + g.y * g.y);
          const double d = gn > 0 ? v / gn : std::numeric_limits<double>::infinity();
          if (d <= o.tolerance) continue;
          outside = true;
          L.max_outside = std::max(L.max_outside, d);
          L.outside_length += len / n;
        }
      }
      L.outside_vectors += outside;
    }
    L.scan_time = clock.seconds();
    L.fr = L.area > 0 ? o.melt_pool * (L.contour_length + L.hatch_length) / L.area : 0;
  });
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (const auto& L : a.layers) {
    a.vectors += L.vectors;
    a.outside_vectors += L.outside_vectors;
    a.scan_length += L.contour_length + L.hatch_length;
    a.outside_length += L.outside_length;
    a.max_outside = std::max(a.max_outside, L.max_outside);
    a.scan_time += L.scan_time;
    if (L.area > 0) {
      sum += L.fr;
      sum2 += L.fr * L.fr;
      ++n;
    }
  }
  if (n > 0) {
    a.fr_mean = sum / static_cast<double>(n);
    const double var = std::max(0.0, sum2 / static_cast<double>(n) - a.fr_mean * a.fr_mean);
    a.fr_cv = a.fr_mean > 0 ? std::sqrt(var) / a.fr_mean : 0;
  }
  return a;
}

}  // namespace trellis
