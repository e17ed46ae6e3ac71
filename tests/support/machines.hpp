// Machines for writer tests: design coordinates written as they are (no centring, X0 Y0 at the
// bed centre) on a bed large enough for any test part, with the tools and mixing inputs a test
// asks of the writer. The machine check (machine/machine_check.hpp) still runs on every write.
#pragma once
#include "trellis/machine/profile.hpp"

namespace trellis::test {

inline MachineProfile open_bed(MachineProfile p = {}, int tools = 0, int mixing_inputs = 0) {
  p.center = false;
  p.origin = BedOrigin::Center;
  p.bed_shape = BedShape::Rectangle;
  p.bed_x = p.bed_y = p.bed_z = 2000;
  if (tools > 0) p.tool_count = tools;
  if (mixing_inputs > 0) p.mixing_inputs = mixing_inputs;
  return p;
}

}  // namespace trellis::test
