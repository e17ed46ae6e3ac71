#include <algorithm>
#include <cmath>
#include <limits>

#include "trellis/core/error.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/lattice/cells3d.hpp"

namespace trellis {

namespace {

// Keeps the struts `keep` accepts, with their nodes, renumbered (map: old node -> new node or
// UINT32_MAX).
template <class Keep>
Graph filter(const Graph& g, Keep keep, int material, std::vector<NodeId>& map) {
  Graph out;
  map.assign(g.nodes.size(), UINT32_MAX);
  auto node = [&](NodeId n) {
    if (map[n] == UINT32_MAX) {
      map[n] = static_cast<NodeId>(out.nodes.size());
      out.nodes.push_back(g.nodes[n]);
    }
    return map[n];
  };
  for (EdgeId e = 0; e < g.edges.size(); ++e) {
    if (!keep(e)) continue;
    Edge ed = g.edges[e];
    ed.a = node(ed.a);
    ed.b = node(ed.b);
    ed.material = material;
    out.edges.push_back(ed);
  }
  return out;
}

// Joins every piece of the lattice to the rest: the smallest piece, by a strut between its node
// and the nearest node of another piece, until one piece remains (skin foam clipped to a shell
// falls apart into fragments that would print as loose bits).
void join_fragments(Graph& g, int material, Diagnostics& diag) {
  std::size_t added = 0;
  while (true) {
    int count = 0;
    const std::vector<int> comp = connected_components(g, &count);
    if (count <= 1) break;
    std::vector<std::size_t> size(static_cast<std::size_t>(count), 0);
    for (int c : comp)
      if (c >= 0) ++size[static_cast<std::size_t>(c)];
    const int small = static_cast<int>(std::min_element(size.begin(), size.end()) - size.begin());
    NodeId best_a = 0, best_b = 0;
    double best = std::numeric_limits<double>::infinity();
    for (NodeId a = 0; a < g.nodes.size(); ++a) {
      if (comp[a] != small) continue;
      for (NodeId b = 0; b < g.nodes.size(); ++b)
        if (comp[b] >= 0 && comp[b] != small)
          if (const double d = distance(g.nodes[a], g.nodes[b]); d < best)
            best = d, best_a = a, best_b = b;
    }
    g.edges.push_back({best_a, best_b, material});
    ++added;
  }
  if (added)
    diag.warn("conformal_fragments_joined",
              std::to_string(added) +
                  " loose piece(s) of the skin joined by a strut to the nearest "
                  "node of the rest");
}

}  // namespace

Graph conformal_lattice(const ConformalParams& p, Diagnostics& diag) {
  if (!(p.size > 0) || !std::isfinite(p.size)) throw SettingError("the cell size must be positive");
  if (!(p.skin >= 0) || !std::isfinite(p.skin))
    throw SettingError("the skin thickness must be zero or positive (mm)");
  if (p.mesh.empty()) throw SettingError("a conformal lattice needs a closed mesh");
  const TriangleMesh mesh = read_mesh(p.mesh);
  require_closed(mesh, p.mesh);
  const BBox3 box = bounds(mesh);
  const Vec3 span = box.max - box.min;
  // Depth below the surface from the mesh's signed distance field, exact enough for the band
  // that matters (the skin plus a strut).
  const double voxel = p.voxel > 0 ? p.voxel : std::max(p.size / 10, 1e-3);
  MeshSdfOptions sdf;
  sdf.voxel = voxel;
  sdf.band_voxels = std::max(3.0, (p.skin + p.size) / voxel + 2);
  Evaluator depth_field(mesh_field(mesh, sdf, "conformal"));
  auto depth = [&](Vec3 q) { return -depth_field.value(q); };

  // Core: the periodic lattice over the mesh's box, struts with both ends at least `skin` deep.
  CellLatticeParams cells;
  cells.cell = p.cell;
  cells.size = p.size;
  cells.nx = std::max(1, static_cast<int>(std::ceil(span.x / p.size)));
  cells.ny = std::max(1, static_cast<int>(std::ceil(span.y / p.size)));
  cells.nz = std::max(1, static_cast<int>(std::ceil(span.z / p.size)));
  Graph full = cell_lattice(cells);
  for (auto& n : full.nodes) n = n + box.min;
  std::vector<double> d(full.nodes.size());
  for (NodeId n = 0; n < full.nodes.size(); ++n) d[n] = depth(full.nodes[n]);
  const double floor_depth = p.skin > 0 ? p.skin : 0.0;
  auto in_core = [&](EdgeId e) {
    return d[full.edges[e].a] >= floor_depth && d[full.edges[e].b] >= floor_depth;
  };
  std::vector<NodeId> core_id, skin_id;
  Graph core = filter(full, in_core, p.core_material, core_id);
  if (p.skin <= 0) {
    if (core.edges.empty())
      throw GeometryError("no cell strut lies inside the mesh: smaller cells");
    return core;
  }
  // Core nodes that lost a strut to the clipping: where the skin attaches.
  std::vector<char> cut(full.nodes.size(), 0);
  for (EdgeId e = 0; e < full.edges.size(); ++e)
    if (!in_core(e)) {
      const Edge& ed = full.edges[e];
      if (d[ed.a] >= floor_depth) cut[ed.a] = 1;
      if (d[ed.b] >= floor_depth) cut[ed.b] = 1;
    }
  // Skin: a Voronoi foam in the mesh, struts with an end shallower than the skin.
  FoamParams foam;
  foam.mesh = p.mesh;
  foam.density = p.skin_density;
  foam.seed = p.seed;
  const Graph froth = voronoi_foam(foam, diag);
  std::vector<double> fd(froth.nodes.size());
  for (NodeId n = 0; n < froth.nodes.size(); ++n) fd[n] = depth(froth.nodes[n]);
  const Graph skin = filter(
      froth,
      [&](EdgeId e) { return std::min(fd[froth.edges[e].a], fd[froth.edges[e].b]) < p.skin; },
      p.skin_material, skin_id);
  if (skin.edges.empty())
    throw GeometryError("the skin has no struts: raise lattice3d.skin_density");
  // Join: each cut core node to its nearest skin node (a strut of the core's material).
  Graph out = core;
  const auto offset = static_cast<NodeId>(out.nodes.size());
  out.nodes.insert(out.nodes.end(), skin.nodes.begin(), skin.nodes.end());
  for (Edge e : skin.edges) {
    e.a += offset;
    e.b += offset;
    out.edges.push_back(e);
  }
  for (NodeId n = 0; n < full.nodes.size(); ++n) {
    if (!cut[n]) continue;
    const Vec3 q = full.nodes[n];
    NodeId best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (NodeId s = 0; s < skin.nodes.size(); ++s)
      if (const double dd = distance(q, skin.nodes[s]); dd < best_d) best_d = dd, best = s;
    const NodeId c = core_id[n];
    if (c == UINT32_MAX || best_d <= 0) continue;  // a node whose struts all fell away
    out.edges.push_back({c, best + offset, p.core_material});
  }
  join_fragments(out, p.skin_material, diag);
  CleanOptions clean;
  clean.merge_tolerance = 1e-6 * std::max({span.x, span.y, span.z});
  clean.split_t_junctions = false;
  Diagnostics quiet;
  Graph g = clean_graph(out, clean, quiet);
  if (quiet.total() > 0)
    diag.warn("conformal_cleaned", std::to_string(quiet.total()) +
                                       " degenerate or duplicate strut(s) dropped while joining "
                                       "the core and the skin");
  return g;
}

}  // namespace trellis
