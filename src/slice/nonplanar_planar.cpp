// The planar control of a non-planar print: the bands of the solid that the non-planar layer
// groups fill, each a closed mesh (the surface lifted to the band's bottom and top, joined by
// walls along the footprint's rim), sliced flat and planned by the planar slicer, one tool each.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/nonplanar.hpp"
#include "trellis/slice/slice.hpp"

namespace trellis {

namespace {

struct Group {
  int first = 0, end = 0;  // non-planar layers [first, end)
  int tool = 0;
};

// Runs of consecutive layers with one tool (layer_tools cycled over the layers).
std::vector<Group> layer_groups(const NonplanarParams& p) {
  std::vector<Group> groups;
  const auto& tools = p.layer_tools.empty() ? std::vector<int>{0} : p.layer_tools;
  for (int k = 0; k < p.layers; ++k) {
    const int t = tools[static_cast<std::size_t>(k) % tools.size()];
    if (groups.empty() || groups.back().tool != t)
      groups.push_back({k, k + 1, t});
    else
      groups.back().end = k + 1;
  }
  return groups;
}

// The surface's triangles on shared vertices (an STL repeats them), each turned to face up.
TriangleMesh welded_upward(const TriangleMesh& in) {
  TriangleMesh out = weld(in);
  std::erase_if(out.triangles, [&](auto& f) {
    const Vec3 a = out.vertices[f[0]], b = out.vertices[f[1]], c = out.vertices[f[2]];
    const double nz = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (nz < 0) std::swap(f[1], f[2]);
    return nz == 0;  // vertical or degenerate: no area over the footprint
  });
  return out;
}

// The closed band between the surface lifted by lo and by hi.
TriangleMesh band_mesh(const TriangleMesh& up, double lo, double hi) {
  TriangleMesh m;
  const auto n = static_cast<std::uint32_t>(up.vertices.size());
  for (const auto& v : up.vertices) m.vertices.push_back({v.x, v.y, v.z + lo});
  for (const auto& v : up.vertices) m.vertices.push_back({v.x, v.y, v.z + hi});
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;  // directed edge -> uses
  for (const auto& t : up.triangles) {
    m.triangles.push_back({t[0], t[2], t[1]});              // bottom, facing down
    m.triangles.push_back({t[0] + n, t[1] + n, t[2] + n});  // top, facing up
    for (int i = 0; i < 3; ++i) ++edges[{t[i], t[(i + 1) % 3]}];
  }
  // A rim edge a -> b is used by one triangle only: the wall below it faces outwards.
  for (const auto& [e, uses] : edges) {
    if (edges.count({e.second, e.first})) continue;
    const auto [a, b] = e;
    m.triangles.push_back({a, b, b + n});
    m.triangles.push_back({a, b + n, a + n});
  }
  return m;
}

}  // namespace

PlanarControlResult slice_planar_control(const HeightField& surface, const NonplanarParams& params,
                                         const RunContext& context) {
  const Progress& progress = context.progress;
  if (params.offset != OffsetMode::Vertical)
    throw SettingError(
        "the planar control stacks the layers vertically: use nonplanar.offset = vertical",
        {"", 0, "nonplanar.offset"});
  if (!(params.layer_height > 0) || !(params.width > 0) || params.layers < 1)
    throw SettingError("the planar control needs a layer height, a width and at least one layer",
                       {"", 0, "nonplanar.layers"});
  const TriangleMesh up = welded_upward(surface_mesh(surface, params.width / 2));
  if (up.triangles.empty())
    throw GeometryError("surface '" + surface.name() + "' has no area over its footprint",
                        {"", 0, "surface"});
  double zmin = std::numeric_limits<double>::infinity(), zmax = -zmin;
  for (const auto& v : up.vertices) {
    zmin = std::min(zmin, v.z);
    zmax = std::max(zmax, v.z);
  }
  const double h = params.layer_height;
  const std::vector<double> zs = layer_planes(zmin, zmax + params.layers * h, h);

  PlanarOptions o;
  o.layer_height = h;
  o.bead_width = params.width;
  o.walls = 1;
  o.top_layers = o.bottom_layers = 0;
  o.infill_density = 1;
  o.infill_angle = params.angles.empty() ? 0 : params.angles.front();

  const std::vector<Group> groups = layer_groups(params);
  std::vector<Toolpath> planned;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    progress.check("planar control");
    const TriangleMesh band = band_mesh(up, groups[g].first * h, groups[g].end * h);
    planned.push_back(plan_planar(slice_mesh_layers(band, zs), o));
    progress("bands", static_cast<double>(g + 1) / static_cast<double>(groups.size()));
  }

  PlanarControlResult r;
  r.toolpath.source = "planar control of " + surface.name();
  int last = groups.front().tool;
  // Planes whose bands are all thinner than a bead print nothing: no layer is written for them
  // (the others keep their heights, so the print fills the non-planar print's volume).
  for (std::size_t i = 0; i < zs.size(); ++i) {
    Layer layer;
    layer.z = static_cast<double>(i + 1) * h;
    // The tools present in this layer, the one the layer below ended with first.
    std::vector<int> tools;
    for (std::size_t g = 0; g < groups.size(); ++g)
      if (i < planned[g].layers.size() && !planned[g].layers[i].paths.empty() &&
          std::find(tools.begin(), tools.end(), groups[g].tool) == tools.end())
        tools.push_back(groups[g].tool);
    std::stable_sort(tools.begin(), tools.end(),
                     [&](int a, int b) { return (a == last) > (b == last); });
    for (int t : tools) {
      for (std::size_t g = 0; g < groups.size(); ++g) {
        if (groups[g].tool != t || i >= planned[g].layers.size()) continue;
        auto& paths = planned[g].layers[i].paths;
        if (paths.empty()) continue;
        // The travel into a band's first path comes from another band's end: straight, outside.
        paths.front().via.clear();
        paths.front().inside = false;
        for (auto& p : paths) {
          if (!layer.paths.empty() && layer.paths.back().tool != t) ++r.tool_changes;
          if (layer.paths.empty() && !r.toolpath.layers.empty() && t != last) ++r.tool_changes;
          p.tool = t;
          layer.paths.push_back(std::move(p));
        }
      }
      last = t;
    }
    r.layers_with_several_tools += tools.size() > 1;
    if (!layer.paths.empty()) r.toolpath.layers.push_back(std::move(layer));
  }
  return r;
}

}  // namespace trellis
