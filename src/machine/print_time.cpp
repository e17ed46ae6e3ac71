#include "trellis/machine/print_time.hpp"

#include <algorithm>
#include <cmath>

namespace trellis {

namespace {

// Queued moves planned together; the oldest half is counted when the queue is full (a move's
// speeds hardly depend on moves a few hundred further on).
constexpr std::size_t kQueue = 512;

// Time of a trapezoid (or triangle) from `v0` to `v1` over `d` mm, cruising at most at `vn`.
double trapezoid(double d, double v0, double v1, double vn, double a) {
  if (a <= 0) return d / vn;
  const double da = (vn * vn - v0 * v0) / (2 * a), dd = (vn * vn - v1 * v1) / (2 * a);
  if (da + dd <= d) return (vn - v0) / a + (vn - v1) / a + (d - da - dd) / vn;
  const double vp = std::sqrt(std::max(0.0, (2 * a * d + v0 * v0 + v1 * v1) / 2));
  return std::max(0.0, vp - v0) / a + std::max(0.0, vp - v1) / a;
}

}  // namespace

void PrintTimeEstimator::add(double seconds, int tag) {
  total_ += seconds;
  if (tag < 0) return;
  if (by_tag_.size() <= static_cast<std::size_t>(tag))
    by_tag_.resize(static_cast<std::size_t>(tag) + 1);
  by_tag_[static_cast<std::size_t>(tag)] += seconds;
}

void PrintTimeEstimator::move(Vec3 a, Vec3 b, double de, double feed) {
  const std::array<double, 4> delta{b.x - a.x, b.y - a.y, b.z - a.z, de};
  const double xyz = std::sqrt(delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2]);
  const bool e_only = xyz < 1e-9;
  const double length = e_only ? std::abs(de) : xyz;
  if (length < 1e-9 || !(feed > 0)) return;
  double accel = e_only && limits_.retract_acceleration > 0 ? limits_.retract_acceleration
                 : !e_only && de <= 0 && limits_.travel_acceleration > 0
                     ? limits_.travel_acceleration
                     : limits_.acceleration;
  const bool capped = limits_.max_feed[0] > 0 || limits_.max_feed[1] > 0 ||
                      limits_.max_feed[2] > 0 || limits_.max_feed[3] > 0;
  if (accel <= 0 && !capped) {  // feeds only, none capped: the move at its feed
    add(length / feed, tag_);
    return;
  }
  std::array<double, 4> u{};
  for (int i = 0; i < 4; ++i) u[i] = delta[i] / length;
  double nominal = feed;
  for (int i = 0; i < 4; ++i)
    if (limits_.max_feed[i] > 0 && std::abs(u[i]) > 1e-12)
      nominal = std::min(nominal, limits_.max_feed[i] / std::abs(u[i]));
  if (accel <= 0) {  // feeds only
    add(length / nominal, tag_);
    return;
  }
  for (int i = 0; i < 4; ++i)
    if (limits_.max_acceleration[i] > 0 && std::abs(u[i]) > 1e-12)
      accel = std::min(accel, limits_.max_acceleration[i] / std::abs(u[i]));
  // Classic jerk (Marlin's planner): the speed a move may start at from rest, and the corner
  // speed from the per-axis change of velocity between the previous move and this one.
  std::array<double, 4> speed{};
  double safe = nominal;
  for (int i = 0; i < 4; ++i) {
    speed[i] = u[i] * nominal;
    const double j = limits_.jerk[i];
    if (j > 0 && std::abs(speed[i]) > j) safe = std::min(safe, j / std::abs(u[i]));
  }
  double junction = safe;
  if (!queue_.empty() && prev_nominal_ > 1e-9) {
    double factor = 1;
    double smaller = 1;
    if (nominal < prev_nominal_) {
      junction = nominal;
    } else {
      junction = prev_nominal_;
      smaller = junction / nominal;
    }
    bool limited = false;
    for (int i = 0; i < 4; ++i) {
      double v_exit = prev_speed_[i] * smaller, v_entry = speed[i];
      if (limited) v_exit *= factor, v_entry *= factor;
      const double jerk =
          v_exit > v_entry
              ? ((v_entry > 0 || v_exit < 0) ? v_exit - v_entry : std::max(v_exit, -v_entry))
              : ((v_entry < 0 || v_exit > 0) ? v_entry - v_exit : std::max(-v_exit, v_entry));
      if (limits_.jerk[i] > 0 && jerk > limits_.jerk[i]) {
        factor *= limits_.jerk[i] / jerk;
        limited = true;
      }
    }
    if (limited) junction *= factor;
    if (prev_safe_ > junction * 0.99 && safe > junction * 0.99) junction = safe;
  }
  prev_speed_ = speed;
  prev_nominal_ = nominal;
  prev_safe_ = safe;
  queue_.push_back({length, nominal, accel, std::min(junction, nominal), safe, 0, 0, tag_});
  if (queue_.size() >= 2 * kQueue) plan(kQueue);
}

void PrintTimeEstimator::plan(std::size_t keep) {
  const std::size_t n = queue_.size();
  if (n == 0) return;
  // Backward: every move can stop by the end of the queue (at its safe speed).
  std::vector<double> entry(n);
  double next_entry = queue_.back().safe;
  for (std::size_t k = n; k-- > 0;) {
    Block& b = queue_[k];
    const double exit = k + 1 < n ? next_entry : std::min(b.safe, b.nominal);
    entry[k] = std::min(b.max_entry, std::sqrt(exit * exit + 2 * b.accel * b.length));
    next_entry = entry[k];
  }
  // Forward: no move enters faster than the one before can reach.
  if (fixed_entry_) entry[0] = queue_[0].entry;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const Block& b = queue_[k];
    entry[k + 1] = std::min(entry[k + 1], std::sqrt(entry[k] * entry[k] + 2 * b.accel * b.length));
  }
  const std::size_t count = n > keep ? n - keep : 0;
  for (std::size_t k = 0; k < count; ++k) {
    const Block& b = queue_[k];
    const double exit = k + 1 < n ? entry[k + 1] : std::min(b.safe, b.nominal);
    add(trapezoid(b.length, entry[k], exit, b.nominal, b.accel), b.tag);
  }
  queue_.erase(queue_.begin(), queue_.begin() + static_cast<std::ptrdiff_t>(count));
  fixed_entry_ = !queue_.empty();
  if (fixed_entry_) queue_.front().entry = entry[count];
}

double PrintTimeEstimator::elapsed() const {
  double t = total_;
  for (const Block& b : queue_) t += b.length / b.nominal;
  return t;
}

void PrintTimeEstimator::flush() {
  plan(0);
  fixed_entry_ = false;
  prev_nominal_ = 0;  // the machine stops: the next move starts from rest
}

void PrintTimeEstimator::dwell(double seconds) {
  if (!(seconds > 0)) return;
  flush();
  add(seconds, tag_);
}

PrintTimeEstimator::Heater& PrintTimeEstimator::heater(int id) {
  for (auto& h : heaters_)
    if (h.id == id) return h;
  heaters_.push_back({id, kAmbient, kAmbient, 0});
  return heaters_.back();
}

void PrintTimeEstimator::set_target(int id, double celsius) {
  if (!std::isfinite(celsius)) return;
  // The time now: counted moves plus the queued ones at their feeds (close enough for a heater).
  const double t = elapsed();
  Heater& h = heater(id);
  const double rate = id == kBed ? kBedRate : kNozzleRate;
  const double at = h.target >= h.from ? std::min(h.target, h.from + rate * (t - h.since))
                                       : h.target;  // cooling: taken as done
  h = {id, at, std::max(celsius, kAmbient), t};
}

void PrintTimeEstimator::wait_for(int id, double celsius) {
  flush();
  if (std::isfinite(celsius) && std::max(celsius, kAmbient) != heater(id).target)
    set_target(id, celsius);
  Heater& h = heater(id);
  const double rate = id == kBed ? kBedRate : kNozzleRate;
  const double at = std::min(h.target, h.from + rate * std::max(0.0, total_ - h.since));
  const double wait = std::max(0.0, h.target - at) / rate;
  heating_ += wait;
  add(wait, tag_);
  h = {id, h.target, h.target, total_};
}

void PrintTimeEstimator::wait_all() {
  flush();
  double wait = 0;
  for (auto& h : heaters_) {
    const double rate = h.id == kBed ? kBedRate : kNozzleRate;
    const double at = std::min(h.target, h.from + rate * std::max(0.0, total_ - h.since));
    wait = std::max(wait, std::max(0.0, h.target - at) / rate);
  }
  const double t = total_ + wait;
  for (auto& h : heaters_) h = {h.id, h.target, h.target, t};
  heating_ += wait;
  add(wait, tag_);
}

}  // namespace trellis
