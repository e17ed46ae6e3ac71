// Uses an installed libtrellis: a light route (honeycomb -> GIPPO plan) and the heavy routes that
// run in its run-time modules (a Voronoi lattice through CGAL, a mesh -> distance field through
// OpenVDB), which the installed library must find on its own. Exit 0 only if every check holds.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <trellis/core/diagnostics.hpp>
#include <trellis/field/field.hpp>
#include <trellis/geom/mesh.hpp>
#include <trellis/lattice/atlas.hpp>
#include <trellis/plan/plan.hpp>
#include <trellis/version.hpp>

namespace {
int failures = 0;
void check(bool ok, const char* what) {
  std::printf("%s: %s\n", ok ? "ok" : "FAILED", what);
  failures += !ok;
}
}  // namespace

int main() {
  check(std::strcmp(trellis::version(), TRELLIS_VERSION) == 0, "library and header versions agree");

  trellis::AtlasParams honeycomb;
  honeycomb.region.width = honeycomb.region.height = 10;
  const trellis::Graph g = trellis::make_lattice2d(honeycomb);
  trellis::PlanParams params;
  params.gippo.iterations = 20;
  trellis::Diagnostics diag;
  const trellis::PlanResult plan = trellis::plan_lattice(g, params, diag);
  std::size_t points = 0;
  for (const auto& layer : plan.toolpath.layers)
    for (const auto& path : layer.paths) points += path.points.size();
  check(!g.edges.empty() && points >= g.edges.size(), "a planned honeycomb covers its struts");

  trellis::AtlasParams voronoi = honeycomb;
  voronoi.pattern = trellis::Pattern::Voronoi;
  check(!trellis::make_lattice2d(voronoi).edges.empty(), "a Voronoi lattice (CGAL module)");

  trellis::TriangleMesh cube;
  cube.add_prism({{0, 0}, {4, 0}, {4, 4}, {0, 4}}, 0, 4);
  trellis::MeshSdfOptions sdf;
  sdf.voxel = 0.2;
  trellis::Evaluator ev(trellis::mesh_field(cube, sdf, "cube"));
  const double inside = ev.value({2, 2, 2}), outside = ev.value({2, 2, 4.4});
  // Narrow band of 3 voxels: deep inside reads -0.6; 0.4 mm above the top face reads 0.4.
  check(inside < -0.5 && std::abs(outside - 0.4) < 0.05, "a mesh distance field (OpenVDB module)");
  return failures == 0 ? 0 : 1;
}
