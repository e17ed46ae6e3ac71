// The pixels of a grid whose centres lie inside a region set (even-odd over all its rings), found
// row by row from each row's crossings with the rings: coverage checks paint beads into a grid
// and count what lies inside the outline.
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

#include "trellis/geom/regions.hpp"

namespace trellis::test {

// fn(ix, iy) for each pixel of an nx × ny grid of `px` mm pixels from `origin` (the grid's lower
// left corner) whose centre lies inside `regions`.
template <class Fn>
void for_each_pixel_inside(const Regions& regions, Vec2 origin, double px, int nx, int ny,
                           Fn&& fn) {
  const auto rings = rings_of(regions);
  std::vector<double> xs;
  for (int iy = 0; iy < ny; ++iy) {
    const double y = origin.y + (iy + 0.5) * px;
    xs.clear();
    for (const auto& ring : rings)
      for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
        if ((ring[i].y > y) != (ring[j].y > y))
          xs.push_back(ring[j].x +
                       (ring[i].x - ring[j].x) * (y - ring[j].y) / (ring[i].y - ring[j].y));
    std::sort(xs.begin(), xs.end());
    for (std::size_t k = 0; k + 1 < xs.size(); k += 2)
      for (int ix = std::max(0, static_cast<int>(std::ceil((xs[k] - origin.x) / px - 0.5)));
           ix < nx && origin.x + (ix + 0.5) * px < xs[k + 1]; ++ix)
        fn(ix, iy);
  }
}

}  // namespace trellis::test
