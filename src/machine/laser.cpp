#include "trellis/machine/laser.hpp"

namespace trellis {

ScanTiming scan_timing(const LaserProfile& p) {
  ScanTiming t;
  t.contour_speed = p.contour_speed;
  t.hatch_speed = p.hatch_speed;
  t.jump_speed = p.jump_speed;
  t.jump_delay = p.jump_delay;
  t.mark_delay = p.mark_delay;
  t.polygon_delay = p.polygon_delay;
  t.skywriting = p.skywriting;
  t.skywriting_time = p.skywriting_time;
  t.laser_on_delay = p.laser_on_delay;
  t.laser_off_delay = p.laser_off_delay;
  return t;
}

}  // namespace trellis
