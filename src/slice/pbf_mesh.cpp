#include "trellis/slice/pbf_mesh.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis {

namespace {

// Inward offsets are exact to this (mm): the arcs Clipper puts at concave corners stay within it
// of the true offset, well under the 1 µm the beam compensation is held to.
constexpr double kArcTolerance = 1e-4;

double length(const std::vector<Vec2>& line) {
  double s = 0;
  for (std::size_t i = 1; i < line.size(); ++i) s += std::sqrt(dist2(line[i - 1], line[i]));
  return s;
}

void check(const PbfSolidOptions& o) {
  if (!(o.layer > 0)) throw SettingError("layer thickness must be > 0", {"", 0, "scan.layer"});
  if (!(o.pattern.hatch_distance > 0))
    throw SettingError("hatch distance must be > 0", {"", 0, "scan.hatch_distance"});
  if (o.contours < 0) throw SettingError("contour count must be >= 0", {"", 0, "pbf.contours"});
  if (o.pattern.strategy == ScanStrategy::Island &&
      !(o.pattern.island_overlap < o.pattern.island_size))
    throw SettingError("the island overlap must be smaller than the island size",
                       {"", 0, "pbf.island_overlap"});
  if (o.pattern.strategy == ScanStrategy::Stripe &&
      !(o.pattern.stripe_overlap < o.pattern.stripe_width))
    throw SettingError("the stripe overlap must be smaller than the stripe width",
                       {"", 0, "pbf.stripe_overlap"});
}

}  // namespace

BBox3 PbfSolid::extent() const {
  if (mesh) return bounds(*mesh);
  if (field) return field->extent();
  return {};
}

PbfLayer plan_pbf_layer(const Regions& region, std::size_t index, const PbfSolidOptions& o) {
  PbfLayer L;
  L.hatch_angle = scan_angle(o.pattern, index);
  L.area = area(region);
  if (region.empty()) return L;
  const double step = o.contour_distance > 0 ? o.contour_distance : o.pattern.hatch_distance;
  for (int i = 0; i < o.contours; ++i) {
    const Regions ring = offset(region, -(o.beam_compensation + i * step), kArcTolerance);
    for (auto& r : rings_of(ring)) {
      if (r.size() < 2) continue;
      r.push_back(r.front());
      L.contour_length += length(r);
      L.contours.push_back(std::move(r));
    }
  }
  const double inset = o.beam_compensation + (o.contours > 0 ? o.contours * step : 0.0);
  L.hatches = scan_hatches(region, inset, o.pattern, index);
  for (const Segment2& s : L.hatches) L.hatch_length += std::sqrt(dist2(s.a, s.b));
  ScanClock clock(o.timing);
  for (const auto& c : L.contours) clock.mark(c.data(), c.size(), o.timing.contour_speed);
  for (const Segment2& s : L.hatches) clock.mark(s.a, s.b, o.timing.hatch_speed);
  L.scan_time = clock.seconds();
  return L;
}

PbfResult plan_pbf_solid(const PbfSolid& part, const PbfSolidOptions& o, const Progress& progress,
                         const PbfLayerSink& sink) {
  const auto t0 = std::chrono::steady_clock::now();
  check(o);
  if ((part.mesh != nullptr) == (part.field != nullptr))
    throw std::logic_error("plan_pbf_solid: give a mesh or a field");
  const BBox3 e = part.extent();
  if (e.empty() || !std::isfinite(e.min.z) || !std::isfinite(e.max.z) || !std::isfinite(e.min.x) ||
      !std::isfinite(e.max.x) || !std::isfinite(e.min.y) || !std::isfinite(e.max.y))
    throw GeometryError(
        "the part has no finite extent to scan (a .vcad solid needs a bounded "
        "shape or a root box)");
  PbfResult result;
  result.layer = o.layer;
  result.extent = e;
  const std::vector<double> zs = layer_planes(e.min.z, e.max.z, o.layer);
  FieldSliceOptions fo;
  fo.resolution = o.resolution;
  const std::size_t batch = std::max<std::size_t>(1, o.batch);
  for (std::size_t first = 0; first < zs.size(); first += batch) {
    progress.check("PBF planning");
    const std::size_t end = std::min(zs.size(), first + batch);
    const std::vector<double> span(zs.begin() + static_cast<long>(first),
                                   zs.begin() + static_cast<long>(end));
    const std::vector<LayerOutline> outlines =
        part.mesh ? slice_mesh_layers(*part.mesh, span) : slice_field(*part.field, span, fo);
    std::vector<PbfLayer> layers(span.size());
    tbb::parallel_for(std::size_t{0}, span.size(), [&](std::size_t k) {
      layers[k] = plan_pbf_layer(outlines[k].regions, first + k, o);
      layers[k].z = span[k];
    });
    for (std::size_t k = 0; k < layers.size(); ++k) {
      PbfLayer& L = layers[k];
      result.contour_vectors += L.contours.size();
      result.hatch_vectors += L.hatches.size();
      result.contour_length += L.contour_length;
      result.hatch_length += L.hatch_length;
      result.scan_time += L.scan_time;
      if (sink) {
        sink(first + k, L);
        // Freed, not just emptied (`= {}` would keep the capacity): the series stays small.
        std::vector<std::vector<Vec2>>().swap(L.contours);
        std::vector<Segment2>().swap(L.hatches);
      }
      result.layers.push_back(std::move(L));
    }
    progress("layers", static_cast<double>(end) / static_cast<double>(zs.size()));
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace trellis
