// The gradient error of a graded toolpath: how far each path's mixture is from the design's
// fractions along it, summed per layer (in layer order: the same for any thread count).
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "trellis/slice/fgm.hpp"

namespace trellis {

std::vector<GradientErrorSum> gradient_error_sums(const Field& field, const Toolpath& tp,
                                                  const std::vector<LayerOutline>& layers, double h,
                                                  std::size_t first_layer) {
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  std::vector<GradientErrorSum> acc(tp.layers.size());
  tbb::parallel_for(std::size_t{0}, tp.layers.size(), [&](std::size_t li) {
    const Layer& l = tp.layers[li];
    const auto idx = static_cast<std::size_t>(std::llround(l.z / h)) - 1 - first_layer;
    if (idx >= layers.size()) return;
    acc[li] = layer_gradient_error(evaluators.local(), l, layers[idx].z);
  });
  return acc;
}

GradientErrorSum layer_gradient_error(Evaluator& ev, const Layer& l, double z) {
  GradientErrorSum a;
  // Each path's points at once (the design's expressions evaluated over the path).
  const std::size_t nm = ev.field().materials().size();
  std::vector<Vec3> pts;
  std::vector<double> fr;
  for (const auto& p : l.paths) {
    if (p.mixture.empty() || p.role == PathRole::Other || p.role == PathRole::Purge) continue;
    if (nm == 0) continue;
    pts.resize(p.points.size());
    for (std::size_t k = 0; k < p.points.size(); ++k) pts[k] = {p.points[k].x, p.points[k].y, z};
    fr.resize(pts.size() * nm);
    ev.fractions(pts.data(), pts.size(), fr.data());
    for (std::size_t k = 0; k < p.points.size(); ++k) {
      const Vec3& q = p.points[k];
      const double* f = fr.data() + k * nm;
      double e = 0;
      for (std::size_t m = 0; m < nm && m < p.mixture.size(); ++m)
        e = std::max(e, std::abs(std::clamp(f[m], 0.0, 1.0) - p.mixture[m]));
      // The point's share of the path: half of each segment it ends.
      double w = 0;
      if (k > 0) w += 0.5 * distance(p.points[k - 1], q);
      if (k + 1 < p.points.size()) w += 0.5 * distance(q, p.points[k + 1]);
      a.sum += e * w;
      a.length += w;
      a.max = std::max(a.max, e);
      ++a.n;
    }
  }
  return a;
}

void measure_gradient_error(const Field& field, const Toolpath& tp,
                            const std::vector<LayerOutline>& layers, double h, FgmStats& st) {
  // One sum per layer, added in layer order: the report is the same for any thread count
  // (per-thread sums would be added in whatever order the threads ran).
  double sum = 0;
  st.error_max = 0;
  st.error_samples = 0;
  st.error_length = 0;
  for (const auto& a : gradient_error_sums(field, tp, layers, h)) {
    sum += a.sum;
    st.error_max = std::max(st.error_max, a.max);
    st.error_samples += a.n;
    st.error_length += a.length;
  }
  st.error_mean = st.error_length > 0 ? sum / st.error_length : 0;
}

}  // namespace trellis
