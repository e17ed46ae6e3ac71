#include "trellis/slice/pbf_skin.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <unordered_map>

namespace trellis {

namespace {

// Inward offsets are exact to this (mm), as the contours' (slice/pbf_mesh.cpp).
constexpr double kArcTolerance = 1e-4;
// Hatch pieces shorter than this (mm) are dropped, as the scan strategies' cuts.
constexpr double kMinPiece = 1e-4;

// A hatch line's frame: u along the lines, v across them (as geom/regions.cpp's hatch()).
struct Frame {
  Vec2 u, v;
  explicit Frame(double angle_deg) {
    const double a = angle_deg * std::numbers::pi / 180;
    u = {std::cos(a), std::sin(a)};
    v = {-std::sin(a), std::cos(a)};
  }
  double along(Vec2 p) const { return p.x * u.x + p.y * u.y; }
  double across(Vec2 p) const { return p.x * v.x + p.y * v.y; }
};

// The region's stretches on each line of one direction, by line number.
struct LineSpans {
  Frame f;
  std::unordered_map<long, std::vector<std::pair<double, double>>> spans;
  LineSpans(const Regions& region, double angle_deg, double spacing, Vec2 origin) : f(angle_deg) {
    for (const Segment2& s : hatch(region, angle_deg, spacing, origin)) {
      const long k = std::lround(f.across(s.a - origin) / spacing);
      spans[k].push_back({f.along(s.a - origin), f.along(s.b - origin)});
    }
    for (auto& [k, v] : spans) std::sort(v.begin(), v.end());
  }
};

}  // namespace

const char* hatch_kind_name(HatchKind kind) {
  switch (kind) {
    case HatchKind::Skin:
      return "skin";
    case HatchKind::Core:
      return "core";
    case HatchKind::UpSkin:
      return "upskin";
    case HatchKind::DownSkin:
      return "downskin";
  }
  return "skin";
}

std::size_t layers_within(double thickness, double layer) {
  if (!(thickness > 0) || !(layer > 0)) return 0;
  return static_cast<std::size_t>(std::ceil(thickness / layer - 1e-9));
}

SkinWindow::SkinWindow(const SkinOptions& options, double layer, std::size_t layers)
    : o_(options),
      layers_(layers),
      n_up_(layers_within(options.upskin_thickness, layer)),
      n_down_(layers_within(options.downskin_thickness, layer)),
      n_core_(layers_within(options.skin_thickness, layer)),
      reach_(std::max({n_up_, n_down_, n_core_})) {}

const Regions& SkinWindow::run(Run r) const {
  const auto it = runs_.find(r);
  return it == runs_.end() ? empty_ : it->second;
}

void SkinWindow::prepare(std::size_t first, std::size_t end,
                         const std::function<const Regions&(std::size_t)>& region) {
  const long low = static_cast<long>(first) - static_cast<long>(reach_);
  std::erase_if(runs_, [&](const auto& e) { return e.first.first < low; });
  // The runs the layers need, each once: a layer's run above is a later layer's run below.
  std::vector<Run> wanted;
  for (std::size_t i = first; i < end; ++i) {
    if (n_up_ > 0) wanted.push_back(above(i));
    if (n_down_ > 0) wanted.push_back(below(i));
    if (n_core_ > 0) wanted.push_back(around(i));
  }
  std::sort(wanted.begin(), wanted.end());
  wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
  // A run reaching outside the part holds no material everywhere: empty, not made.
  std::erase_if(wanted, [&](Run r) {
    return runs_.count(r) > 0 || r.first < 0 || r.first + r.second > static_cast<long>(layers_);
  });
  std::vector<Regions> made(wanted.size());
  tbb::parallel_for(std::size_t{0}, wanted.size(), [&](std::size_t k) {
    const auto [from, count] = wanted[k];
    Regions r = region(static_cast<std::size_t>(from));
    for (long j = from + 1; j < from + count && !r.empty(); ++j)
      r = intersection(r, region(static_cast<std::size_t>(j)));
    made[k] = std::move(r);
  });
  for (std::size_t k = 0; k < wanted.size(); ++k) runs_[wanted[k]] = std::move(made[k]);
}

LayerKinds SkinWindow::split(std::size_t i, const Regions& region) const {
  LayerKinds k;
  Regions rest = region;
  if (n_down_ > 0) {
    k[static_cast<int>(HatchKind::DownSkin)] = difference(rest, run(below(i)));
    rest = intersection(rest, run(below(i)));
  }
  if (n_up_ > 0) {
    k[static_cast<int>(HatchKind::UpSkin)] = difference(rest, run(above(i)));
    rest = intersection(rest, run(above(i)));
  }
  if (n_core_ > 0) {
    const Regions core =
        intersection(rest, offset(run(around(i)), -o_.skin_thickness, kArcTolerance));
    k[static_cast<int>(HatchKind::Skin)] = difference(rest, core);
    k[static_cast<int>(HatchKind::Core)] = core;
  } else {
    k[static_cast<int>(HatchKind::Skin)] = std::move(rest);
  }
  return k;
}

LaserSet PbfExposures::of_contour(std::size_t offset) const {
  return offset < contours.size() ? contours[offset] : contour;
}

LaserSet PbfExposures::of(HatchKind kind) const {
  const LaserSet* s = kind == HatchKind::Core       ? &core
                      : kind == HatchKind::UpSkin   ? &upskin
                      : kind == HatchKind::DownSkin ? &downskin
                                                    : &hatch;
  return {s->power > 0 ? s->power : hatch.power, s->speed > 0 ? s->speed : hatch.speed};
}

std::vector<ParameterSet> named_parameter_sets(const PbfExposures& e, const SkinOptions& skin) {
  std::vector<ParameterSet> sets{{"contour", PathRole::Contour, e.contour.power, e.contour.speed},
                                 {"hatch", PathRole::Hatch, e.hatch.power, e.hatch.speed}};
  const auto add = [&](std::string name, PathRole role, LaserSet s) {
    Toolpath named;  // parameter_set_of looks sets up in a toolpath
    named.parameter_sets = std::move(sets);
    if (parameter_set_of(named, role, s.power, s.speed) < 0)
      named.parameter_sets.push_back({std::move(name), role, s.power, s.speed});
    sets = std::move(named.parameter_sets);
  };
  for (std::size_t i = 0; i < e.contours.size(); ++i)
    add("contour " + std::to_string(i + 1), PathRole::Contour, e.of_contour(i));
  if (skin.skin_thickness > 0) add("core hatch", PathRole::Hatch, e.of(HatchKind::Core));
  if (skin.upskin_thickness > 0) add("upskin hatch", PathRole::Hatch, e.of(HatchKind::UpSkin));
  if (skin.downskin_thickness > 0)
    add("downskin hatch", PathRole::Hatch, e.of(HatchKind::DownSkin));
  return sets;
}

std::vector<Segment2> clip_hatches(const std::vector<Segment2>& segments, const Regions& region,
                                   double angle_deg, double spacing, Vec2 origin) {
  std::vector<Segment2> out;
  if (segments.empty() || region.empty()) return out;
  const LineSpans along(region, angle_deg, spacing, origin);
  std::unique_ptr<LineSpans> across;  // the islands' other direction, made when first met
  for (const Segment2& s : segments) {
    const Vec2 d = s.b - s.a;
    const bool turned = std::abs(along.f.along(d)) < std::abs(along.f.across(d));
    if (turned && !across)
      across = std::make_unique<LineSpans>(region, angle_deg + 90, spacing, origin);
    const LineSpans& lines = turned ? *across : along;
    const long k = std::lround(lines.f.across(s.a - origin) / spacing);
    const auto it = lines.spans.find(k);
    if (it == lines.spans.end()) continue;
    const double ua = lines.f.along(s.a - origin), ub = lines.f.along(s.b - origin);
    const double len = ub - ua;
    if (len == 0) continue;
    const double lo = std::min(ua, ub), hi = std::max(ua, ub);
    const auto at = [&](double u) { return s.a + d * ((u - ua) / len); };
    const std::size_t before = out.size();
    for (const auto& [x0, x1] : it->second) {
      const double a = std::max(lo, x0), b = std::min(hi, x1);
      if (b - a > kMinPiece)
        out.push_back(ua < ub ? Segment2{at(a), at(b)} : Segment2{at(b), at(a)});
    }
    if (ub < ua) std::reverse(out.begin() + static_cast<long>(before), out.end());
  }
  return out;
}

}  // namespace trellis
