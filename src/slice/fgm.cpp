#include "trellis/slice/fgm.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "fgm_internal.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

const char* to_string(FgmOrder order) {
  return order == FgmOrder::Paths ? "paths" : "faces";
}

namespace {

// A Strategy 2 layer's paths paired with their colours.
struct Planned {
  Layer layer;
  std::vector<int> colors;
  std::size_t faces = 0;
  FgmStats shorts;  // short_* only
};

// Strategy 2's layers in order into the toolpath, with the run's counts.
Toolpath strategy2_toolpath(std::vector<Planned>& planned, const FgmOptions& o, bool outline_route,
                            FgmStats& st) {
  Toolpath tp;
  st.shortest_path = std::numeric_limits<double>::infinity();
  int last_color = -1;
  std::vector<double> last_mixture;
  st.min_segment = o.min_segment;
  for (auto& pl : planned) {
    st.faces += pl.faces;
    st.short_merged += pl.shorts.short_merged;
    st.short_kept += pl.shorts.short_kept;
    st.short_kept_bound += pl.shorts.short_kept_bound;
    // Face by face every path is a bead; in path order pieces of a bead are counted apart.
    st.short_beads += outline_route ? pl.shorts.short_beads : pl.shorts.short_kept;
    for (std::size_t i = 0; i < pl.layer.paths.size(); ++i) {
      const Path& path = pl.layer.paths[i];
      if (pl.colors[i] != last_color && last_color >= 0) ++st.colour_changes;
      last_color = pl.colors[i];
      st.abrupt_changes += abrupt_start(last_mixture, path, o.palette);
      last_mixture = path.mixture;
      st.joined += path.joined;
      ++st.paths;
    }
    st.shortest_path = std::min(st.shortest_path, shortest_piece(pl.layer));
    if (!pl.layer.paths.empty()) tp.layers.push_back(std::move(pl.layer));
  }
  if (st.paths == 0) st.shortest_path = 0;
  return tp;
}

// Strategy 1's layers of pieces in order into the toolpath, with the run's counts.
Toolpath strategy1_toolpath(std::vector<std::vector<fgm::Piece>>& per,
                            const std::vector<std::size_t>& faces_per,
                            const std::vector<FgmStats>& shorts_per, const Toolpath& planar,
                            const FgmOptions& o, FgmStats& st) {
  Toolpath tp;
  st.shortest_path = std::numeric_limits<double>::infinity();
  int last = -1;
  std::vector<double> last_mixture;
  st.min_segment = o.min_segment;
  for (std::size_t li = 0; li < per.size(); ++li) {
    st.faces += faces_per[li];
    st.short_merged += shorts_per[li].short_merged;
    st.short_kept += shorts_per[li].short_kept;
    st.short_kept_bound += shorts_per[li].short_kept_bound;
    st.short_beads += shorts_per[li].short_beads;
    Layer layer;
    layer.z = planar.layers[li].z;
    for (auto& piece : per[li]) {
      if (last >= 0 && piece.color != last) ++st.colour_changes;
      st.abrupt_changes += abrupt_start(last_mixture, piece.path, o.palette);
      last = piece.color;
      last_mixture = piece.path.mixture;
      st.shortest_path = std::min(st.shortest_path, piece.path.length());
      ++st.paths;
      st.joined += piece.path.joined;
      layer.paths.push_back(std::move(piece.path));
    }
    if (!layer.paths.empty()) tp.layers.push_back(std::move(layer));
  }
  return tp;
}

}  // namespace

Toolpath plan_fgm_strategy2(const Field& field, const std::vector<LayerOutline>& layers,
                            const FgmOptions& o, FgmStats* stats) {
  if (!(o.bead_width > 0) || !(o.resolution > 0))
    throw SettingError("bead width and resolution must be positive");
  fgm::require_materials(field, o.palette);
  // Layers are independent: planned in parallel (oneTBB), one evaluator per thread, each
  // layer's paths paired with their colours.
  std::vector<Planned> planned(layers.size());
  // Path order on a machine that changes the mixture along a bead: each island filled whole
  // and cut at the colour zones (outline_layer); the paper's face-by-face fill otherwise.
  const bool outline_route = o.order == FgmOrder::Paths && !o.tool_changer && !o.concentric;
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::parallel_for(std::size_t{0}, layers.size(), [&](std::size_t li) {
    Evaluator& ev = evaluators.local();
    const LayerOutline& lo = layers[li];
    Planned& out = planned[li];
    const std::size_t g = o.first_layer + li;  // the part's layer (a shard plans a range)
    // As the planar slicer: the nozzle at the top of layer i, counted from the bed.
    out.layer.z = static_cast<double>(g + 1) * o.layer_height;
    if (outline_route)
      fgm::outline_layer(ev, lo, g, o, out.layer, out.colors, out.faces, out.shorts);
    else
      fgm::face_layer(field, ev, lo, g, o, out.layer, out.colors, out.faces, out.shorts);
  });
  FgmStats st;
  Toolpath tp = strategy2_toolpath(planned, o, outline_route, st);
  if (stats) *stats = st;
  return tp;
}

Toolpath plan_fgm_strategy1(const Field& field, const std::vector<LayerOutline>& layers,
                            const Toolpath& planar, const FgmOptions& o, const PurgeOptions& purge,
                            FgmStats* stats) {
  if (!(o.bead_width > 0) || !(o.layer_height > 0))
    throw SettingError("bead width and layer height must be positive");
  if (!(o.zipper >= 0) || o.zipper >= o.palette.band())
    throw SettingError("the zipper overlap must be in [0, one colour band) of the gradient");
  fgm::require_materials(field, o.palette);
  if (o.zipper > 0 && o.palette.materials != 2)
    throw SettingError("zippering interlocks two neighbouring colours of a two-material palette");
  using fgm::Piece;
  std::vector<std::vector<Piece>> per(planar.layers.size());
  std::vector<std::size_t> faces_per(planar.layers.size(), 0);
  std::vector<FgmStats> shorts_per(planar.layers.size());  // short_* only
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::parallel_for(std::size_t{0}, planar.layers.size(), [&](std::size_t li) {
    Evaluator& ev = evaluators.local();
    const Layer& pl = planar.layers[li];
    // The outline this layer was planned from: nozzle z = (g + 1) h for the part's layer g
    // (a shard's outlines start at first_layer).
    const auto g = static_cast<std::size_t>(std::llround(pl.z / o.layer_height)) - 1;
    if (g < o.first_layer) return;
    const std::size_t idx = g - o.first_layer;
    if (idx >= layers.size()) return;
    // Zones: a colour's band, or with zippering the overlap band around each colour boundary
    // (|f - k/N| < β/2), where pieces alternate between the two neighbouring colours.
    const double res = std::max(o.material_resolution, o.bead_width / 2);
    const double beta = o.zipper;
    const double z = layers[idx].z;
    // The planar paths lie inside the outline: the zones need not be cut by it (the outline's
    // many vertices would make every clip slower), only cover the paths' box.
    BBox3 box;
    for (const auto& p : pl.paths)
      for (const auto& q : p.points) box.add({q.x, q.y, 0});
    if (box.empty()) return;
    // Two cells of margin: chords ending on the zones' border are not refined onto the iso-lines.
    const Vec2 zlo{box.min.x - 2 * res, box.min.y - 2 * res};
    const Vec2 zhi{box.max.x + 2 * res, box.max.y + 2 * res};
    fgm::PathZones pz = fgm::path_zones(ev, z, zlo, zhi, o, beta);
    if (o.order == FgmOrder::Paths) {
      per[li] = fgm::path_order_layer(pl, pz.below, pz.levels, pz.zones, ev, z, g, o, zlo, zhi,
                                      shorts_per[li]);
      for (const auto& zone : pz.zones) faces_per[li] += zone.count > 0;
      return;
    }
    per[li] = fgm::band_layer(pl, pz, ev, z, g, o, faces_per[li], shorts_per[li]);
  });
  FgmStats st;
  Toolpath tp = strategy1_toolpath(per, faces_per, shorts_per, planar, o, st);
  if (o.order == FgmOrder::Faces || o.tool_changer) add_prime_tower(tp, o, purge, st);
  if (st.paths == 0) st.shortest_path = 0;
  if (stats) *stats = st;
  return tp;
}

}  // namespace trellis
