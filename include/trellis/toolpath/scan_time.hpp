// How long a galvanometer scanner takes over a layer of laser scan vectors (PBF-LB): every
// vector is marked at its type's speed, the mirrors jump between vectors at the jump speed, and
// the controller waits its delays (SCANLAB-style: a jump delay after each jump, a mark delay
// after each marked vector, a polygon delay at each corner inside a polyline). With skywriting the
// mirrors run in and out of each vector at speed instead, costing `skywriting_time` per vector
// in place of the mark delay. The laser on delay (before the laser fires at a vector's start)
// and off delay (the laser kept on after the mirrors reach its end) add to every vector when the
// controller waits them out (defaults 0: the mark delay covers them). The model counts scanning
// only (no recoating).
#pragma once
#include <cstddef>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/toolpath/laser_parameters.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// Adds up one layer's scan time, vector by vector in scan order.
class ScanClock {
 public:
  explicit ScanClock(const ScanTiming& timing) : t_(timing) {}
  // One vector (a polyline of n >= 2 points) marked at `speed` (mm/s), after a jump from the
  // end of the previous vector (none before the first).
  void mark(const Vec2* points, std::size_t n, double speed);
  void mark(Vec2 a, Vec2 b, double speed) {
    const Vec2 p[2] = {a, b};
    mark(p, 2, speed);
  }
  double seconds() const { return jump_s_ + mark_s_ + delay_s_; }
  double jump_seconds() const { return jump_s_; }
  double mark_seconds() const { return mark_s_; }
  double delay_seconds() const { return delay_s_; }
  std::size_t vectors() const { return vectors_; }
  std::size_t jumps() const { return jumps_; }      // jumps of non-zero length
  std::size_t corners() const { return corners_; }  // corners inside polylines

 private:
  ScanTiming t_;
  Vec2 at_{};
  bool started_ = false;
  double jump_s_ = 0, mark_s_ = 0, delay_s_ = 0;
  std::size_t vectors_ = 0, jumps_ = 0, corners_ = 0;
};

struct Layer;
// One toolpath layer's scan time: its paths in order, each a vector marked at its own speed (when
// set; else the hatch or contour speed by its role), the clock above.
ScanClock layer_scan_clock(const Layer& layer, const ScanTiming& timing);
// Each path's share of its layer's scan time, in order: the jump into it, its marking and its
// delays (they add up to layer_scan_clock's seconds).
std::vector<double> path_scan_seconds(const Layer& layer, const ScanTiming& timing);
// One laser's scan time (s) over `vectors` in the order given: each marked at its own speed
// (Path::speed; 0 = the timing's contour or hatch speed by role), jumps and delays between them.
// The one time function the multi-laser split balances and reports (slice/pbf_lasers.hpp).
double scan_time(const std::vector<const Path*>& vectors, const ScanTiming& laser);

}  // namespace trellis
