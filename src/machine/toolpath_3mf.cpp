// The 3MF toolpath functions of libtrellis: the work is in the toolpath3mf module (libzip and
// expat), loaded on first use (src/core/module.hpp).
#include "trellis/machine/toolpath_3mf.hpp"

#include "toolpath_3mf_module.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

namespace {
const Toolpath3mfModule& module() {
  return detail::module_table<Toolpath3mfModule>("toolpath3mf");
}
}  // namespace

Vec3 apply_transform(const Transform3mf& m, const Vec3& p) {
  return {p.x * m[0] + p.y * m[3] + p.z * m[6] + m[9], p.x * m[1] + p.y * m[4] + p.z * m[7] + m[10],
          p.x * m[2] + p.y * m[5] + p.z * m[8] + m[11]};
}

std::string write_toolpath_3mf(const Toolpath& toolpath, const Toolpath3mfOptions& options) {
  return module().write(toolpath, options);
}

void write_toolpath_3mf_file(const std::string& path, const Toolpath& toolpath,
                             const Toolpath3mfOptions& options) {
  write_file_atomic(path, write_toolpath_3mf(toolpath, options));
}

Toolpath read_toolpath_3mf_file(const std::string& path, Diagnostics* diag) {
  return module().read(path, diag);
}

Toolpath3mfKind toolpath_3mf_kind(const std::string& path) {
  return module().kind(path);
}

}  // namespace trellis
