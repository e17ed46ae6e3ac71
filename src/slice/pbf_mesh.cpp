#include "trellis/slice/pbf_mesh.hpp"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

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
  if (!o.exposures.contours.empty() &&
      o.exposures.contours.size() != static_cast<std::size_t>(o.contours))
    throw SettingError(fmt::format("{} contour parameter sets for {} contours: give one power and "
                                   "one speed per contour, outermost first",
                                   o.exposures.contours.size(), o.contours),
                       {"", 0, "laser.contour_powers"});
  for (double t : {o.skin.skin_thickness, o.skin.upskin_thickness, o.skin.downskin_thickness})
    if (!(t >= 0))
      throw SettingError("skin thicknesses must be >= 0", {"", 0, "pbf.skin_thickness"});
  for (std::size_t k = 0; k < kHatchKinds; ++k)
    if (!(o.kind_hatch[k].distance >= 0))
      throw SettingError(
          "hatch distances must be >= 0",
          {"", 0,
           fmt::format("pbf.{}_hatch_distance", hatch_kind_name(static_cast<HatchKind>(k)))});
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

ScanPattern PbfSolidOptions::pattern_of(HatchKind kind) const {
  const KindHatch& h = kind_hatch[static_cast<std::size_t>(kind)];
  ScanPattern p = pattern;
  if (h.distance > 0) p.hatch_distance = h.distance;
  if (std::isfinite(h.rotation)) p.rotation = h.rotation;
  return p;
}

bool PbfSolidOptions::own_lines(HatchKind kind) const {
  const ScanPattern p = pattern_of(kind);
  return p.hatch_distance != pattern.hatch_distance || p.rotation != pattern.rotation;
}

Vec2 hatch_phase_point(const PbfSolidOptions& o, const ScanPattern& p, std::size_t index) {
  switch (o.hatch_phase) {
    case HatchPhase::Origin:
      return o.machine_origin;
    case HatchPhase::Random: {
      // Moved across both the layer's lines and the islands' turned ones (one draw: the same
      // fraction of the hatch distance).
      const double a = scan_angle(p, index);
      return random_hatch_shift(a, o.hatch_seed, index, p.hatch_distance) +
             random_hatch_shift(a + 90, o.hatch_seed, index, p.hatch_distance);
    }
    case HatchPhase::Wall:
      break;
  }
  return {0, 0};
}

PbfLayer plan_pbf_layer(const Regions& region, std::size_t index, const PbfSolidOptions& o) {
  return plan_pbf_layer(region, nullptr, index, o);
}

PbfLayer plan_pbf_layer(const Regions& region, const LayerKinds* kinds, std::size_t index,
                        const PbfSolidOptions& o) {
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
      L.contour_offset.push_back(static_cast<std::uint8_t>(i));
    }
  }
  const double inset = o.beam_compensation + (o.contours > 0 ? o.contours * step : 0.0);
  const Vec2 origin = hatch_phase_point(o, o.pattern, index);
  const auto skin = static_cast<std::size_t>(HatchKind::Skin);
  if (!kinds) {
    L.hatches = scan_hatches(region, inset, o.pattern, index, origin);
    L.hatch_kind.assign(L.hatches.size(), static_cast<std::uint8_t>(HatchKind::Skin));
    L.kind_area[skin] = L.area;
  } else {
    std::vector<Segment2> whole;  // the pattern's hatch of the whole region, made once
    bool made = false;
    for (std::size_t k = 0; k < kHatchKinds; ++k) {
      const Regions& part = (*kinds)[k];
      L.kind_area[k] = area(part);
      if (part.empty()) continue;
      const bool own_lines = o.own_lines(static_cast<HatchKind>(k));
      const ScanPattern p = own_lines ? o.pattern_of(static_cast<HatchKind>(k)) : o.pattern;
      const Vec2 at = own_lines ? hatch_phase_point(o, p, index) : origin;
      std::vector<Segment2> own;
      if (own_lines) {
        own = scan_hatches(region, inset, p, index, at);
      } else if (!made) {
        whole = scan_hatches(region, inset, p, index, at);
        made = true;
      }
      for (const Segment2& s : clip_hatches(own_lines ? own : whole, part, scan_angle(p, index),
                                            p.hatch_distance, at)) {
        L.hatches.push_back(s);
        L.hatch_kind.push_back(static_cast<std::uint8_t>(k));
      }
    }
  }
  for (std::size_t j = 0; j < L.hatches.size(); ++j) {
    const double l = std::sqrt(dist2(L.hatches[j].a, L.hatches[j].b));
    L.hatch_length += l;
    L.kind_hatch_length[L.hatch_kind[j]] += l;
  }
  const auto speed = [](double set, double fallback) { return set > 0 ? set : fallback; };
  ScanClock clock(o.timing);
  for (std::size_t j = 0; j < L.contours.size(); ++j)
    clock.mark(L.contours[j].data(), L.contours[j].size(),
               speed(o.exposures.of_contour(L.contour_offset[j]).speed, o.timing.contour_speed));
  for (std::size_t j = 0; j < L.hatches.size(); ++j)
    clock.mark(
        L.hatches[j].a, L.hatches[j].b,
        speed(o.exposures.of(static_cast<HatchKind>(L.hatch_kind[j])).speed, o.timing.hatch_speed));
  L.scan_time = clock.seconds();
  return L;
}

Layer pbf_solid_layer_toolpath(const PbfLayer& L, std::size_t index, double thickness,
                               const PbfExposures& e) {
  Layer layer = pbf_layer_toolpath(L, index, thickness, e.contour.power, e.contour.speed,
                                   e.hatch.power, e.hatch.speed);
  const auto set = [](Path& p, LaserSet s) {
    if (s.power > 0) p.power = s.power;
    if (s.speed > 0) p.speed = s.speed;
  };
  for (std::size_t j = 0; j < L.contour_offset.size(); ++j)
    set(layer.paths[j], e.of_contour(L.contour_offset[j]));
  for (std::size_t j = 0; j < L.hatch_kind.size(); ++j)
    set(layer.paths[L.contours.size() + j], e.of(static_cast<HatchKind>(L.hatch_kind[j])));
  return layer;
}

namespace {

PbfResult plan_pbf_solid_on(const PbfSolid& part, const PbfSolidOptions& o,
                            const PbfLayerSink& sink, const Progress& progress) {
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
  // With region kinds a layer needs its neighbours': each layer is sliced once and held while
  // a batch within the window's reach needs it.
  const bool split = o.skin.any();
  SkinWindow window(o.skin, o.layer, zs.size());
  const std::size_t reach = split ? window.reach() : 0;
  std::map<std::size_t, Regions> held;
  for (std::size_t first = 0; first < zs.size(); first += batch) {
    progress.check("PBF planning");
    const std::size_t end = std::min(zs.size(), first + batch);
    const std::size_t lo = first > reach ? first - reach : 0;
    const std::size_t hi = std::min(zs.size(), end + reach);
    std::erase_if(held, [&](const auto& e) { return e.first < lo; });
    const std::size_t from = held.empty() ? lo : std::max(lo, held.rbegin()->first + 1);
    if (from < hi) {
      const std::vector<double> span(zs.begin() + static_cast<long>(from),
                                     zs.begin() + static_cast<long>(hi));
      std::vector<LayerOutline> outlines =
          part.mesh ? slice_mesh_layers(*part.mesh, span) : slice_field(*part.field, span, fo);
      for (std::size_t k = 0; k < outlines.size(); ++k)
        held[from + k] = std::move(outlines[k].regions);
    }
    if (split)
      window.prepare(first, end, [&](std::size_t j) -> const Regions& { return held.at(j); });
    std::vector<PbfLayer> layers(end - first);
    tbb::parallel_for(std::size_t{0}, layers.size(), [&](std::size_t k) {
      const Regions& region = held.at(first + k);
      if (split) {
        const LayerKinds kinds = window.split(first + k, region);
        layers[k] = plan_pbf_layer(region, &kinds, first + k, o);
      } else {
        layers[k] = plan_pbf_layer(region, nullptr, first + k, o);
      }
      layers[k].z = zs[first + k];
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
        std::vector<std::uint8_t>().swap(L.contour_offset);
        std::vector<std::uint8_t>().swap(L.hatch_kind);
      }
      result.layers.push_back(std::move(L));
    }
    progress("layers", static_cast<double>(end) / static_cast<double>(zs.size()));
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace

PbfResult plan_pbf_solid(const PbfSolid& part, const PbfSolidOptions& o, const PbfLayerSink& sink,
                         const RunContext& context) {
  PbfResult result;
  context.run([&] { result = plan_pbf_solid_on(part, o, sink, context.progress); });
  return result;
}

}  // namespace trellis
