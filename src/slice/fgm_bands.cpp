// Strategy 1 face by face (FgmOrder::Faces): a layer's planar paths split among the colour
// zones (bisecting on the bands, one clip inside and one outside a level), each piece coloured
// by its zone (alternating in the zipper's overlap bands), short pieces merged, then colour by
// colour in palette order.
#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>

#include "fgm_internal.hpp"

namespace trellis::fgm {

namespace {

// Splits polylines among the bands [a, b) of nested sets below[k] = {f <= level k}: band k lies
// between below[k-1] and below[k]. Bisects on the bands (one inside and one outside clip per
// level of the recursion), so every line is clipped about 2·log2(bands) times, not once per band.
void split_bands(std::vector<std::vector<Vec2>> lines, const std::vector<Regions>& below, int a,
                 int b, const std::function<void(int, std::vector<std::vector<Vec2>>&)>& emit) {
  if (lines.empty()) return;
  if (b - a <= 1) {
    emit(a, lines);
    return;
  }
  const int mid = (a + b) / 2;
  const Regions& cut = below[static_cast<std::size_t>(mid - 1)];
  split_bands(clip_polylines(lines, cut, true), below, a, mid, emit);
  split_bands(clip_polylines(lines, cut, false), below, mid, b, emit);
}

// The layer's paths split among the zones, each piece with its zone's colour.
std::vector<Piece> split_among_zones(const Layer& pl, PathZones& pz, const FgmOptions& o) {
  const int d = o.palette.divisions();
  std::vector<Zone>& zones = pz.zones;
  const std::vector<Regions>(&below)[3] = pz.below;
  const int bands = static_cast<int>(pz.levels.size()) + 1;
  std::vector<Piece> per;
  // Paths of one role share their attributes: each role's paths are cut together (piece
  // order within a role follows Clipper's, not the planar order).
  std::vector<std::pair<PathRole, std::vector<std::size_t>>> roles;
  for (std::size_t k = 0; k < pl.paths.size(); ++k) {
    auto it = std::find_if(roles.begin(), roles.end(),
                           [&](const auto& r) { return r.first == pl.paths[k].role; });
    if (it == roles.end()) {
      roles.push_back({pl.paths[k].role, {}});
      it = roles.end() - 1;
    }
    it->second.push_back(k);
  }
  for (const auto& [role, ids] : roles) {
    std::vector<std::vector<Vec2>> lines;
    for (std::size_t k : ids) {
      std::vector<Vec2> line;
      for (const auto& q : pl.paths[k].points) line.push_back(q.xy());
      lines.push_back(std::move(line));
    }
    const Path& proto = pl.paths[ids.front()];  // role, width, height, speed
    auto emit = [&](int zone_index, std::vector<std::vector<Vec2>>& pieces) {
      Zone& zone = zones[static_cast<std::size_t>(zone_index)];
      for (auto& piece : pieces) {
        if (piece.size() < 2) continue;
        Path p;
        p.role = proto.role;
        p.width = proto.width;
        p.height = proto.height;
        p.speed = proto.speed;
        p.tool = proto.tool;
        for (const Vec2 q : piece) p.points.push_back({q.x, q.y, pl.z});
        if (p.length() <= 1e-9) continue;
        const int color = zone.count++ % 2 ? zone.b : zone.a;
        p.mixture = o.palette.mixture(color);
        per.push_back({std::move(p), color});
      }
    };
    if (o.palette.materials != 3) {
      split_bands(std::move(lines), below[0], 0, bands, emit);
      continue;
    }
    // Triangle (i, j): up if i + j = d - 1, else down where the third fraction is below
    // (d - 1 - i - j)/d.
    split_bands(std::move(lines), below[0], 0, d, [&](int i, std::vector<std::vector<Vec2>>& li_) {
      split_bands(std::move(li_), below[1], 0, d, [&](int j, std::vector<std::vector<Vec2>>& lj) {
        j = std::min(j, d - 1 - i);
        if (i + j >= d - 1) {
          emit(o.palette.color_of_cell(i, j, true), lj);
          return;
        }
        const Regions& cut = below[2][static_cast<std::size_t>(d - 2 - i - j)];
        auto down = clip_polylines(lj, cut, true), up = clip_polylines(lj, cut, false);
        emit(o.palette.color_of_cell(i, j, false), down);
        emit(o.palette.color_of_cell(i, j, true), up);
      });
    });
  }
  return per;
}

// Short pieces merged into a neighbour where the gradient bound allows.
void merge_short(std::vector<Piece>& per, Evaluator& ev, double z, const FgmOptions& o,
                 FgmStats& shorts) {
  std::vector<Path> paths;
  std::vector<int> colours;
  for (auto& piece : per) {
    paths.push_back(std::move(piece.path));
    colours.push_back(piece.color);
  }
  merge_short_pieces(paths, colours, ev, z, o.palette, o.min_segment, shorts);
  per.clear();
  for (std::size_t k = 0; k < paths.size(); ++k) per.push_back({std::move(paths[k]), colours[k]});
}

// Pieces of one colour and role printed one after the other where one ends and the next begins
// (a line cut only by a merged piece) joined into one; the short ones counted.
void join_printed(std::vector<Piece>& per, const FgmOptions& o, FgmStats& shorts) {
  std::vector<Piece> joined;
  for (auto& piece : per) {
    if (!joined.empty()) {
      Path& last = joined.back().path;
      const Vec3 a = last.points.back(), b = piece.path.points.front();
      if (joined.back().color == piece.color && last.role == piece.path.role &&
          last.width == piece.path.width && last.speed == piece.path.speed &&
          std::abs(a.x - b.x) <= 1e-6 && std::abs(a.y - b.y) <= 1e-6) {
        last.points.insert(last.points.end(), piece.path.points.begin() + 1,
                           piece.path.points.end());
        continue;
      }
    }
    joined.push_back(std::move(piece));
  }
  per = std::move(joined);
  shorts.short_kept = 0;
  for (const auto& piece : per) shorts.short_kept += piece.path.length() < o.min_segment;
  shorts.short_beads = shorts.short_kept;  // face order: every piece a bead
}

}  // namespace

std::vector<Piece> band_layer(const Layer& planar, PathZones& pz, Evaluator& ev, double z,
                              std::size_t g, const FgmOptions& o, std::size_t& faces,
                              FgmStats& shorts) {
  std::vector<Piece> per = split_among_zones(planar, pz, o);
  // Faces: zones that some path crosses.
  for (const auto& zone : pz.zones) faces += zone.count > 0;
  if (o.min_segment > 0) merge_short(per, ev, z, o, shorts);
  // Colour by colour in palette order (reversed every other layer), the planar order within.
  std::stable_sort(per.begin(), per.end(), [&](const Piece& a, const Piece& b) {
    return g % 2 ? a.color > b.color : a.color < b.color;
  });
  if (o.min_segment > 0) join_printed(per, o, shorts);
  return per;
}

}  // namespace trellis::fgm
