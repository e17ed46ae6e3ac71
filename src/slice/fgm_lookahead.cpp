// The look-ahead of a mixing hotend: the mixture a print starts with is the one the nozzle
// holds once the look-ahead length has been extruded, so the first paths take it.
#include "trellis/slice/fgm.hpp"

namespace trellis {

bool deposit_start_mixtures(Toolpath& tp, double lookahead) {
  if (!(lookahead > 0)) return false;
  // The mixture of the last graded path starting within the first `lookahead` mm (as the writer
  // counts printed length: paths of two points or more).
  const std::vector<double>* last = nullptr;
  double s = 0;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) {
      if (p.points.size() < 2) continue;
      if (s > lookahead) break;
      if (!p.mixture.empty()) last = &p.mixture;
      s += p.length();
    }
  if (!last) return false;
  const std::vector<double> held = *last;
  bool changed = false;
  s = 0;
  for (auto& l : tp.layers)
    for (auto& p : l.paths) {
      if (p.points.size() < 2) continue;
      if (s > lookahead) return changed;
      if (!p.mixture.empty() && p.mixture != held) p.mixture = held, changed = true;
      s += p.length();
    }
  return changed;
}

}  // namespace trellis
