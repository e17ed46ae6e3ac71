// The 3MF toolpath module's table (src/core/module.hpp): libzip and expat load only when a 3MF
// toolpath is written or read. The names and URIs both halves share are here.
#pragma once
#include <string>

#include "../core/module.hpp"
#include "trellis/machine/toolpath_3mf.hpp"

namespace trellis {

namespace tp3mf {
// Toolpath Extension v1.0, Appendix C.
constexpr const char* kNamespace = "http://schemas.3mf.io/3dmanufacturing/toolpath/2026/03";
constexpr const char* kLayerRelationship =
    "http://schemas.3mf.io/3dmanufacturing/toolpath/2026/03/layer";
// Appendix C: the drafts' URIs, still read.
constexpr const char* kOldNamespace =
    "http://schemas.microsoft.com/3dmanufacturing/toolpath/2019/05";
constexpr const char* kOldLayerRelationship =
    "http://schemas.microsoft.com/3dmanufacturing/2019/05/toolpath";
constexpr const char* kCore = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";
constexpr const char* kProduction =
    "http://schemas.microsoft.com/3dmanufacturing/production/2015/06";
constexpr const char* kModelRelationship =
    "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel";
// What the extension has no attribute for (§2.3: namespaced profile attributes; §4.4
// toolpathdata): path roles, tools, process values, planned travel, the job and part labels.
constexpr const char* kTrellis = "urn:trellis:3mf-toolpath:2026-11";
// 10 nm: the .cli's resolution (machine/cli.hpp), so both files carry the same coordinates.
constexpr double kUnitFactor = 1e-5;
}  // namespace tp3mf

namespace impl {
std::string write_toolpath_3mf(const Toolpath& toolpath, const Toolpath3mfOptions& options);
Toolpath read_toolpath_3mf_file(const std::string& path, Diagnostics* diag);
Toolpath3mfKind toolpath_3mf_kind(const std::string& path);
}  // namespace impl

struct Toolpath3mfModule {
  detail::ModuleHeader header;
  std::string (*write)(const Toolpath&, const Toolpath3mfOptions&);
  Toolpath (*read)(const std::string&, Diagnostics*);
  Toolpath3mfKind (*kind)(const std::string&);
};

}  // namespace trellis
