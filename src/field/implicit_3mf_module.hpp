// The implicit3mf module's table (src/core/module.hpp): 3MF level-set designs (libzip, expat).
#pragma once
#include "../core/module.hpp"
#include "trellis/field/implicit_3mf.hpp"

namespace trellis {

struct Implicit3mfModule {
  detail::ModuleHeader header;
  bool (*is_implicit)(const std::string&);
  VcadDesign (*read)(const std::string&, const VcadOptions&);
};

}  // namespace trellis
