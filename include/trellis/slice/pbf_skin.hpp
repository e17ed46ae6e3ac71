// Region kinds of a solid part's layers for laser powder-bed fusion, each exposed with its own
// laser parameter set (build processors' exposure types: Netfabb's up-skin and down-skin
// filters, EOSPRINT's in-skin / up-skin / down-skin and core; PySLM's build styles):
//   down-skin  the part of a layer with no material somewhere in the N layers below it
//              (N = downskin_thickness / layer, rounded up): over powder;
//   up-skin    the rest of it with no material somewhere in the N layers above it (its own N);
//   core       the rest that is at least `skin_thickness` inside the part: inside every layer
//              within that distance above and below, eroded by it in XY;
//   skin       what is left.
// The four partition the layer's region. Each layer is sliced once; the intersection of a run
// of consecutive layers is made once and shared: the run above layer i is the run below layer
// i + N + 1 (a sliding window).
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <utility>
#include <vector>

#include "trellis/geom/regions.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

enum class HatchKind : std::uint8_t { Skin, Core, UpSkin, DownSkin };
inline constexpr std::size_t kHatchKinds = 4;
// "skin", "core", "upskin", "downskin": report keys and parameter-set names.
const char* hatch_kind_name(HatchKind kind);

struct SkinOptions {
  double skin_thickness = 0;      // mm: the core is at least this inside the surface; 0 = no core
  double upskin_thickness = 0;    // mm below a top surface that is up-skin; 0 = none
  double downskin_thickness = 0;  // mm above a bottom surface that is down-skin; 0 = none
  bool any() const { return skin_thickness > 0 || upskin_thickness > 0 || downskin_thickness > 0; }
};

// A layer's region by kind (index: HatchKind).
using LayerKinds = std::array<Regions, kHatchKinds>;

// The layers a thickness spans (rounded up, 0 for none).
std::size_t layers_within(double thickness, double layer);

class SkinWindow {
 public:
  // `layers`: the part's layer count (layers beyond it, and below 0, are empty).
  SkinWindow(const SkinOptions& options, double layer, std::size_t layers);
  // Layers a layer's kinds depend on, above and below it.
  std::size_t reach() const { return reach_; }
  // Makes the intersections layers [first, end) need; `region(j)` is layer j's region, for j in
  // [first − reach, end + reach) within the part. Runs below first − reach are forgotten.
  void prepare(std::size_t first, std::size_t end,
               const std::function<const Regions&(std::size_t)>& region);
  // Layer i's kinds (after prepare covering i); safe to call from several threads at once.
  LayerKinds split(std::size_t i, const Regions& region) const;

 private:
  using Run = std::pair<long, long>;  // layers [first, first + count)
  const Regions& run(Run r) const;
  Run above(std::size_t i) const { return {static_cast<long>(i) + 1, static_cast<long>(n_up_)}; }
  Run below(std::size_t i) const {
    return {static_cast<long>(i) - static_cast<long>(n_down_), static_cast<long>(n_down_)};
  }
  Run around(std::size_t i) const {
    return {static_cast<long>(i) - static_cast<long>(n_core_), 2 * static_cast<long>(n_core_) + 1};
  }
  SkinOptions o_;
  std::size_t layers_, n_up_, n_down_, n_core_, reach_;
  std::map<Run, Regions> runs_;
  Regions empty_;
};

// Laser parameter sets (W, mm/s) of a solid part's vectors: each contour offset and each kind.
struct LaserSet {
  double power = 0, speed = 0;
  bool operator==(const LaserSet&) const = default;
};
struct PbfExposures {
  LaserSet contour, hatch;          // the profile's contour and hatch sets
  std::vector<LaserSet> contours;   // per contour offset, outermost first; empty: all `contour`
  LaserSet core, upskin, downskin;  // a power or speed of 0: the hatch's
  LaserSet of_contour(std::size_t offset) const;
  LaserSet of(HatchKind kind) const;
};

// The named laser parameter sets of a solid part's vectors (Toolpath::parameter_sets, the build
// file's ids): "contour" and "hatch" (the profile's), then "contour k", "core hatch", "upskin
// hatch" and "downskin hatch" for each in use (`skin`) that is not one of those or an earlier
// one in power and speed (a machine knows a set by its power and speed).
std::vector<ParameterSet> named_parameter_sets(const PbfExposures& exposures,
                                               const SkinOptions& skin);

// The pieces of hatch vectors `segments` inside `region`, in their order and direction. The
// vectors lie on lines `spacing` apart through `origin` at `angle_deg` or at 90° to it (islands);
// the region is cut on the same lines (hatch() in geom/regions.hpp), so the pieces are exact.
std::vector<Segment2> clip_hatches(const std::vector<Segment2>& segments, const Regions& region,
                                   double angle_deg, double spacing, Vec2 origin);

}  // namespace trellis
