// Fuzzes the .vcad reader and the field it builds: any input parses or throws trellis::Error;
// evaluating and contouring a small parsed design never crashes or hangs.
#include <cmath>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/slice/slice.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    trellis::VcadOptions opt;
    opt.base_dir = "/nonexistent-trellis-fuzz";  // mesh() must fail cleanly, not read files
    const auto d = trellis::parse_vcad(std::string(reinterpret_cast<const char*>(data), size),
                                       "fuzz.vcad", opt);
    trellis::Evaluator ev(d.field);
    for (double t : {-1.0, 0.0, 0.5, 2.0}) (void)ev.value({t, t * 0.5, -t});
    (void)ev.fractions({0.1, 0.2, 0.3});
    const trellis::BBox3 e = d.field.extent();
    const double span = std::max(e.max.x - e.min.x, e.max.y - e.min.y);
    if (std::isfinite(span) && span < 50) {
      trellis::FieldSliceOptions o;
      o.resolution = 0.5;
      (void)trellis::contour_at(d.field, ev, 0.5 * (e.min.z + e.max.z), o);
    }
  } catch (const trellis::Error&) {
  }
  return 0;
}
