// plan_pbf's steps (src/slice/pbf.cpp runs them in order): what a plan's layers share (Plan),
// the tiles layers a period apart take (pbf_tiles.cpp), a layer's sections and their marches
// (pbf_sections.cpp), thin-wall contours on the mid-curve (pbf_thin_walls.cpp), hatch vectors
// (pbf_hatch.cpp), one layer's plan and statistics (pbf_layer.cpp) and the in-order pipeline
// the layers run through (pbf_pipeline.cpp).
#pragma once
#include <tbb/enumerable_thread_specific.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "pbf_sections.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/pbf.hpp"

namespace trellis::pbf_detail {

// Bisection of many brackets [lo, hi] at once: each round samples the middle of every bracket
// still wider than tol in one batch. sample(active, middles, values) fills values for the
// listed brackets; low(value) tells whether the middle is on lo's side. At most max_rounds.
struct Bracket {
  double lo, hi;
};
template <class Sample, class Low>
void bisect_together(std::vector<Bracket>& br, double tol, int max_rounds, Sample sample, Low low) {
  std::vector<std::size_t> active;
  for (std::size_t i = 0; i < br.size(); ++i)
    if (br[i].hi - br[i].lo > tol) active.push_back(i);
  std::vector<double> mid, val;
  for (int round = 0; round < max_rounds && !active.empty(); ++round) {
    mid.resize(active.size());
    val.resize(active.size());
    for (std::size_t k = 0; k < active.size(); ++k)
      mid[k] = 0.5 * (br[active[k]].lo + br[active[k]].hi);
    sample(active, mid, val);
    std::size_t keep = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      Bracket& b = br[active[k]];
      (low(val[k]) ? b.lo : b.hi) = mid[k];
      if (b.hi - b.lo > tol) active[keep++] = active[k];
    }
    active.resize(keep);
  }
}

// What every layer of a plan shares, set up once by plan_pbf before the layers run.
struct Plan {
  const PbfDesign& design;
  const PbfOptions& o;
  Field part;              // design.part()
  BBox3 extent;            // the part's
  std::vector<double> zs;  // the layers' planes
  double c_const = 0;      // the sheet parameter c when it is a constant,
  Field c_field;           // else c as its own field
  bool thin_walls_possible = true;
  TriangleMesh mesh;                                // the STL route's marching-cubes part
  std::vector<std::vector<std::uint32_t>> buckets;  // its triangles each layer cuts
  // The coarse grid (joints, mid-curve) of step H, the section's of step Hs, both from lo over
  // [lo, hi] (nx × ny cells of Hs), pad around the part.
  double H = 0, Hs = 0, pad = 0;
  Vec2 lo, hi;
  std::size_t nx = 0, ny = 0;
  MarchOptions mo_section, mo_mid, mo_joint;
  std::size_t stride = 0;          // H / Hs
  bool section_crossings = false;  // the thin-wall march takes the section march's crossings
  Vec2 sheet_period;               // the sheet's period along x and y (0: it does not repeat)
};

// --- sections (pbf_sections.cpp) ---

// The grids and the marches' options (crossing tolerances, tiles, crossings shared).
void plan_grids(Plan& p);
// The section march of a context at height z over [a, b] (direct route): its crossings are kept
// with the context's grid for the thin-wall march.
ContourSet march_section(const Plan& p, Ctx& c, double z, Vec2 a, Vec2 b, MarchOptions mo);
// The joint slots of the grid's nodes hold the joint measure when the joints are marched (no
// compensation), else the thin-wall measure (the thin region is marched instead).
void use_grid(const Plan& p, Ctx& c, JointSection& joint, JointSection& thin);

// --- tiles (pbf_tiles.cpp) ---

// The tiles of one class of layers (i mod P): the section, thin-wall, joint and mid marches'.
struct ClassTiles {
  PeriodTiles section, thin, joint, mid;
  std::size_t bytes() const { return section.bytes + thin.bytes + joint.bytes + mid.bytes; }
};

// The sheet's period along x and y when the layers take periodic tiles, else 0 (and
// result.periodic_fraction, when probed).
Vec2 sheet_period(const Plan& p, PbfResult& result);

// Layers a period apart along z (the sheet repeats along z too, by a whole number P of layers)
// take the same tiles: a class of layers (i mod P) has its tiles made once, at the height of
// its first layer, by marches of the sheet alone over one period from the layers' grid origin,
// and kept while later layers of the class remain (up to the budget; else made again). Made
// from the class alone, they are the same whichever layers a run covers (a layer range run on
// its own equals that range of the whole run). A last layer cut below the top (not whole
// periods above its class's first) marches its own.
class ZTiles {
 public:
  // Layers up to `last` (excluded) will ask. With classes mirrored through the origin the grid
  // origin p.lo is moved down (result.mirror_tiles).
  ZTiles(Plan& p, std::size_t last, PbfResult& result);
  // Layer i's class tiles; null when it marches its own.
  std::shared_ptr<const ClassTiles> get(std::size_t i);
  // After layer i: its class's tiles are dropped when no later layer of the run needs them.
  void release(std::size_t i);
  std::size_t turned_classes() const { return turned_classes_; }

 private:
  void mirror_classes(Plan& p);
  std::size_t mirror_source(std::size_t c) const;
  std::shared_ptr<const ClassTiles> make(std::size_t c);

  const Plan& p_;
  std::size_t last_;
  std::size_t zp_;  // P; 0: no sharing along z
  int parity_;
  long long mirror_n_ = 0;
  bool mirror_ = false;
  std::size_t sx_s_ = 0, sy_s_ = 0, sx_c_ = 0, sy_c_ = 0;
  PbfDesign sheet_design_;
  Field sheet_part_;
  tbb::enumerable_thread_specific<Ctx> contexts_;
  std::vector<std::shared_ptr<const ClassTiles>> kept_;
  std::size_t kept_bytes_ = 0;
  std::mutex kept_mutex_;
  std::atomic<std::size_t> turned_classes_{0};
};

// --- one layer (pbf_layer.cpp, pbf_thin_walls.cpp, pbf_hatch.cpp) ---

// A march's contours, its blocks counted in the layer's.
ContourSet counted(ContourSet c, PbfLayer& L);
// The march options with the class's tiles of one march (none without class tiles).
MarchOptions tiled(const MarchOptions& base, const ClassTiles* ct,
                   const PeriodTiles ClassTiles::*which);

// Layer i into L on the calling thread's context.
void plan_layer(const Plan& p, ZTiles& tiles, Ctx& ctx, std::size_t i, PbfLayer& L);
// The contour scan vectors of layer i: chords along the mid-curve's thin-wall pieces, with the
// wall thickness measured along it.
void thin_wall_contours(const Plan& p, Ctx& ctx, JointSection& thin, const ClassTiles* ct,
                        std::size_t i, double z, PbfLayer& L);
// The layer's hatch vectors into L (ho: a point the hatch lines pass through); returns the
// whole section S hatched with the compensation (the R67 baseline).
std::vector<Segment2> hatch_layer(const Plan& p, Ctx& ctx, JointSection& joint, const Regions& S,
                                  const Regions& T, const Regions& hatch_region, Vec2 ho, double z,
                                  PbfLayer& L);
// The layer's totals added to the result's.
void add_layer_totals(PbfResult& result, const PbfLayer& L);

// --- pipeline (pbf_pipeline.cpp) ---

// A bounded in-order pipeline: layer numbers first … last − 1 in order, compute(i) in parallel
// (at most two per thread in flight), then collect(i) in order.
void run_layers_in_order(std::size_t first, std::size_t last,
                         const std::function<void(std::size_t)>& compute,
                         const std::function<void(std::size_t)>& collect);

}  // namespace trellis::pbf_detail
