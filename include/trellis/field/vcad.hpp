// The OpenVCAD design language (.vcad):
//
//   root((minx,miny,minz),(maxx,maxy,maxz),(vx,vy,vz)) { ... }   optional; clips to the box and
//                                                                sets the default resolution
//   sphere(r) cube(s) rectprism(x,y,z) | rectprism((x,y,z)) cylinder(r,h) cone(r,h) torus(R,r)
//   function((minx,miny,minz),(maxx,maxy,maxz),"expr")
//   gyroid|schwarz_p|schwarz_d|diamond|neovius|iwp(cell [, c])   c: number or "expression"
//   mesh("file.stl|.obj|.3mf")                                   path relative to the .vcad file
//   each leaf takes an optional trailing material string:  sphere(5, "red");
//   union() intersection() difference() { ... }   optional blend radius: union(2) { ... }
//   translate(x,y,z) scale(s | x,y,z) rotate(x,y,z) { ... }      degrees, X then Y then Z
//   fgrade(["expr", ...], ["material", ...] [, "mode"]) { ... }
//   fprocess(["expr", ...], ["temperature" | "speed" | "flow" | "fan", ...]) { ... }
//                                      process parameters as fields (°C, mm/s, multiplier, %)
//
// Several statements in a block are a union. `;` after a leaf is optional; // and /* */ comment.
// Expressions use x, y, z, rho, phic (phi), r, theta, phis, d, pi (muparser syntax).
#pragma once
#include <string>

#include "trellis/field/field.hpp"

namespace trellis {

struct VcadOptions {
  double mesh_voxel = 0.25;  // mm, for mesh() leaves without a root resolution
  std::string base_dir;      // where mesh() paths are resolved; default: the file's directory
};

struct VcadDesign {
  Field field;
  bool has_root = false;
  Vec3 root_min, root_max;
  Vec3 resolution{0, 0, 0};  // from root(), 0 if none
  // mm: the smallest feature the design asks to be resolved (a 3MF level set's minfeaturesize,
  // Volumetric & Implicit Part I §4.1.1); 0 if none. Routes warn when they cannot resolve it.
  double min_feature_size = 0;
  std::string source;  // file name
};

// Throws ParseError with file, line and column on any problem.
VcadDesign parse_vcad(const std::string& text, const std::string& name,
                      const VcadOptions& options = {});
VcadDesign read_vcad(const std::string& path, const VcadOptions& options = {});

}  // namespace trellis
