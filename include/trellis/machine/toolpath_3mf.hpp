// 3MF packages with the 3MF Consortium's Toolpath Extension v1.0 (namespace
// http://schemas.3mf.io/3dmanufacturing/toolpath/2026/03), written and read: the build's mesh
// where there is one, and its toolpath as one <tp:toolpathresource> with one XML part per layer.
//
// What is written (docs/formats.md, "3MF toolpath"): coordinates as integers of 10 nm (the .cli's
// resolution, unitfactor 0.00001 mm); one profile per distinct set of path values — laser power,
// speed, jump speed, spot radius and laser index for laser paths, deposition speed, bead width and
// height for extrusion paths — with what the standard has no attribute for (role, tool, mixture,
// temperature, flow, fan, filament, planned travel) in Trellis's own namespace, which other
// consumers ignore. Planar layers when every point lies at its layer's height, else 3-axis.
// Laser hatches (two-point Hatch/Infill paths with a power) become hatch segments, closed
// polylines loops, the rest polylines; a path's order, part and values read back unchanged.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// A strut lattice as the Beam Lattice Extension v1.2 writes it (§2.1): vertices (mm) and beams
// between two of them with a radius at each end; `material` names a beam set ("material N").
struct BeamLattice3mf {
  struct Beam {
    std::uint32_t v1 = 0, v2 = 0;
    double r1 = 0, r2 = 0;
    int material = 0;
  };
  std::vector<Vec3> vertices;
  std::vector<Beam> beams;
};

// A build item's transform (3MF Core §3.4.1): the 3 x 4 matrix "m00 m01 m02 m10 m11 m12 m20 m21
// m22 m30 m31 m32" that maps an object's point (x, y, z, 1), a row vector, into the build.
using Transform3mf = std::array<double, 12>;
inline constexpr Transform3mf kIdentity3mf{1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
// The point `p` mapped by `m`.
Vec3 apply_transform(const Transform3mf& m, const Vec3& p);

// A design as an object of the package: triangles and/or struts, in the design's coordinates,
// placed in the build (the toolpath's coordinates) by its build item's transform.
struct Design3mf {
  const TriangleMesh* mesh = nullptr;       // mm
  bool mesh_is_surface = false;             // an open surface printed on (core §4.1 "surface")
  const BeamLattice3mf* lattice = nullptr;  // mm, as a beam lattice
  Transform3mf transform = kIdentity3mf;
  std::string name;  // the object's name (default: "design", else the part's label)
};

// The build's geometry: every part a path names (Path::part) is a build item of the package
// (Toolpath Extension Part II §1.1.1). Part 0 is the design's own object: its mesh and/or its
// strut lattice; part k ≥ 1 (a plate's part) is parts[k - 1]'s design at its place on the plate.
// Parts whose design is the same (the same mesh and lattice pointers) share one object, each
// with its own build item. A part without geometry (a toolpath read back) gets the beads it
// prints instead: one beam per path segment, of half the path's width (else bead_width; a laser
// path's: the spot's; else its height), in the build's coordinates.
struct Toolpath3mfOptions {
  const LaserProfile* laser = nullptr;      // PBF: the laser (lasersources, jump speed, spot)
  const TriangleMesh* mesh = nullptr;       // the build's geometry (mm), written as its build item
  bool mesh_is_surface = false;             // an open surface printed on (core §4.1 "surface")
  const BeamLattice3mf* lattice = nullptr;  // the build's struts (mm), as a beam lattice
  Transform3mf transform = kIdentity3mf;    // where mesh and lattice lie in the build
  std::vector<Design3mf> parts;             // a plate's parts' designs (Path::part k: [k - 1])
  double bead_width = 0;  // mm: a deposition path's width where it has none (the nozzle's)
};

// The package's bytes, and the package written atomically (core/file.hpp). A coordinate beyond
// ±21 m or a value that is not finite → GeometryError naming the layer and path.
std::string write_toolpath_3mf(const Toolpath& toolpath, const Toolpath3mfOptions& options);
void write_toolpath_3mf_file(const std::string& path, const Toolpath& toolpath,
                             const Toolpath3mfOptions& options);

// A 3MF package's toolpath (ours or any producer's) → the IR. No toolpath resource → ParseError
// saying so; malformed XML → ParseError naming the part, line and column; what the IR cannot
// hold (a modifier other than a constant one, a 6-axis orientation) is refused. A laser path's
// laser index (§4.5: the segment's, its profile's or the default) becomes its Path::tool, and
// the writer writes a laser path's tool as its profile's laserindex, with one laser source per
// laser (LaserProfile::lasers and fields).
Toolpath read_toolpath_3mf_file(const std::string& path, Diagnostics* diag = nullptr);

// What a 3MF file carries, from its model part alone (no layer is read): no toolpath (a mesh or
// lattice, or not a 3MF package at all), a laser toolpath (a profile with laser power or speed)
// or a deposition one.
enum class Toolpath3mfKind { None, Laser, Deposition };
Toolpath3mfKind toolpath_3mf_kind(const std::string& path);

}  // namespace trellis
