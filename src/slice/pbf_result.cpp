// What a PBF plan's result gives beyond its layers: statistics over the layers (FR_a, FR_eq and
// the measured wall thickness) and the toolpath IR of its scan vectors.
#include <algorithm>
#include <cmath>
#include <limits>

#include "trellis/slice/pbf.hpp"

namespace trellis {

namespace {
PbfStats stats_of(const std::vector<PbfLayer>& layers, double PbfLayer::*member) {
  PbfStats s;
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -s.min;
  for (const auto& l : layers) {
    if (!(l.area > 0)) continue;
    const double v = l.*member;
    sum += v;
    sum2 += v * v;
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
    ++n;
  }
  if (n == 0) return {};
  s.mean = sum / static_cast<double>(n);
  const double var = std::max(0.0, sum2 / static_cast<double>(n) - s.mean * s.mean);
  s.cv = s.mean > 0 ? std::sqrt(var) / s.mean : 0;
  return s;
}
}  // namespace

PbfStats fr_stats(const std::vector<PbfLayer>& layers, bool r67) {
  return stats_of(layers, r67 ? &PbfLayer::fr_r67 : &PbfLayer::fr);
}

PbfStats fr_eq_stats(const std::vector<PbfLayer>& layers, bool r67) {
  return stats_of(layers, r67 ? &PbfLayer::fr_eq_r67 : &PbfLayer::fr_eq);
}

PbfStats thickness_stats(const std::vector<PbfLayer>& layers) {
  PbfStats s;
  double sum = 0;
  std::size_t n = 0;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -s.min;
  for (const auto& l : layers) {
    if (l.t_count == 0) continue;
    sum += l.t_sum;
    n += l.t_count;
    s.min = std::min(s.min, l.t_min);
    s.max = std::max(s.max, l.t_max);
  }
  if (n == 0) return {};
  s.mean = sum / static_cast<double>(n);
  s.cv = s.mean > 0 ? (s.max - s.min) / s.mean : 0;
  return s;
}

Toolpath pbf_toolpath(const PbfResult& r, double contour_power, double contour_speed,
                      double hatch_power, double hatch_speed) {
  Toolpath tp;
  tp.source = "trellis pbf";
  for (std::size_t i = 0; i < r.layers.size(); ++i)
    tp.layers.push_back(pbf_layer_toolpath(r.layers[i], i, r.layer, contour_power, contour_speed,
                                           hatch_power, hatch_speed));
  return tp;
}

Layer pbf_layer_toolpath(const PbfLayer& L, std::size_t i, double thickness, double contour_power,
                         double contour_speed, double hatch_power, double hatch_speed) {
  {
    Layer layer;
    layer.z = static_cast<double>(i + 1) * thickness;  // the powder surface of layer i
    for (const auto& v : L.contours) {
      Path p;
      p.role = PathRole::Contour;
      p.power = contour_power;
      p.speed = contour_speed;
      for (auto q : v) p.points.push_back({q.x, q.y, layer.z});
      layer.paths.push_back(std::move(p));
    }
    for (const auto& h : L.hatches) {
      Path p;
      p.role = PathRole::Hatch;
      p.power = hatch_power;
      p.speed = hatch_speed;
      p.points = {{h.a.x, h.a.y, layer.z}, {h.b.x, h.b.y, layer.z}};
      layer.paths.push_back(std::move(p));
    }
    return layer;
  }
}

}  // namespace trellis
