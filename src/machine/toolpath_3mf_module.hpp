// The 3MF toolpath module's table (src/core/module.hpp): libzip and expat load only when a 3MF
// toolpath is written or read. The names and URIs both halves share are here.
#pragma once
#include <fmt/format.h>

#include <cstdint>
#include <set>
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
// Shortest text that reads back to the same double (matches ST_Number, Appendix B.2).
inline std::string num(double v) {
  return fmt::format("{}", v);
}

// A UUID made from a name (stable run to run, so the same toolpath is the same file): 128 bits
// of two FNV-1a hashes, marked as a version-5 (name-based) UUID.
inline std::string uuid_of(const std::string& name) {
  auto fnv = [&](std::uint64_t h) {
    for (unsigned char c : name) h = (h ^ c) * 0x100000001b3ULL;
    return h ^ (h >> 29);
  };
  std::uint64_t a = fnv(0xcbf29ce484222325ULL), b = fnv(0x84222325cbf29ce4ULL);
  a = (a & ~0xf000ULL) | 0x5000ULL;                         // version 5
  b = (b & 0x3fffffffffffffffULL) | 0x8000000000000000ULL;  // RFC 4122 variant
  return fmt::format("{:08x}-{:04x}-{:04x}-{:04x}-{:012x}", a >> 32, (a >> 16) & 0xffff, a & 0xffff,
                     b >> 48, b & 0xffffffffffffULL);
}

// `text`: element content, where line breaks stay as they are.
inline void escape_to(std::string& out, std::string_view s, bool text = false) {
  for (char c : s) {
    if (text && c == '\n') {
      out += c;
      continue;
    }
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\n':
        out += "&#10;";
        break;
      case '\r':
        out += "&#13;";
        break;
      case '\t':
        out += "&#9;";
        break;
      default:
        // Other control characters are not XML 1.0 characters at all: dropped.
        if (static_cast<unsigned char>(c) >= 0x20) out += c;
    }
  }
}

inline std::string esc(std::string_view s) {
  std::string out;
  escape_to(out, s);
  return out;
}

// Beam Lattice Extension v1.2, Appendix C.
constexpr const char* kBeamLattice =
    "http://schemas.microsoft.com/3dmanufacturing/beamlattice/2017/02";
}  // namespace tp3mf

namespace impl {
std::string write_toolpath_3mf(const Toolpath& toolpath, const Toolpath3mfOptions& options);
Toolpath read_toolpath_3mf_file(const std::string& path, Diagnostics* diag);
Toolpath3mfKind toolpath_3mf_kind(const std::string& path);

// The model part's geometry (toolpath_3mf_geometry.cpp): an <object> per part with geometry,
// from resource id 2, and a build <item> per part carrying its UUID (`part_uuids`, index
// Path::part), so every part a layer names is a build item of the package (Part II §1.1.1).
struct Geometry3mf {
  std::string objects, items;
  bool beams = false;  // a beam lattice is written: the "b" extension is required
};
Geometry3mf geometry_xml(const Toolpath& toolpath, const Toolpath3mfOptions& options,
                         const std::vector<std::string>& part_uuids, const std::set<int>& parts);
}  // namespace impl

struct Toolpath3mfModule {
  detail::ModuleHeader header;
  std::string (*write)(const Toolpath&, const Toolpath3mfOptions&);
  Toolpath (*read)(const std::string&, Diagnostics*);
  Toolpath3mfKind (*kind)(const std::string&);
};

}  // namespace trellis
