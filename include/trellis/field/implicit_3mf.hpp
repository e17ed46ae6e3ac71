// Designs in 3MF packages of the Volumetric & Implicit Extension v1.0 (3MF Consortium,
// spec_volumetric): an object shaped by a <levelset> (Part I §4.1.1) over an <i:implicitfunction>
// (Part II ch. 3), a graph of native nodes (Part II ch. 5) evaluated at positions. The graph is
// compiled into one field node of the kernel (no mesh is made), clipped to the levelset's mesh
// (its bounding box, or the mesh itself unless meshbboxonly), so a design written by another
// implicit modeller slices on every field route like a .vcad.
//
// Read: every native node (mesh/unsignedmesh through the kernel's distance field of the mesh),
// volumetric image stacks (<functionfromimage3d> over an <image3d> of PNG sheets, Part I ch.
// 2-3), objects made of components, mesh objects beside level sets (their distance fields);
// also the 2022 draft's <v:function> and <volumedata><boundary> (the 3MF Consortium's sample
// ImplicitGyroid.3mf). Anything else is refused by name with the part, line and column. A 3MF
// whose objects are all meshes is not one.
#pragma once
#include <string>

#include "trellis/field/vcad.hpp"

namespace trellis {

// Whether `path` is a 3MF package whose build places an object shaped by a level set. False for
// a mesh 3MF and for anything that is not a 3MF package (those go to the mesh reader and its
// errors).
bool is_implicit_3mf(const std::string& path);

// The design of such a package (every build item's object, united; VcadDesign::has_root with
// the box of the clipping meshes). Throws ParseError naming the file, part, line and column of
// the first problem: malformed XML, a reference to nothing, a type mismatch, a cycle, or a node
// or function type it does not read (named).
VcadDesign read_implicit_3mf(const std::string& path, const VcadOptions& options = {});

// What the field routes read: a .vcad, or a 3MF implicit design (chosen by content).
bool is_field_design(const std::string& path);
VcadDesign read_field_design(const std::string& path, const VcadOptions& options = {});

}  // namespace trellis
