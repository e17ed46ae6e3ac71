// The CGAL module's table (src/core/module.hpp): Voronoi patterns and foams (lattice) and mesh
// repair (geom) share the one module that loads CGAL, gmp and mpfr. The types are only named
// here, so this header adds no dependency between the modules that use it.
#pragma once
#include <cstdint>
#include <vector>

#include "module.hpp"

namespace trellis {

struct Segment2;
struct Graph;
struct FoamParams;
class Diagnostics;
struct TriangleMesh;
struct MeshRepairOptions;
struct MeshRepairReport;

struct CgalModule {
  detail::ModuleHeader header;
  std::vector<Segment2> (*voronoi_segments)(double, double, std::uint64_t);
  Graph (*voronoi_foam)(const FoamParams&, Diagnostics&);
  TriangleMesh (*repair_mesh)(const TriangleMesh&, const MeshRepairOptions&, MeshRepairReport&);
};

namespace impl {
// Defined in the module (src/geom/mesh_repair.cpp).
TriangleMesh repair_mesh(const TriangleMesh&, const MeshRepairOptions&, MeshRepairReport&);
}  // namespace impl

}  // namespace trellis
