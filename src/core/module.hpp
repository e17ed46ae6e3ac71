// Heavy dependencies live in run-time modules that libtrellis loads the first time one of their
// functions is called: OpenVDB (mesh <-> distance field), CGAL (Voronoi), cairo (PNG previews),
// lib3mf (3MF files). A program that never uses them, `trellis --version` included, does not
// load their ~40 shared libraries or resolve their ~70,000 relocations at start-up.
//
// A module `name` is the file trellis_<name>.so exporting `extern "C" const ModuleHeader*
// trellis_module_<name>()`, which returns a static table of function pointers that starts with
// a ModuleHeader. It is searched in $TRELLIS_MODULE_DIR if set, then in the folder `trellis`
// next to libtrellis itself (build tree: build/<preset>/src/trellis; installed:
// <prefix>/<libdir>/trellis), so a build tree and any install prefix work without settings.
#pragma once
#include <cstddef>
#include <string>

#include "trellis/version.hpp"

namespace trellis::detail {

struct ModuleHeader {
  const char* version;  // TRELLIS_VERSION the module was built with
  std::size_t size;     // sizeof its table, a guard against a stale module of another build
};

// Loads module `name` once per process (thread-safe) and checks its header. Throws trellis::Error
// naming every path tried and why each failed.
const ModuleHeader& load_module(const std::string& name, std::size_t table_size);

// The module's table of functions, typed: Table starts with a ModuleHeader member `header`.
template <class Table>
const Table& module_table(const std::string& name) {
  return reinterpret_cast<const Table&>(load_module(name, sizeof(Table)));
}

}  // namespace trellis::detail

// Defines a module's entry point (in the module's one .cpp): returns `table`.
#define TRELLIS_MODULE_ENTRY(name, Table, ...)                               \
  extern "C" __attribute__((visibility("default")))                          \
  const ::trellis::detail::ModuleHeader* trellis_module_##name() {           \
    static const Table table{{TRELLIS_VERSION, sizeof(Table)}, __VA_ARGS__}; \
    return &table.header;                                                    \
  }
