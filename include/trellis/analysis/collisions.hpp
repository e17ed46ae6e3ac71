// The independent collision checker: replays any toolpath in print order (ours, or read back from
// G-code) against the nozzle model of lattice/collision.hpp and reports every collision with the
// strut ids and positions, steep struts printed top-down, and struts missing or printed twice.
//
// It knows nothing of how the path was planned: printed segments are matched to design struts by
// snapping their ends to design nodes (within `snap`, which must exceed any node overlap the
// writer added), each segment's tip sweep is tested against every segment printed before it.
// Travel is assumed to be the embedded writer's (vertical lift to the bath surface, move above
// everything, vertical descent), which is free of collisions exactly when the nozzle cylinder at
// the two ends is — and the ends are checked as part of the printed segments.
//
// The replay holds only the material a later tip can still hit: before each layer, what lies no
// higher than the lowest tip of the layers still to come (+ tip_clearance) is dropped, so a print
// of stacked layers is replayed in about two layers' memory, streamed from its file.
#pragma once
#include <string>
#include <vector>

#include "trellis/core/budget.hpp"
#include "trellis/lattice/collision.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// A segment end within this of a design node is at that node (mm); a print whose struts run past
// their nodes (embedded.node_overlap, nozzle.end_overlap) is checked with that overlap + this.
inline constexpr double kNodeSnap = 0.05;

struct CheckOptions {
  NozzleModel nozzle;
  double snap = kNodeSnap;        // a segment end within this of a design node is at that node (mm)
  std::size_t max_listed = 1000;  // collisions listed in full (all are counted)
  Budget budget;                  // the replay's estimate is checked against it before it starts
};

struct CollisionHit {
  std::size_t path = 0, segment = 0;  // the moving segment (path index in print order)
  long long strut = -1;               // design strut being printed (-1: not on the design)
  long long hit_strut = -1;           // design strut hit (-1: not on the design)
  std::size_t hit_path = 0, hit_segment = 0;
  Vec3 tip, point;  // nozzle tip and the hit material
};

struct CollisionCheck {
  std::size_t paths = 0, segments = 0;
  std::size_t struts = 0, printed_once = 0;
  std::size_t collisions = 0;      // all of them; `hits` lists the first max_listed
  std::vector<CollisionHit> hits;  // in print order of the moving segment, then of the one hit
  std::vector<std::pair<std::size_t, EdgeId>> top_down;  // (path, strut) steep struts printed down
  std::vector<EdgeId> missing, repeated;
  std::size_t off_design_segments = 0;
  std::size_t pairs_tested =
      0;                      // pairs within reach (padded footprints meet, material above the tip)
  std::size_t peak_held = 0;  // most segments held at once by the replay
  bool ok() const {
    return collisions == 0 && top_down.empty() && missing.empty() && repeated.empty() &&
           off_design_segments == 0;
  }
};

CollisionCheck check_collisions(const Graph& design, const Toolpath& toolpath,
                                const CheckOptions& options);
// The same over layers as they come (a G-code read from its file layer by layer): the source is
// visited twice, first for each layer's height and extent (the estimate and what may be dropped
// when), then to replay.
CollisionCheck check_collisions(const Graph& design, const LayerSource& layers,
                                const CheckOptions& options);

}  // namespace trellis
