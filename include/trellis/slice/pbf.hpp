// STL-free hybrid laser toolpaths for sheet lattices (PBF paper §3.1–3.3): per layer, the sheet
// Φ = φ² − c² is cut straight from the field; where the mid-surface φ = 0 is steep and the wall
// one track wide (thin walls) a single contour track follows φ = 0, cut into scan vectors of
// length SL separated by gaps LHD; elsewhere (joints, shallow overhangs, solid parts) the region
// is hatched with lines rotated 67° per layer, each vector's ends found by zero-finding on the
// field and pulled in by the beam compensation. The filling ratio FR_a = D·ΣL/A (Eq. 8) is
// reported for this path and for the plain rotating-67° hatch of the whole sheet (R67).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "trellis/core/budget.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/run_context.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/toolpath/scan_defaults.hpp"
#include "trellis/toolpath/scan_time.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct PbfDesign {
  Field phi;                // mid-surface φ (e.g. a TPMS network field)
  Expression c;             // sheet half-width parameter: a number or an expression
  double thickness = 0;     // > 0: uniform thickness instead of c (c = t·|∇φ|/2)
  Field envelope;           // where the lattice is (a box, a mesh field…)
  Field solids;             // optional solid parts (bosses), hatched; may be empty
  std::vector<BBox3> clip;  // boxes Φ ∩ envelope is cut by (a .vcad's root box), if any
  // Φ ∩ envelope (clipped) ∪ solids: the part.
  Field part() const;
};

// Where each layer's hatch lines are fixed (they lie hatch_distance apart across the point):
// Wall — through the design's origin (the Fig. 3 wall's centre line, a lattice's centre);
// Origin — through the machine origin (PbfOptions::machine_origin), as a machine hatches in plate
// coordinates; Random — moved across by a uniform fraction of the hatch distance every layer.
enum class HatchPhase { Wall, Origin, Random };
// How thin walls (contoured) and joints (hatched) are told apart: Width — horizontal width <=
// thin_multiple·D and the mid-surface at least min_inclination steep; Inclination — the paper's
// Eq. 6 / Fig. S5: c interpolated by the mid-surface's inclination (pbf_split_c), the thin wall
// being the sheet of that c and the joint the rest of the section.
enum class PbfSplit { Width, Inclination };

// The PBF paper's c by inclination (Fig. S5): 0 where the mid-surface is shallower than
// `min_inclination` (degrees from horizontal), the full c from min_inclination + kSplitBand up,
// linear between (the figure's band is not given in the text: 10° here).
inline constexpr double kSplitBand = 10;
double pbf_split_c(double c, double inclination_deg, double min_inclination_deg);

// The equivalent scan length L̃_p of one vector of length L (Supplementary Text 3 is not in the
// text we have): the area a melt track D wide with round ends covers, over D, L + π·D/4.
double equivalent_length(double length, double melt_pool);

// pbf.resolution's default: the sampling step of TPMS sheets and of solid parts' field sections.
inline constexpr double kPbfResolution = 0.025;  // mm

// PbfOptions::test: switches for the tests and benchmarks that compare (no setting, no flag).
struct PbfTestSwitches {
  // STL route only: every layer tests every triangle of the mesh instead of the triangles its
  // plane cuts (a slicer without a plane index, O(layers × triangles): the STL baseline as the
  // PBF paper counts it, "approximately O(n⁴)"). For the comparison benchmark.
  bool stl_scan_all = false;
  // Direct route: the thin-wall outline takes the section march's refined crossings where the
  // part decides it (false: refines its own; for the tests that compare the two).
  bool reuse_section_crossings = true;
  // A sheet that repeats across the plane (a TPMS φ with a constant c or thickness): the
  // contours of blocks where the part is that sheet alone (inside the envelope and the root
  // boxes, outside the solids) are marched once per period and translated to the others
  // (MarchOptions::periodic_tiles); false: every block is marched (for the tests that compare).
  bool periodic_tiles = true;
  // With periodic tiles and a sheet that also repeats along z by a whole number of layers P:
  // layers P apart take the same tiles, made once per class of layers (i mod P) by marches of the
  // sheet alone over one period at the class's first height and kept, up to this many bytes, for
  // the class's later layers (0: every layer marches its own tiles; for the tests that compare).
  std::size_t z_tiles_budget = std::size_t{8} << 20;
  // With layers sharing tiles along z and a φ symmetric through the origin (Field::
  // inversion_parity: the gyroid, Schwarz P and D, …), the sheet at −z is the sheet at z turned
  // half a turn about the z axis: a class of layers whose mirror class (its heights' negatives,
  // modulo the period) comes first takes that class's tiles turned, instead of marching its own
  // (the grid's origin is then moved out to where the turn maps tiles onto tiles); false: every
  // class marches its own (for the tests that compare).
  bool mirror_tiles = true;
};

struct PbfOptions {
  // The scan parameters: the laser profile's (LaserProfile), with its defaults.
  double layer = kScanLayer;  // mm
  // mm: the STL route's voxel, the seed bracket of hatch ends and the zero-finding step of the
  // plain R67 hatch; the direct contours (section, joints, mid-curve) are sampled on a grid
  // `coarse` times this, their crossings refined on the field.
  double resolution = kPbfResolution;
  int coarse = 2;
  // Contour scan vectors are straight chords of length SL with both ends on φ = 0, LHD apart
  // (> 0 and >= 0; the paper tested 5–400 µm and 0–120 µm, outside that is a warning).
  double segment_length = kScanSegmentLength;  // SL, mm
  double segment_gap = kScanSegmentGap;        // LHD, mm
  double hatch_distance = kScanHatchDistance;  // mm
  // mm: the hatched region (joints; the whole sheet for R67) is offset inward by this before
  // hatching, so every hatch vector keeps this distance from the region's boundary whatever its
  // angle to the wall; contour tracks stop this far (along φ = 0) from the part's outer boundary.
  double beam_compensation = kScanBeamCompensation;
  double melt_pool = kScanMeltPoolWidth;  // D, mm
  double thin_multiple = 1.5;             // thin wall: horizontal width <= this × D
  double min_inclination = 20;            // degrees; shallower mid-surface → joint
  double hatch_angle = 0;                 // first layer's hatch angle, degrees
  double hatch_rotation = 67;             // degrees per layer
  HatchPhase hatch_phase = HatchPhase::Wall;
  Vec2 machine_origin{};         // the machine's origin in design coordinates (Origin phase)
  std::uint64_t hatch_seed = 1;  // Random phase: seeds the layers' shifts
  PbfSplit split = PbfSplit::Width;
  double contour_shift = 0.381966;  // scan-vector phase shift per layer, fraction of SL+LHD
  double refine = 1e-4;             // mm, crossing accuracy of hatch ends
  bool hybrid = true;               // false: plain R67 hatch of the whole sheet
  bool stl_route = false;           // regions from a marching-cubes mesh instead of the field
  // Switches that exist for the tests and benchmarks that compare two ways of making the same
  // paths; users' runs keep the defaults (no setting reaches them).
  PbfTestSwitches test;
  // Scan-time model (speeds, delays) for the per-layer times of this path and the R67 baseline.
  ScanTiming timing;
};

struct PbfLayer {
  double z = 0;                                 // design height of the cut
  double hatch_angle = 0;                       // degrees
  std::vector<std::vector<Vec2>> contours;      // contour scan vectors (polylines)
  std::vector<Segment2> hatches;                // hatch vectors
  double area = 0;                              // sheet cross-section A (mm²)
  double contour_length = 0, hatch_length = 0;  // mm
  double fr = 0;                                // FR_a of this path
  double fr_r67 = 0;                            // FR_a of the R67 baseline on the same layer
  // FR_a with the equivalent scan length L̃_p (equivalent_length) of every vector, both paths.
  double fr_eq = 0, fr_eq_r67 = 0;
  double r67_length = 0;                    // mm, the R67 baseline's hatch length
  double scan_time = 0, scan_time_r67 = 0;  // s, this path and the R67 baseline
  // Sheet thickness measured along ∇φ from mid-curve points (Φ = 0 on both sides): min, max,
  // sum, count.
  double t_min = 0, t_max = 0, t_sum = 0;
  std::size_t t_count = 0;
  // Top blocks of this layer's marches, and those translated from another period's
  // (PbfOptions::test.periodic_tiles) instead of contoured.
  std::size_t blocks = 0, tiled_blocks = 0;
  // Solid parts (slice/pbf_mesh.hpp, pbf_skin.hpp): each contour's offset (0: the outermost),
  // each hatch's region kind (HatchKind: skin, core, up-skin, down-skin), and each kind's area
  // (mm²) and hatch length (mm). Empty: every contour the first offset, every hatch skin.
  std::vector<std::uint8_t> contour_offset, hatch_kind;
  std::array<double, 4> kind_area{}, kind_hatch_length{};
};

struct PbfStats {
  double mean = 0, min = 0, max = 0, cv = 0;  // over layers with area > 0
};
PbfStats fr_stats(const std::vector<PbfLayer>& layers, bool r67);
// The same over FR_a with L̃_p (PbfLayer::fr_eq, fr_eq_r67).
PbfStats fr_eq_stats(const std::vector<PbfLayer>& layers, bool r67);
// Wall thickness over all layers' samples (mean, min, max; cv = (max − min) / mean here).
PbfStats thickness_stats(const std::vector<PbfLayer>& layers);

struct PbfResult {
  std::vector<PbfLayer> layers;
  BBox3 extent;
  double layer = 0;  // thickness (mm)
  std::size_t contour_vectors = 0, hatch_vectors = 0;
  double contour_length = 0, hatch_length = 0;
  // STL route only: the mesh it made.
  std::size_t mesh_triangles = 0, mesh_bytes = 0, grid_bytes = 0;
  double seconds = 0;
  double scan_time = 0, scan_time_r67 = 0;  // s, sums over layers
  double memory_estimate = 0;               // bytes, estimated before the run
  // False when the sheet is nowhere as narrow as a thin wall (thin_multiple · D), by φ's
  // Lipschitz bound and a constant c, or a uniform thickness: no thin walls, their march skipped.
  bool thin_walls_possible = true;
  // Sums of the layers' march blocks and of those translated from another period's; the
  // share of the part's extent where the part is the repeating sheet alone (on three layers;
  // tiles are used from 0.3), 0 when the sheet does not repeat.
  std::size_t blocks = 0, tiled_blocks = 0;
  double periodic_fraction = 0;
  // Whether classes of layers mirrored through the origin take each other's tiles turned
  // (PbfOptions::test.mirror_tiles), and how many classes' tiles were made so (not marched).
  bool mirror_tiles = false;
  std::size_t turned_classes = 0;
  Diagnostics diagnostics;  // warnings (settings outside the paper's ranges…)
};

// Bytes plan_pbf would use for this design and these options with `threads` workers (per-thread
// grids and caches, the layers' vectors and the toolpath made of them; the STL route's mesh is
// not counted). plan_pbf refuses to start above its context's memory budget.
double pbf_memory_estimate(const PbfDesign& design, const PbfOptions& options, int threads);
// streamed: the layers' vectors go to a sink as they come (plan_pbf with a sink), so only the
// pipeline's layers in flight count.
double pbf_memory_estimate(const PbfDesign& design, const PbfOptions& options, int threads,
                           bool streamed);

// Seconds plan_pbf (the direct route) takes with `threads` workers, from the outline length of
// five sampled sections (an order of magnitude, for refusing runs beyond run.max_time).
double pbf_time_estimate(const PbfDesign& design, const PbfOptions& options, int threads);
// Scan vectors of the whole build, from the sampled sections' area (FR_a ≈ 1).
double pbf_vectors_estimate(const PbfDesign& design, const PbfOptions& options);
// The part's mean section over five sampled layers: area (mm²) and outline length (mm).
struct PbfSections {
  double area = 0, perimeter = 0;
};
PbfSections pbf_sample_sections(const PbfDesign& design, const PbfOptions& options);

// The paper's thin-wall experiments (Fig. 3): a plane wall of thickness t (mm) through the
// origin, inclined `inclination` degrees from the horizontal (90 = vertical) and running along
// `azimuth` degrees from the X axis, cut by a box of `size` centred at the origin.
PbfDesign plane_wall(double thickness, double inclination_deg, double azimuth_deg, Vec3 size);

// `context` (core/run_context.hpp): stage "layers", reported under a lock; cancel checked per
// layer; the memory estimate refused above its budget (unless forced); the layers on its threads;
// the result's diagnostics also go to its diagnostics.
PbfResult plan_pbf(const PbfDesign& design, const PbfOptions& options,
                   const RunContext& context = {});

// Streaming and layer ranges (issue 23: bounded memory, sharding). Layers are numbered from 0 at
// the bottom of the part's extent; a layer's vectors depend only on the design, the options and
// its number (hatch angle and contour phase included), so any range computed on its own gives
// the same vectors as the whole run.
struct PbfLayerRange {
  std::size_t first = 0;                            // first layer number
  std::size_t last = static_cast<std::size_t>(-1);  // one past the last (clamped to the count)
};
// Called in layer order, from one thread at a time, with the layer's number and the layer.
using PbfLayerSink = std::function<void(std::size_t index, const PbfLayer& layer)>;
// The number of layers plan_pbf makes for this design and options.
std::size_t pbf_layer_count(const PbfDesign& design, const PbfOptions& options);
// Layers [range.first, range.last) computed in parallel by a bounded in-order pipeline (at most
// twice the threads' layers in flight) and handed to `sink` in order. With a sink, the result's
// layers keep their series (z, FR_a, lengths, area, times) but not their vectors, so memory does
// not grow with the layer count; without one they keep everything (as plan_pbf). The totals
// (vectors, lengths, scan times) are over the range.
PbfResult plan_pbf(const PbfDesign& design, const PbfOptions& options, const PbfLayerSink& sink,
                   PbfLayerRange range = {}, const RunContext& context = {});

// The toolpath IR: contour vectors role Contour, hatch vectors role Infill, with laser power and
// speed per role.
Toolpath pbf_toolpath(const PbfResult& result, double contour_power, double contour_speed,
                      double hatch_power, double hatch_speed);
// Layer number `index` of a run with layers `layer` mm thick as a toolpath layer (what
// pbf_toolpath makes of it): for writing layer by layer.
Layer pbf_layer_toolpath(const PbfLayer& layer, std::size_t index, double layer_thickness,
                         double contour_power, double contour_speed, double hatch_power,
                         double hatch_speed);

}  // namespace trellis
