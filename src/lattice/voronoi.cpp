// Voronoi edges via CGAL's Delaunay triangulation (its dual). CGAL stays inside this file, built
// as the run-time module trellis_cgal (see src/core/module.hpp).
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "../core/cgal_module.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/geom/mesh_repair.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/lattice/cells3d.hpp"

namespace trellis {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel>;

namespace impl {

std::vector<Segment2> voronoi_segments(double half, double density, std::uint64_t seed) {
  // Seeds over a margin beyond the square so cells near its border are closed.
  const double h = half * 1.25;
  const auto count = static_cast<std::size_t>(std::llround(density * (2 * h) * (2 * h)));
  Rng rng(seed);
  std::vector<Kernel::Point_2> pts;
  pts.reserve(count);
  for (std::size_t i = 0; i < count; ++i)
    pts.emplace_back(-h + 2 * h * rng.uniform01(), -h + 2 * h * rng.uniform01());
  Delaunay dt(pts.begin(), pts.end());
  std::vector<Segment2> out;
  for (auto e = dt.finite_edges_begin(); e != dt.finite_edges_end(); ++e) {
    const auto f1 = e->first, f2 = e->first->neighbor(e->second);
    if (dt.is_infinite(f1) || dt.is_infinite(f2)) continue;
    const auto a = dt.dual(f1), b = dt.dual(f2);
    Segment2 s{{a.x(), a.y()}, {b.x(), b.y()}};
    if (std::tie(s.b.x, s.b.y) < std::tie(s.a.x, s.a.y)) std::swap(s.a, s.b);
    out.push_back(s);
  }
  // CGAL's bulk insertion shuffles with a global random state, so the edge order varies from
  // call to call; sort for output that depends only on the seed.
  std::sort(out.begin(), out.end(), [](const Segment2& p, const Segment2& q) {
    return std::tie(p.a.x, p.a.y, p.b.x, p.b.y) < std::tie(q.a.x, q.a.y, q.b.x, q.b.y);
  });
  return out;
}

namespace {

// Inside a closed mesh by ray parity (a slightly tilted +z ray avoids edges and vertices).
bool inside_mesh(const TriangleMesh& mesh, Vec3 p) {
  const Vec3 d{1.2345e-3, 2.3456e-3, 1.0};
  int crossings = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    if (std::max({a.z, b.z, c.z}) < p.z) continue;
    const Vec3 e1 = b - a, e2 = c - a;
    const Vec3 h{d.y * e2.z - d.z * e2.y, d.z * e2.x - d.x * e2.z, d.x * e2.y - d.y * e2.x};
    const double det = dot(e1, h);
    if (std::abs(det) < 1e-15) continue;
    const Vec3 sv = p - a;
    const double u = dot(sv, h) / det;
    if (u < 0 || u > 1) continue;
    const Vec3 q{sv.y * e1.z - sv.z * e1.y, sv.z * e1.x - sv.x * e1.z, sv.x * e1.y - sv.y * e1.x};
    const double v = dot(d, q) / det;
    if (v < 0 || u + v > 1) continue;
    if (dot(e2, q) / det > 0) ++crossings;
  }
  return crossings % 2 == 1;
}

}  // namespace

Graph voronoi_foam(const FoamParams& p, Diagnostics& diag) {
  using Delaunay3 = CGAL::Delaunay_triangulation_3<Kernel>;
  if (!(p.density > 0) || !std::isfinite(p.density))
    throw SettingError("the foam seed density must be positive (seeds per mm³)");
  TriangleMesh mesh;
  Vec3 lo{0, 0, 0}, hi{p.width, p.depth, p.height};
  if (!p.mesh.empty()) {
    mesh = read_mesh(p.mesh);
    require_closed(mesh, p.mesh);
    const BBox3 b = bounds(mesh);
    lo = b.min;
    hi = b.max;
  } else if (!(p.width > 0 && p.depth > 0 && p.height > 0) || p.width > 1e5 || p.depth > 1e5 ||
             p.height > 1e5) {
    throw SettingError("the foam box needs positive width, depth and height (at most 100 m)");
  }
  const Vec3 size = hi - lo;
  const double seeds_f = p.density * size.x * size.y * size.z;
  if (seeds_f > 2e6) throw SettingError("more than 2 million foam seeds: lower the density");
  const auto count = static_cast<std::size_t>(std::llround(seeds_f));
  if (count < 2) throw SettingError("fewer than 2 foam seeds: raise the density or the size");
  Rng rng(p.seed);
  std::vector<Kernel::Point_3> pts;
  std::vector<Vec3> seeds;
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3 q{lo.x + size.x * rng.uniform01(), lo.y + size.y * rng.uniform01(),
                 lo.z + size.z * rng.uniform01()};
    if (!mesh.triangles.empty() && !inside_mesh(mesh, q)) continue;
    seeds.push_back(q);
  }
  for (const Vec3 q : seeds) {
    pts.emplace_back(q.x, q.y, q.z);
    if (mesh.triangles.empty())  // mirror images in the six faces close the cells on them
      for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
          Vec3 m = q;
          const double wall = side ? (&hi.x)[axis] : (&lo.x)[axis];
          (&m.x)[axis] = 2 * wall - (&q.x)[axis];
          pts.emplace_back(m.x, m.y, m.z);
        }
  }
  if (seeds.size() < 4)
    throw GeometryError("only " + std::to_string(seeds.size()) +
                        " foam seed(s) inside the mesh (4 or more needed): raise the density");
  Delaunay3 dt(pts.begin(), pts.end());
  if (dt.dimension() < 3)  // all seeds on a plane: no Voronoi vertices
    throw GeometryError("the foam seeds are coplanar: raise the density or change the seed");
  const double eps = 1e-9 * std::max({size.x, size.y, size.z});
  auto keep = [&](Vec3 v) {
    if (!mesh.triangles.empty()) return inside_mesh(mesh, v);
    return v.x >= lo.x - eps && v.y >= lo.y - eps && v.z >= lo.z - eps && v.x <= hi.x + eps &&
           v.y <= hi.y + eps && v.z <= hi.z + eps;
  };
  // Voronoi vertices are circumcentres of finite cells; edges join neighbouring cells.
  std::vector<std::array<double, 6>> segs;
  for (auto f = dt.finite_facets_begin(); f != dt.finite_facets_end(); ++f) {
    const auto c1 = f->first, c2 = c1->neighbor(f->second);
    if (dt.is_infinite(c1) || dt.is_infinite(c2)) continue;
    const auto a = dt.dual(c1), b = dt.dual(c2);
    const Vec3 va{a.x(), a.y(), a.z()}, vb{b.x(), b.y(), b.z()};
    if (!keep(va) || !keep(vb)) continue;
    std::array<double, 6> s{va.x, va.y, va.z, vb.x, vb.y, vb.z};
    if (std::tie(s[3], s[4], s[5]) < std::tie(s[0], s[1], s[2])) {
      std::swap(s[0], s[3]);
      std::swap(s[1], s[4]);
      std::swap(s[2], s[5]);
    }
    segs.push_back(s);
  }
  std::sort(segs.begin(), segs.end());  // CGAL's insertion order varies; the seed decides
  Graph raw;
  for (const auto& s : segs) {
    const auto i = static_cast<NodeId>(raw.nodes.size());
    raw.nodes.push_back({s[0], s[1], s[2]});
    raw.nodes.push_back({s[3], s[4], s[5]});
    raw.edges.push_back({i, i + 1, 0, false});
  }
  if (raw.edges.empty()) throw GeometryError("the foam has no struts: raise the seed density");
  CleanOptions clean;
  clean.merge_tolerance = 1e-6 * std::max({size.x, size.y, size.z});
  clean.split_t_junctions = false;
  Diagnostics quiet;  // coincident circumcentres (co-spherical seeds) merge by design
  Graph g = clean_graph(raw, clean, quiet);
  if (quiet.count("zero_length_edge") > 0)
    diag.warn("foam_degenerate", std::to_string(quiet.count("zero_length_edge")) +
                                     " zero-length Voronoi edges (co-spherical seeds) dropped");
  return g;
}

}  // namespace impl

}  // namespace trellis

TRELLIS_MODULE_ENTRY(cgal, trellis::CgalModule, &trellis::impl::voronoi_segments,
                     &trellis::impl::voronoi_foam, &trellis::impl::repair_mesh)
