#include "trellis/machine/mixing_lag.hpp"

#include <algorithm>

namespace trellis {

namespace {

constexpr double kSnap = 0.05;  // mm: a change this close to a point falls on it

struct Event {
  double at;  // printed length (mm) from the start of the print
  std::vector<double> mixture;
};

// The deposited mixture at printed length `s`: the last event at or before it (within kSnap).
const std::vector<double>& deposited_at(const std::vector<Event>& events, double s) {
  static const std::vector<double> kNone;
  const auto it = std::upper_bound(events.begin(), events.end(), s + kSnap,
                                   [](double v, const Event& e) { return v < e.at; });
  return it == events.begin() ? kNone : std::prev(it)->mixture;
}

// `path` cut at the distances `cuts` along it (ascending, strictly inside): the pieces.
std::vector<Path> cut(const Path& path, const std::vector<double>& cuts) {
  std::vector<Path> pieces;
  Path cur = path;
  cur.points = {path.points.front()};
  double along = 0, total = path.length();
  std::size_t c = 0;
  auto finish = [&](bool last) {
    Path done = cur;
    if (!pieces.empty()) done.via.clear(), done.joined = true;
    if (total > 0) done.filament = path.filament * done.length() / total;
    pieces.push_back(std::move(done));
    if (!last) cur.points = {pieces.back().points.back()};
  };
  for (std::size_t i = 1; i < path.points.size(); ++i) {
    const Vec3 a = path.points[i - 1], b = path.points[i];
    const double len = distance(a, b);
    while (c < cuts.size() && cuts[c] < along + len - kSnap) {
      const double t = len > 0 ? (cuts[c] - along) / len : 0;
      if (cuts[c] - along > kSnap) cur.points.push_back(a + (b - a) * t);
      if (cur.points.size() >= 2) finish(false);
      ++c;
    }
    cur.points.push_back(b);
    along += len;
    // A cut within kSnap of this point (not the path's end) falls on it.
    if (c < cuts.size() && cuts[c] <= along + kSnap && i + 1 < path.points.size()) {
      finish(false);
      while (c < cuts.size() && cuts[c] <= along + kSnap) ++c;
    }
  }
  finish(true);
  return pieces;
}

}  // namespace

std::vector<std::vector<double>> deposit_mixtures(Toolpath& tp, double lookahead) {
  std::vector<std::vector<double>> commanded;
  // The commanded mixture as events along the printed length.
  std::vector<Event> events;
  double s = 0;
  const std::vector<double>* last = nullptr;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) {
      if (!last || p.mixture != *last) events.push_back({s, p.mixture});
      last = &p.mixture;
      s += p.length();
    }
  if (!(lookahead > 0)) {
    for (const auto& l : tp.layers)
      for (const auto& p : l.paths) commanded.push_back(p.mixture);
    return commanded;
  }
  // Deposited: every change after the first mixture reaches the nozzle `lookahead` later.
  bool primed = false;
  for (auto& e : events) {
    if (primed) e.at += lookahead;
    primed = primed || !e.mixture.empty();
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.at < b.at; });
  s = 0;
  for (auto& l : tp.layers) {
    std::vector<Path> out;
    out.reserve(l.paths.size());
    for (auto& p : l.paths) {
      const double len = p.length();
      std::vector<double> cuts;  // changes strictly inside the path
      for (auto e = std::upper_bound(events.begin(), events.end(), s + kSnap,
                                     [](double v, const Event&x) { return v < x.at; });
           e != events.end() && e->at < s + len - kSnap; ++e)
        cuts.push_back(e->at - s);
      std::vector<Path> pieces =
          cuts.empty() || p.points.size() < 2 ? std::vector<Path>{std::move(p)} : cut(p, cuts);
      double at = s;
      for (auto& q : pieces) {
        commanded.push_back(q.mixture);
        q.mixture = deposited_at(events, at);
        at += q.length();
        out.push_back(std::move(q));
      }
      s += len;
    }
    l.paths = std::move(out);
  }
  return commanded;
}

namespace {

bool same_bead(const Path& a, const Path& b) {
  return a.role == b.role && a.tool == b.tool && a.mixture == b.mixture && a.width == b.width &&
         a.height == b.height && a.temperature == b.temperature && a.power == b.power &&
         a.flow == b.flow && a.fan == b.fan && a.part == b.part;
}

}  // namespace

void merge_joined_pieces(Toolpath& tp) {
  for (auto& l : tp.layers) {
    std::vector<Path> out;
    out.reserve(l.paths.size());
    for (auto& p : l.paths) {
      if (!out.empty() && p.joined && p.points.size() >= 2 && out.back().points.size() >= 2 &&
          distance(out.back().points.back(), p.points.front()) <= 1e-9 &&
          same_bead(out.back(), p)) {
        Path& q = out.back();
        q.points.insert(q.points.end(), p.points.begin() + 1, p.points.end());
        q.filament += p.filament;
        continue;
      }
      out.push_back(std::move(p));
    }
    l.paths = std::move(out);
  }
}

}  // namespace trellis
