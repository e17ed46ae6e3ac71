// The pieces of a graded toolpath: short pieces merged into a neighbour where the gradient
// bound allows, the shortest printed piece of a layer, and whether a piece starts with an abrupt
// change of mixture.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include "fgm_order.hpp"
#include "trellis/slice/fgm.hpp"

namespace trellis {

void merge_short_pieces(std::vector<Path>& paths, std::vector<int>& colours, Evaluator& ev,
                        double z, const Palette& palette, double min, FgmStats& st) {
  if (!(min > 0) || paths.empty()) return;
  // α/2 (2α/3 for three materials), with a rounding allowance: a piece along a band's edge is
  // exactly α/2 from both colours.
  const double bound = palette.error_bound() + 1e-9;
  constexpr double touch = 1e-6;  // cut points of one line coincide
  auto near = [&](const Vec3& a, const Vec3& b) {
    return std::abs(a.x - b.x) <= touch && std::abs(a.y - b.y) <= touch;
  };
  auto samples = [&](const Path& p) { return fgm::design_along(ev, z, p); };
  const auto& error = fgm::mixture_error;
  // Pieces by their ends, on a grid of `touch` cells (a lookup checks the 3 x 3 cells around).
  auto key = [&](const Vec3& a) {
    return std::pair<long long, long long>{std::llround(a.x / touch), std::llround(a.y / touch)};
  };
  std::map<std::pair<long long, long long>, std::vector<std::size_t>> ends;
  auto add_ends = [&](std::size_t j) {
    if (paths[j].points.size() < 2) return;
    ends[key(paths[j].points.front())].push_back(j);
    ends[key(paths[j].points.back())].push_back(j);
  };
  for (std::size_t j = 0; j < paths.size(); ++j) add_ends(j);
  std::vector<char> dead(paths.size(), 0);
  for (std::size_t i = 0; i < paths.size(); ++i) {
    Path& p = paths[i];
    if (dead[i] || p.points.size() < 2 || !(p.length() < min)) continue;
    // Pieces of another colour and the same role touching an end of this one.
    std::vector<std::size_t> touching;
    for (const Vec3& end : {p.points.front(), p.points.back()}) {
      const auto k = key(end);
      for (long long dx = -1; dx <= 1; ++dx)
        for (long long dy = -1; dy <= 1; ++dy) {
          const auto it = ends.find({k.first + dx, k.second + dy});
          if (it == ends.end()) continue;
          for (std::size_t j : it->second) {
            const Path& q = paths[j];
            if (j == i || dead[j] || colours[j] == colours[i] || q.role != p.role ||
                q.points.size() < 2 ||
                std::find(touching.begin(), touching.end(), j) != touching.end())
              continue;
            if (near(end, q.points.front()) || near(end, q.points.back())) touching.push_back(j);
          }
        }
    }
    std::sort(touching.begin(), touching.end());
    if (touching.empty()) continue;
    const auto f = samples(p);
    std::size_t best = touching.front();
    double best_mean = std::numeric_limits<double>::infinity();
    for (std::size_t j : touching) {
      const double m = error(f, palette.mixture(colours[j]), false);
      if (m < best_mean) best_mean = m, best = j;
    }
    if (error(f, palette.mixture(colours[best]), true) > bound) {
      ++st.short_kept_bound;
      continue;
    }
    // Join: the neighbour's line runs on through this piece.
    Path& q = paths[best];
    std::vector<Vec3> pts = p.points;
    for (auto& v : pts) v.z = q.points.front().z;
    if (near(q.points.back(), pts.front())) {
      q.points.insert(q.points.end(), pts.begin() + 1, pts.end());
    } else if (near(q.points.back(), pts.back())) {
      q.points.insert(q.points.end(), pts.rbegin() + 1, pts.rend());
    } else if (near(q.points.front(), pts.back())) {
      q.points.insert(q.points.begin(), pts.begin(), pts.end() - 1);
    } else {
      q.points.insert(q.points.begin(), pts.rbegin(), pts.rend() - 1);
    }
    dead[i] = 1;
    add_ends(best);
    ++st.short_merged;
  }
  std::size_t n = 0;
  for (std::size_t i = 0; i < paths.size(); ++i) {
    if (dead[i]) continue;
    if (paths[i].length() < min) ++st.short_kept;
    if (n != i) {
      paths[n] = std::move(paths[i]);
      colours[n] = colours[i];
    }
    ++n;
  }
  paths.resize(n);
  colours.resize(n);
}

double shortest_piece(const Layer& layer) {
  double best = std::numeric_limits<double>::infinity(), run = 0;
  const Path* prev = nullptr;
  for (const Path& p : layer.paths) {
    const bool continues = prev && p.joined && p.mixture == prev->mixture;
    if (prev && !continues) best = std::min(best, run), run = 0;
    run += p.length();
    prev = &p;
  }
  if (prev) best = std::min(best, run);
  return best;
}

bool abrupt_start(const std::vector<double>& before, const Path& path, const Palette& palette) {
  if (path.joined || before.empty() || path.mixture.size() != before.size()) return false;
  double change = 0;
  for (std::size_t m = 0; m < before.size(); ++m)
    change = std::max(change, std::abs(path.mixture[m] - before[m]));
  return change > palette.band() + 1e-9;
}

}  // namespace trellis
