// The nozzle-collision model of embedded (and any 3-axis) strut printing, in one place: the AERO
// planner uses it to decide what may be printed when, the independent checker replays toolpaths
// against it.
//
// The nozzle is a vertical cylinder of radius R from the tip upward. With the tip at q, printed
// material at p is hit when p lies above q by more than `tip_clearance` and within R of q
// horizontally. Points of the printed strut within `node_clearance` of a node it shares with the
// strut being printed are exempt (the nozzle meets its own node there). Struts within the cone of
// half-angle `cone_half_angle_deg` around the nozzle axis may only be printed bottom-up.
//
// Hand-written: the test is a small exact geometric predicate (a convex quadratic minimised over
// a clipped parameter square), not something a library offers.
#pragma once
#include <cstdint>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/lattice/graph.hpp"

namespace trellis {

struct NozzleModel {
  double radius = 0.36;             // R (mm): the paper's 410 µm nozzle plus its wall
  double tip_clearance = 0.05;      // material less than this above the tip is not hit (mm)
  double node_clearance = 1.0;      // exemption around shared nodes (mm)
  double cone_half_angle_deg = 30;  // struts this close to vertical print bottom-up only
  double end_overlap = 0;  // planning only: struts as printed may run this far past their nodes
                           // (the writer's node overlap); the blocking relation extends both
                           // the tip path and the material by it

  void validate() const;  // throws SettingError
};

// True if struts within the cone must be printed bottom-up: |dz| >= |d| cos(half angle).
bool is_steep(Vec3 a, Vec3 b, const NozzleModel& nozzle);

// Where a collision happens: the tip position and the hit point.
struct Contact {
  Vec3 tip, point;
};

// Does a tip moving along [tip_a, tip_b] hit material deposited along [printed_a, printed_b]?
// Points of the printed segment within node_clearance of any of `shared` (n_shared points) are
// exempt. Exact up to rounding: the horizontal distance, a convex quadratic in the two segment
// parameters, is minimised over the part of the parameter square where the height condition
// holds.
bool nozzle_hits(const NozzleModel& nozzle, Vec3 tip_a, Vec3 tip_b, Vec3 printed_a, Vec3 printed_b,
                 const Vec3* shared, int n_shared, Contact* contact = nullptr);

// Uniform XY grid over segment footprints padded by `pad`, for candidate pairs: segments whose
// padded footprint shares a cell with a query footprint. Cells about the size of a typical
// footprint, at most ~4 per segment.
class FootprintIndex {
 public:
  // ends[2i], ends[2i+1] are segment i.
  FootprintIndex(const std::vector<Vec3>& ends, double pad);

  // Calls f(j) once per candidate segment j (a per-caller stamp vector of size segments()
  // de-duplicates; `tick` must be fresh per query).
  template <class F>
  void for_candidates(Vec3 a, Vec3 b, std::vector<std::uint32_t>& stamp, std::uint32_t tick,
                      F&& f) const {
    int ix0, ix1, iy0, iy1;
    range(a, b, 0, ix0, ix1, iy0, iy1);
    for (int iy = iy0; iy <= iy1; ++iy)
      for (int ix = ix0; ix <= ix1; ++ix) {
        const std::size_t c = static_cast<std::size_t>(iy) * nx_ + ix;
        for (std::uint32_t k = offsets_[c]; k < offsets_[c + 1]; ++k) {
          const std::uint32_t j = items_[k];
          if (stamp[j] == tick) continue;
          stamp[j] = tick;
          f(j);
        }
      }
  }
  std::size_t segments() const { return count_; }
  // Candidates all queries of the indexed segments visit together (about the sum of each cell's
  // count squared): a replay's work, quadratic when the segments pile up in a few cells.
  double visits() const;

 private:
  void range(Vec3 a, Vec3 b, double pad, int& ix0, int& ix1, int& iy0, int& iy1) const;
  double x0_ = 0, y0_ = 0, cell_ = 1;
  int nx_ = 1, ny_ = 1;
  std::size_t count_ = 0;
  std::vector<std::uint32_t> offsets_, items_;
};

// Compressed lists per strut.
struct StrutLists {
  std::vector<std::uint32_t> offsets;
  std::vector<EdgeId> items;
  std::size_t count(EdgeId s) const { return offsets[s + 1] - offsets[s]; }
  const EdgeId* begin(EdgeId s) const { return items.data() + offsets[s]; }
  const EdgeId* end(EdgeId s) const { return items.data() + offsets[s + 1]; }
};

// The precedence the model imposes on a lattice: `blocks` lists for each strut s the struts u it
// would obstruct if s were printed before u (so u must come first); `blocked_by` is the same
// relation seen from u. Built with an XY grid so only struts whose footprints come within R of
// each other are tested.
struct BlockingGraph {
  StrutLists blocks, blocked_by;
  std::size_t pairs_tested = 0;
  std::size_t relations() const { return blocks.items.size(); }
};

// Parallel over struts (oneTBB). `threads` 0 = all cores.
BlockingGraph blocking_graph(const Graph& g, const NozzleModel& nozzle, int threads = 0);

}  // namespace trellis
