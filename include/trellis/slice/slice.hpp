// Layer outlines from a field (marching squares, no mesh) or from a mesh (plane cuts), and the
// planar slicer: walls by inward offsets, top/bottom skins, rectilinear infill, ordered to keep
// travel short, written into the toolpath IR.
#pragma once
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "trellis/core/run_context.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/infill.hpp"
#include "trellis/slice/link.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// One horizontal section: `z` where it was cut (design coordinates), its outline.
struct LayerOutline {
  double z = 0;
  Regions regions;
};

// The field at a height, as a plane function (values, and interval bounds for skipping).
class FieldSection : public PlaneFunction {
 public:
  FieldSection(Evaluator& evaluator, double z) : ev_(evaluator), z_(z) {}
  void sample(const Vec2* points, double* out, std::size_t n) override;
  Interval bound(Vec2 lo, Vec2 hi) override;

 private:
  Evaluator& ev_;
  double z_;
  std::vector<Vec3> buffer_;
};

// Slicing planes: the middle of each layer of height h from the bottom of [zmin, zmax].
std::vector<double> layer_planes(double zmin, double zmax, double layer_height);

struct FieldSliceOptions {
  double resolution = 0.1;  // XY grid step (mm)
  MarchOptions march() const;
};

struct SliceStats {
  std::size_t samples = 0;
  std::size_t blocks = 0, skipped_blocks = 0;
};

// The outline of the field at z (closed polygons with holes). The field must have a finite XY
// extent (a root box or a bounded solid), else GeometryError.
Regions contour_at(const Field& field, Evaluator& evaluator, double z,
                   const FieldSliceOptions& options, SliceStats* stats = nullptr);
// All planes, in parallel (oneTBB), one evaluator per thread.
std::vector<LayerOutline> slice_field(const Field& field, const std::vector<double>& zs,
                                      const FieldSliceOptions& options, SliceStats* stats = nullptr,
                                      const RunContext& context = {});
// `overlapping`: the union of intersecting shells (slice_mesh), for repaired meshes.
std::vector<LayerOutline> slice_mesh_layers(const TriangleMesh& mesh, const std::vector<double>& zs,
                                            double stitch_tolerance = 1e-6,
                                            bool overlapping = false);

struct PlanarOptions {
  double layer_height = 0.2;  // mm
  double bead_width = 0.4;    // mm, wall spacing and solid infill spacing
  int walls = 2;
  int top_layers = 4;
  int bottom_layers = 4;
  double infill_density = 0.2;  // 0..1 of solid
  double infill_angle = 45;     // degrees; alternates with +90 every layer
  // Sparse infill pattern (slice/infill.hpp); skins are rectilinear. Lattice: an atlas pattern
  // (lattice/atlas.hpp) cropped to the infill region and planned by the Euler planner.
  InfillPattern infill_pattern = InfillPattern::Rectilinear;
  std::string infill_lattice = "honeycomb";
  std::uint64_t infill_seed = 1;  // lattice: Voronoi seeds
  // The part's XY box, so that lattice cells stack from layer to layer whatever window of
  // layers is planned; empty (zero width): the box of the outlines given.
  BBox2 infill_frame{};
  double infill_overlap = 0.15;  // fraction of a bead the infill reaches into the inner wall
  double simplify = 0.005;       // mm, outline simplification before offsetting
  double min_path = 0.05;        // mm, shorter infill pieces are dropped
  LinkOptions link;              // seams, connected fill, travel inside (slice/link.hpp)
  // A window of a part's layers (sharding, job/plate.hpp): the outlines given are the part's
  // layers first_index, first_index + 1, …, and only part layers [plan_begin, plan_end) get
  // paths; the toolpath holds those layers only (z and the alternating angles as in the whole
  // part). The window must reach bottom_layers below and top_layers above the planned layers
  // (or the part's ends) for the skins to be those of the whole part.
  std::size_t first_index = 0;
  std::size_t plan_begin = 0, plan_end = static_cast<std::size_t>(-1);
};

struct PlanarStats {
  // walls: wall loops; skin_lines / infill_lines: skin and infill paths (chains) printed
  std::size_t layers = 0, paths = 0, walls = 0, skin_lines = 0, infill_lines = 0;
  double extruded_length = 0;
  LinkStats link;  // starts, their lower bound, travel (slice/link.hpp)
  // Lattice infill: the Euler planner's trails and their proven minimum (before linking).
  std::size_t lattice_trails = 0, lattice_trail_bound = 0;
  // Time spent planning the layers and, of that, linking them (s, summed over the layers, so
  // over threads: CPU time rather than wall time).
  double layer_seconds = 0, link_seconds = 0;
  std::vector<LinkStats> layer_link;  // per planned layer, in order
  void add(const PlanarStats& o);     // sums, layer_link appended
};

// z of layer i's nozzle is (i + 1) · layer_height (the part's bottom on the bed).
// Parallel lines filling a region (spacing apart, at an angle), in zig-zag order from `cursor`
// (updated to the last end); with `link`, neighbouring lines are joined by short connectors
// that stay in the region. Pieces shorter than min_path are dropped.
std::vector<std::vector<Vec2>> fill_lines(const Regions& region, double angle_deg, double spacing,
                                          double bead_width, double min_path, bool link,
                                          Vec2& cursor);

// The same with a direction per square cell (`cell` mm, cells aligned with the origin):
// angle_of(cell centre) in degrees, rounded to `quantum`; each part of the region is filled at
// its cell's angle.
std::vector<std::vector<Vec2>> fill_lines_oriented(const Regions& region,
                                                   const std::function<double(Vec2)>& angle_of,
                                                   double cell, double quantum, double spacing,
                                                   double bead_width, double min_path, bool link,
                                                   Vec2& cursor);

Toolpath plan_planar(const std::vector<LayerOutline>& layers, const PlanarOptions& options,
                     PlanarStats* stats = nullptr);

// What lies under and over each layer's skins: the intersection of the `below` layers under a
// layer and of the `above` layers over it, for a part of `layers` layers given in order (a
// sliding window: the streamed slicer adds its layers as they are outlined, and each window is
// intersected once, never again at the end of a run of planned layers). A sparse table: runs of
// 2, 4, 8, … layers, each the intersection of two runs of half its length, and a window as the
// intersection of two runs that cover it. Runs whose two halves are the same regions (a stack
// of equal layers, as a prism's) share one result. Windows that do not fit in the part are
// empty; so is any window holding an empty layer.
class SkinWindows {
 public:
  using Ptr = std::shared_ptr<const Regions>;
  SkinWindows(std::size_t layers, int below, int above);
  // The next layers' outlines, in order; intersects every window they complete (oneTBB).
  void add(const std::vector<Ptr>& outlines);
  std::size_t size() const { return added_; }
  // The layers under `layer` down to `below` of them (null: below = 0), and over it up to
  // `above`. The layers they read must have been added (or the window reaches past the part).
  Ptr under(std::size_t layer) const;
  Ptr over(std::size_t layer) const;
  // Drops the windows of layers before `layer` (no longer asked for).
  void forget_before(std::size_t layer);
  // Clipper intersections run so far (runs shared by equal halves are not counted).
  std::size_t intersections() const { return intersections_; }

 private:
  struct Level {
    long base = 0;  // position of at.front()
    std::deque<Ptr> at;
    Ptr last_x, last_y;  // the inputs of at.back()
    const Ptr& operator[](long a) const { return at[static_cast<std::size_t>(a - base)]; }
    void drop_before(long a);
  };
  void compute(Level& out, long lo, long hi, const std::function<Ptr(long)>& first,
               const std::function<Ptr(long)>& second);
  long n_, below_, above_;
  std::size_t added_ = 0, intersections_ = 0;
  std::vector<Level> runs_;  // runs_[k]: runs of 2^k layers
  Level under_, over_;       // windows of `below` and of `above` layers, by their first layer
  Ptr empty_;
};

// One layer of plan_planar's, its inputs made: part layer `index` (z = (index + 1) ·
// layer_height), cut at `plane`, its outline simplified by options.simplify, and its skins'
// windows (SkinWindows::under and over).
struct PlanarLayerInput {
  std::size_t index = 0;
  double plane = 0;
  SkinWindows::Ptr outline, under, over;
};
// plan_planar on those layers (all planned; first_index, plan_begin and plan_end unused), lattice
// infill on options.infill_frame (the box of these outlines if it is empty).
Toolpath plan_planar_layers(const std::vector<PlanarLayerInput>& layers,
                            const PlanarOptions& options, PlanarStats* stats = nullptr);

}  // namespace trellis
