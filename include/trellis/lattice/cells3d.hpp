// 3D strut lattices: unit cells tessellated n×m×k, stochastic Voronoi foams in a box or inside a
// closed mesh, and rules that give each strut a material.
//
// Unit cells in a cube of side `cell` (mm), corner at the origin:
//   cubic     the 12 cube edges
//   bcc       the body centre joined to the 8 corners
//   fcc       each face centre joined to its 4 corners (24 struts)
//   octet     fcc plus the octahedron joining adjacent face centres (14 nodes, 36 struts)
//   diamond   4 tetrahedral sites (¼,¼,¼ …) each joined to its 4 nearest fcc sites (16 struts)
//   kelvin    truncated octahedra in bcc packing (Kelvin foam; edge = cell·√2/4)
//   rhombic-dodecahedron  rhombic dodecahedra centred on the fcc sites (edge = cell·√3/4)
// Kelvin and rhombic dodecahedra are generated as whole polyhedra around the cell and clipped
// to it (their edges never straddle a cell face, so nothing is cut). Cells share faces: nodes
// merge and duplicate struts are dropped when the cells are put together.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/lattice/graph.hpp"

namespace trellis {

enum class UnitCell { Cubic, Bcc, Fcc, Octet, Diamond, Kelvin, RhombicDodecahedron };

UnitCell unit_cell_from_string(const std::string& name);  // throws SettingError
std::string to_string(UnitCell cell);
std::vector<std::string> unit_cell_names();

struct CellLatticeParams {
  UnitCell cell = UnitCell::Octet;
  double size = 7.0;  // cell side (mm)
  int nx = 1, ny = 1, nz = 1;
};

// Throws SettingError for a non-positive size or counts outside 1..1000 (or over 10^7 struts).
Graph cell_lattice(const CellLatticeParams& params);

struct FoamParams {
  double width = 20, depth = 20, height = 20;  // box from the origin (mm), if no mesh
  double density = 0.01;                       // seeds per mm³
  std::uint64_t seed = 1;
  std::string mesh;  // closed STL/OBJ/3MF: the foam fills it instead of the box
};

// Voronoi edges of seeded uniform random points (CGAL 3D Delaunay, its dual). In a box the seeds
// are mirrored in its six faces so the cells close on them; in a mesh the struts with both ends
// inside it are kept. Reproducible for a seed. Throws SettingError / IoError / GeometryError.
Graph voronoi_foam(const FoamParams& params, Diagnostics& diag);

// A conformal lattice like the AERO paper's bunny: a periodic cell lattice clipped to a closed
// mesh (struts with both ends inside), optionally with a stochastic skin: the core keeps only
// struts at least `skin` deep, a Voronoi foam fills the outer `skin` mm, and every core node
// that lost a strut to the clipping is joined to its nearest skin node. Depth comes from the
// mesh's signed distance field (OpenVDB). Throws SettingError / IoError / GeometryError.
struct ConformalParams {
  std::string mesh;                 // closed STL/OBJ/3MF
  UnitCell cell = UnitCell::Cubic;  // periodic core cell
  double size = 5.0;                // cell side (mm)
  double skin = 0;                  // stochastic skin thickness (mm); 0 = no skin
  double skin_density = 0.05;       // skin foam seeds per mm³
  std::uint64_t seed = 1;           // skin foam seed
  int core_material = 0, skin_material = 0;
  double voxel = 0;  // distance-field voxel (mm); 0 = size / 10
};
Graph conformal_lattice(const ConformalParams& params, Diagnostics& diag);

enum class MaterialRule {
  None,       // all material 0
  XyPlane,    // struts in the XY plane material 0 (rigid), all others 1 (flexible)
  Component,  // one material per connected part
  Vertical,   // struts within the nozzle cone (steep) material 1, others 0
};

void assign_materials(Graph& g, MaterialRule rule, double tolerance = 1e-6,
                      double cone_half_angle_deg = 30);

}  // namespace trellis
