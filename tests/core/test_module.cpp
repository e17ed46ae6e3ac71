// The run-time module loader (src/core/module.hpp): search order and its errors.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <fstream>

#include "../../src/core/module.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/atlas.hpp"

using namespace trellis;

TEST(Module, MissingModuleIsAnErrorNamingEveryPathTried) {
  const test::TempDir dir("trellis_modules");
  ::setenv("TRELLIS_MODULE_DIR", dir.path().c_str(), 1);
  try {
    detail::load_module("no_such_thing", 16);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(dir.file("trellis_no_such_thing.so")), std::string::npos) << m;
    EXPECT_NE(m.find("/trellis/trellis_no_such_thing.so"), std::string::npos) << m;
    EXPECT_NE(m.find("TRELLIS_MODULE_DIR"), std::string::npos) << m;
  }
  ::unsetenv("TRELLIS_MODULE_DIR");
}

TEST(Module, ABrokenModuleInTheEnvironmentFolderFallsBackToTheLibraryFolder) {
  const test::TempDir dir("trellis_modules");
  std::ofstream(dir.file("trellis_cgal.so")) << "not a shared object";
  ::setenv("TRELLIS_MODULE_DIR", dir.path().c_str(), 1);
  AtlasParams a;
  a.pattern = Pattern::Voronoi;
  a.region.width = a.region.height = 10;
  EXPECT_FALSE(make_lattice2d(a).edges.empty());
  ::unsetenv("TRELLIS_MODULE_DIR");
}
