// Non-planar slicing: height fields, plane sections, serpentine layers, the paper's test surfaces
// and lattices laid on surfaces. Hand-written: no library slices a height field into continuous
// non-planar serpentines; the mesh parts are a grid index and exact plane/triangle cuts.
// slice_nonplanar runs the steps: the height field (nonplanar_height_field.cpp), each layer's
// lines (nonplanar_lines.cpp, curves on the surface in nonplanar_curves.cpp), their serpentines
// (nonplanar_join.cpp); the checks against the surface are in nonplanar_check.cpp.
#include "trellis/slice/nonplanar.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <map>
#include <mutex>

#include "nonplanar_internal.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

using namespace nonplanar_detail;

OffsetMode offset_mode_from_string(const std::string& name) {
  if (name == "vertical") return OffsetMode::Vertical;
  if (name == "normal") return OffsetMode::Normal;
  throw SettingError("unknown offset mode '" + name + "' (expected vertical or normal)");
}
const char* to_string(OffsetMode m) {
  return m == OffsetMode::Vertical ? "vertical" : "normal";
}

namespace {

void check_params(const NonplanarParams& prm) {
  if (!(prm.width > 0) || !(prm.layer_height >= 0) || prm.layers < 1 || prm.angles.empty() ||
      prm.layer_tools.empty() || !(prm.chord_tolerance > 0))
    throw SettingError(
        "non-planar slicing needs width > 0, layer height >= 0, layers >= 1, at least one angle "
        "and tool, and a chord tolerance > 0");
  for (int t : prm.layer_tools)
    if (t < 0) throw SettingError("tool numbers start at 0", {"", 0, "layer tools"});
}

// Every layer's lines, sectioned on worker threads.
std::vector<std::vector<Line>> layer_sections(const HeightField& surface,
                                              const NonplanarParams& prm, std::size_t layers,
                                              const Progress& progress) {
  // Vertical mode: one set of sections per direction a layer uses (1,000 angles over 6 layers
  // are 6 directions, as estimated), lifted per layer.
  std::map<double, std::vector<Line>> base;
  if (prm.offset == OffsetMode::Vertical)
    for (std::size_t k = 0; k < layers && k < prm.angles.size(); ++k) {
      progress.check("non-planar slicing");
      const double a = prm.angles[k];
      if (!base.count(a)) base[a] = layer_lines(surface, a, 0, prm);
    }
  std::vector<std::vector<Line>> per_layer(layers);
  // The sections (normal offsets: the slow part) from worker threads, as layers finish.
  const char* stage = prm.offset == OffsetMode::Vertical ? "sections" : "normal offsets";
  std::atomic<double> sectioned{0};  // layers' worth of lines done
  const double total = static_cast<double>(layers);
  progress(stage, 0.0);
  std::function<void(double)> advance;
  if (progress.report)
    advance = [&](double share) { progress(stage, (sectioned.fetch_add(share) + share) / total); };
  tbb::parallel_for(std::size_t{0}, layers, [&](std::size_t k) {
    progress.check("non-planar slicing");
    const double angle = prm.angles[k % prm.angles.size()];
    const double off = static_cast<double>(k) * prm.layer_height;
    if (prm.offset == OffsetMode::Vertical) {
      per_layer[k] = base.at(angle);
      for (auto& l : per_layer[k])
        for (auto& p : l.pieces)
          for (auto& q : p) q.z += off;
    } else {
      per_layer[k] = layer_lines(surface, angle, off, prm, advance);
      return;
    }
    if (advance) advance(1.0);
  });
  progress(stage, 1.0);
  return per_layer;
}

}  // namespace

NonplanarResult slice_nonplanar(const HeightField& surface, const NonplanarParams& prm,
                                const RunContext& context) {
  const Progress& progress = context.progress;
  check_params(prm);
  const double max_join = prm.max_join > 0 ? prm.max_join : 4 * prm.width;
  NonplanarResult res;
  res.toolpath.source = "trellis nonplanar (" + surface.name() + ")";
  res.toolpath.layers.resize(static_cast<std::size_t>(prm.layers));
  res.layers.resize(res.toolpath.layers.size());
  std::vector<std::vector<Line>> per_layer;
  context.run([&] { per_layer = layer_sections(surface, prm, res.layers.size(), progress); });
  // Join each layer's pieces by nearest neighbour, starting where the previous layer ended.
  Vec3 cursor{kNaN, kNaN, kNaN};
  HeightField::Eval f = surface.evaluator();
  for (std::size_t k = 0; k < res.layers.size(); ++k) {
    progress.check("non-planar slicing");
    progress("layers", static_cast<double>(k) / static_cast<double>(res.layers.size()));
    auto& rep = res.layers[k];
    rep.angle = prm.angles[k % prm.angles.size()];
    rep.tool = prm.layer_tools[k % prm.layer_tools.size()];
    rep.offset = static_cast<double>(k) * prm.layer_height;
    auto& layer = res.toolpath.layers[k];
    layer.z = rep.offset;
    join_layer(surface, prm, f, max_join, per_layer[k], cursor, rep, layer, res.max_descent_deg);
  }
  progress("layers", 1.0);
  return res;
}

Toolpath project_onto_surface(const Toolpath& planar, const HeightField& surface,
                              const ProjectParams& prm) {
  if (planar.layers.empty()) throw GeometryError("nothing to project: the toolpath has no layers");
  if (!(prm.chord_tolerance > 0)) throw SettingError("the chord tolerance must be > 0");
  const Vec3 dir = unit(prm.direction);
  if (!(norm(prm.direction) > 0) || dir.z >= -1e-9)
    throw SettingError("the projection direction must point down towards the surface (z < 0)");
  const bool vertical = std::hypot(dir.x, dir.y) < 1e-12;
  const BBox2 box = surface.domain();
  const double reach = std::hypot(box.width(), box.height());
  Toolpath out;
  out.source = planar.source + " on " + surface.name();
  out.layers.resize(planar.layers.size());
  const double z0 = planar.layers.front().z;
  std::mutex m;
  std::string error;
  tbb::enumerable_thread_specific<HeightField::Eval> evals([&] { return surface.evaluator(); });
  tbb::parallel_for(std::size_t{0}, planar.layers.size(), [&](std::size_t k) {
    auto& f = evals.local();
    const auto& in = planar.layers[k];
    const double off = prm.layer_height > 0 ? static_cast<double>(k) * prm.layer_height : in.z - z0;
    // Where the ray from the planar point along `dir` meets the surface; NaN if it does not.
    auto base = [&](Vec3 p) -> Vec2 {
      if (vertical) return p.xy();
      // g(s) = height of the ray above the surface; first sign change from above, refined.
      auto g = [&](double s) {
        const Vec3 q = p + dir * s;
        const double z = f(q.x, q.y);
        return std::isfinite(z) ? q.z - z : kNaN;
      };
      const double step = 0.05;
      double s0 = -reach, g0 = g(s0);
      for (double s = -reach + step; s <= reach; s += step) {
        const double gs = g(s);
        if (std::isfinite(g0) && std::isfinite(gs) && g0 >= 0 && gs <= 0) {
          double lo = s0, hi = s;
          for (int it = 0; it < 60; ++it) {
            const double mid = 0.5 * (lo + hi);
            (g(mid) >= 0 ? lo : hi) = mid;
          }
          return (p + dir * lo).xy();
        }
        s0 = s, g0 = gs;
      }
      return {kNaN, kNaN};
    };
    const SurfacePoint sp{f, prm.offset, off};
    auto& layer = out.layers[k];
    layer.z = off;
    for (std::size_t pi = 0; pi < in.paths.size(); ++pi) {
      const Path& src = in.paths[pi];
      Path dst = src;
      dst.points.clear();
      for (std::size_t i = 1; i < src.points.size(); ++i) {
        const Vec2 a = base(src.points[i - 1]), b = base(src.points[i]);
        std::vector<std::vector<Vec3>> pieces;
        if (std::isfinite(a.x) && std::isfinite(b.x))
          pieces = sample_curve(sp, a, b, prm.chord_tolerance * 0.5, 0.1);
        if (pieces.size() != 1 || distance_xy(pieces[0].front(), sp(a)) > 1e-6 ||
            distance_xy(pieces[0].back(), sp(b)) > 1e-6) {
          std::lock_guard lock(m);
          if (error.empty())
            error = "layer " + std::to_string(k + 1) + " path " + std::to_string(pi + 1) +
                    " leaves the footprint of surface '" + surface.name() + "' between " +
                    fmt_xy(src.points[i - 1].xy()) + " and " + fmt_xy(src.points[i].xy());
          return;
        }
        auto seg = simplify_polyline(pieces[0], prm.chord_tolerance * 0.5);
        dst.points.insert(dst.points.end(), seg.begin() + (dst.points.empty() ? 0 : 1), seg.end());
      }
      if (dst.points.size() >= 2) layer.paths.push_back(std::move(dst));
    }
  });
  if (!error.empty()) throw GeometryError(error);
  return out;
}

}  // namespace trellis
