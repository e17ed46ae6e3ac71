// Laser powder-bed paths for solid parts (a triangle mesh, or a .vcad solid through the field
// kernel): the part is cut into layers (the planar slicer's mesh and field slicing), and each
// layer's region is scanned as PBF machines do: N contour offsets, the first at the beam
// compensation and each next one a contour distance further in, then the region inside the last
// contour hatched by a scan strategy (slice/scan_strategy.hpp), optionally split into skin, core,
// up-skin and down-skin (slice/pbf_skin.hpp), each kind and each contour offset with its own
// laser parameter set. Layers are planned in parallel
// in batches and handed to a sink in order, so memory does not grow with the layer count; the
// vectors go into the same PbfLayer the TPMS route (slice/pbf.hpp) makes, so its writers, report
// and scan-time model serve both.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "trellis/core/run_context.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/pbf_skin.hpp"
#include "trellis/slice/scan_strategy.hpp"
#include "trellis/slice/slice.hpp"

namespace trellis {

struct PbfSolidOptions {
  double layer = kScanLayer;  // mm, powder layer thickness
  // mm, the first contour's (and with none, the hatch's) inset
  double beam_compensation = kScanBeamCompensation;
  int contours = 1;  // contour offsets per region (0: hatch only)
  // mm between contours and from the last contour to the hatched region; 0 = the hatch distance.
  double contour_distance = 0;
  ScanPattern pattern;  // hatch distance, strategy, angle and rotation
  // Where each layer's hatch lines lie across (slice/pbf.hpp HatchPhase): Wall — through the
  // design's origin; Origin — through the machine origin, `machine_origin` in design
  // coordinates; Random — moved by a uniform fraction of the hatch distance (`hatch_seed`).
  HatchPhase hatch_phase = HatchPhase::Wall;
  Vec2 machine_origin{};
  std::uint64_t hatch_seed = 1;
  // Skin, core, up-skin and down-skin (all 0: one kind, skin). Each kind's own hatch (index:
  // HatchKind; skin's is the pattern): distance (0: the pattern's) and rotation per layer (NaN:
  // the pattern's). A kind with its own lines is hatched on them; the others are cut from the
  // pattern's hatch of the whole region, so their vectors meet end to end.
  struct KindHatch {
    double distance = 0;
    double rotation = std::numeric_limits<double>::quiet_NaN();
  };
  SkinOptions skin;
  std::array<KindHatch, kHatchKinds> kind_hatch{};
  // Laser parameter sets: the speeds time each vector (a speed of 0: the timing's), the powers
  // go into the build file through pbf_solid_layer_toolpath.
  PbfExposures exposures;
  double resolution = kPbfResolution;  // mm, XY grid of a field's sections (.vcad solids)
  std::size_t batch = 32;              // layers sliced and planned together
  ScanTiming timing;                   // scan-time model of each layer
  // A kind's scan pattern (the hatch pattern with the kind's distance and rotation), and whether
  // it differs from the pattern (the kind has lines of its own).
  ScanPattern pattern_of(HatchKind kind) const;
  bool own_lines(HatchKind kind) const;
};

// The part: a closed triangle mesh or a solid field (exactly one of the two).
struct PbfSolid {
  const TriangleMesh* mesh = nullptr;
  const Field* field = nullptr;
  BBox3 extent() const;
};

// The vectors of one layer region (outlines of a section, design coordinates), layer number
// `index` (for the hatch angle and island shift). With `kinds` (SkinWindow::split of the region)
// each kind's part of the hatch is its own, the core on the core pattern's lines.
PbfLayer plan_pbf_layer(const Regions& region, std::size_t index, const PbfSolidOptions& options);
PbfLayer plan_pbf_layer(const Regions& region, const LayerKinds* kinds, std::size_t index,
                        const PbfSolidOptions& options);

// The point layer `index`'s lines of `pattern` pass through (PbfSolidOptions::hatch_phase).
Vec2 hatch_phase_point(const PbfSolidOptions& options, const ScanPattern& pattern,
                       std::size_t index);

// Layer `index` as a toolpath layer (pbf_layer_toolpath) with every contour's and hatch's power
// and speed from its parameter set.
Layer pbf_solid_layer_toolpath(const PbfLayer& layer, std::size_t index, double layer_thickness,
                               const PbfExposures& exposures);

// Every layer of the part, bottom to top, handed to `sink` in order (with their vectors); the
// result keeps the layers' series (z, lengths, area, scan time) without their vectors when a
// sink is given, all of it without one. `context` (core/run_context.hpp): cancel checked per
// batch, "layers" reported per batch, the batches' layers on its threads.
PbfResult plan_pbf_solid(const PbfSolid& part, const PbfSolidOptions& options,
                         const PbfLayerSink& sink = {}, const RunContext& context = {});

}  // namespace trellis
