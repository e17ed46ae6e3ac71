// Print-time estimate of G-code as a firmware runs it, the one estimate behind the writer's
// "; estimated printing time", `trellis analyze` and `trellis view`. Moves are planned as Marlin
// and PrusaSlicer's estimator plan them: trapezoidal speed profiles at the move's acceleration
// (printing, travel or retraction, capped per axis), corners taken at the speed classic jerk
// allows (per-axis speed change), look-ahead over the queued moves (forward and backward passes),
// feeds capped per axis; the queue drains (the machine stops) before a dwell or a heater wait.
// Acceleration 0 means feeds only: every move at its feed, no speed changes.
//
// Dwells (G4) count as written. Heater waits (M109, M190, M116, Klipper TEMPERATURE_WAIT) count
// the time a heater needs to reach its target from where it is: heaters start at kAmbient and
// heat at kNozzleRate (nozzles) or kBedRate (the bed) from the moment their target is set (M104
// early, M109 later waits only for what is left); a wait for a lower temperature counts 0 (the
// cooling rate is not modelled). These rates are documented constants, not machine settings: a
// typical 40 W hotend and a 24 V heated bed. Heating is reported apart (heating_s) because other
// slicers' estimates (PrusaSlicer's among them) leave it out.
#pragma once
#include <array>
#include <cstddef>
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis {

// What a move may do, per axis X, Y, Z, E; 0 = unlimited (or, for the accelerations, not set).
struct MotionLimits {
  double acceleration = 0;                   // printing moves, mm/s² (M204 P or S); 0 = feeds only
  double travel_acceleration = 0;            // travel moves (M204 T); 0 = acceleration
  double retract_acceleration = 0;           // E-only moves (M204 R); 0 = acceleration
  std::array<double, 4> max_acceleration{};  // per axis, mm/s² (M201)
  std::array<double, 4> max_feed{};          // per axis, mm/s (M203)
  std::array<double, 4> jerk{10, 10, 0.4, 5};  // classic jerk per axis, mm/s (M205 X Y Z E)
};

class PrintTimeEstimator {
 public:
  static constexpr double kAmbient = 25;    // °C, every heater at the start
  static constexpr double kNozzleRate = 2;  // °C/s a nozzle heats
  static constexpr double kBedRate = 0.5;   // °C/s the bed heats
  static constexpr int kBed = -1;           // heater number of the bed (nozzles: their tool)

  explicit PrintTimeEstimator(const MotionLimits& limits = {}) : limits_(limits) {}
  void set_limits(const MotionLimits& limits) { limits_ = limits; }
  const MotionLimits& limits() const { return limits_; }
  // Time that follows goes to `tag` (e.g. a part of a build plate; -1 = none).
  void set_tag(int tag) { tag_ = tag; }
  // One straight move from `a` to `b` with `de` mm of filament at `feed` mm/s (E-only moves too).
  void move(Vec3 a, Vec3 b, double de, double feed);
  void dwell(double seconds);
  // A heater's new target (heater: tool number, or kBed); a wait until it is reached (heating).
  void set_target(int heater, double celsius);
  void wait_for(int heater, double celsius);
  void wait_all();  // every heater set so far (they heat at once: the longest wait)
  // Every queued move planned and counted; then the totals.
  void flush();
  double seconds() {
    flush();
    return total_;
  }
  // The time so far without planning the queue: its moves at their feeds (progress marks).
  double elapsed() const;
  double heating_s() const { return heating_; }
  // Time counted under each tag (index = tag), after flush().
  const std::vector<double>& tag_seconds() const { return by_tag_; }

 private:
  struct Block {
    double length, nominal, accel, max_entry, safe, entry = 0, exit = 0;
    int tag;
  };
  struct Heater {
    int id;
    double from, target, since;  // temperature when the target was set, and the time then
  };
  void add(double seconds, int tag);
  void plan(std::size_t keep);  // plans the queue and counts all but the last `keep` blocks
  double now() const { return total_; }
  Heater& heater(int id);

  MotionLimits limits_;
  std::vector<Block> queue_;
  bool fixed_entry_ = false;  // queue_.front().entry is already set by counted blocks
  std::array<double, 4>
      prev_speed_{};  // per-axis velocity of the last queued move at its nominal feed
  double prev_nominal_ = 0, prev_safe_ = 0;
  double total_ = 0, heating_ = 0;
  int tag_ = -1;
  std::vector<double> by_tag_;
  std::vector<Heater> heaters_;
};

}  // namespace trellis
