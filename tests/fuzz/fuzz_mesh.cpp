// Fuzzes the STL (binary and ASCII) and OBJ readers, the closure check and plane slicing, and
// (open meshes) the height-field check and non-planar slicing.
#include <algorithm>
#include <cmath>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/nonplanar.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (int kind = 0; kind < 2; ++kind) {
    try {
      const trellis::TriangleMesh m =
          kind == 0 ? trellis::parse_stl(text, "fuzz.stl") : trellis::parse_obj(text, "fuzz.obj");
      const auto c = trellis::check_mesh(m);
      if (c.closed()) {
        const trellis::BBox3 b = trellis::bounds(m);
        (void)trellis::slice_mesh(m, 0.5 * (b.min.z + b.max.z));
      } else if (m.triangles.size() <= 2000) {
        const trellis::HeightField h = trellis::HeightField::from_mesh(m, "fuzz");
        const trellis::BBox2 d = h.domain();
        trellis::NonplanarParams p;
        p.layers = 2;
        p.width = std::max({d.width(), d.height(), 1e-3}) / 40;  // bounded work
        p.layer_height = p.width;
        if (std::isfinite(p.width)) (void)trellis::slice_nonplanar(h, p);
      }
    } catch (const trellis::Error&) {
    }
  }
  return 0;
}
