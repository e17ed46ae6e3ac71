// A reproducible synthetic toolpath for the G-code benchmarks: `layers` layers of 2000 random
// 24-segment paths over a 200 x 200 mm bed.
#pragma once
#include "trellis/core/rng.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis::bench {

inline Toolpath random_toolpath(int layers, double layer_height, std::uint64_t seed) {
  Toolpath tp;
  Rng rng(seed);
  for (int l = 0; l < layers; ++l) {
    Layer layer{layer_height * (l + 1), {}};
    for (int p = 0; p < 2000; ++p) {
      Path path;
      path.height = layer_height;
      Vec3 q{rng.uniform01() * 200, rng.uniform01() * 200, layer.z};
      for (int k = 0; k < 25; ++k) {
        path.points.push_back(q);
        q = q + Vec3{rng.uniform01() - 0.5, rng.uniform01() - 0.5, 0};
      }
      layer.paths.push_back(std::move(path));
    }
    tp.layers.push_back(std::move(layer));
  }
  return tp;
}

}  // namespace trellis::bench
