// The 3MF implicit-design functions of libtrellis: the work is in the implicit3mf module (libzip
// and expat), loaded on first use (src/core/module.hpp).
#include "trellis/field/implicit_3mf.hpp"

#include <cctype>

#include "implicit_3mf_module.hpp"

namespace trellis {

namespace {
const Implicit3mfModule& module() {
  return detail::module_table<Implicit3mfModule>("implicit3mf");
}
bool ends_with_ci(const std::string& s, const char* suffix) {
  const std::string t(suffix);
  if (s.size() < t.size()) return false;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - t.size() + i])) != t[i]) return false;
  return true;
}
}  // namespace

bool is_implicit_3mf(const std::string& path) {
  return ends_with_ci(path, ".3mf") && module().is_implicit(path);
}

VcadDesign read_implicit_3mf(const std::string& path, const VcadOptions& options) {
  return module().read(path, options);
}

bool is_field_design(const std::string& path) {
  return ends_with_ci(path, ".vcad") || is_implicit_3mf(path);
}

VcadDesign read_field_design(const std::string& path, const VcadOptions& options) {
  if (ends_with_ci(path, ".vcad")) return read_vcad(path, options);
  return read_implicit_3mf(path, options);
}

}  // namespace trellis
