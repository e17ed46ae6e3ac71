// The 3MF module's table (src/core/module.hpp): read_3mf returns the stored triangles with build
// transforms and the model unit applied (millimetres), not yet welded or checked.
#pragma once
#include <string>
#include <vector>

#include "../core/module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"

namespace trellis {

// Where a package lib3mf refused is broken (src/geom/locate_3mf.cpp): `where` names the part and
// line/column ("3D/3dmodel.model line 12, column 40"), `what` the problem; `what` is empty when
// nothing could be placed.
struct Located3mf {
  std::string where, what;
};

namespace impl {
Located3mf locate_3mf_problem(const std::string& path);
std::vector<unsigned char> package_without_dangling_relationships(const std::string& path);
}  // namespace impl

struct Mesh3mfModule {
  detail::ModuleHeader header;
  TriangleMesh (*read_3mf)(const std::string&);
  void (*write_3mf)(const std::string&, const TriangleMesh&, const std::string& unit);
  Located3mf (*locate)(const std::string&);
};

}  // namespace trellis
