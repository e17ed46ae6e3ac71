// Reading a 3MF mesh with one thread and with two (our located walk of the model, then lib3mf's
// reading): the same mesh, or the same error, with either. Generated packages: random
// boxes (meshes of known volume), some with one damage our walk places (a coordinate lib3mf
// reads as 0, an index beyond the mesh, an unknown unit, a tag that does not close, an item
// naming no object), some that lib3mf alone refuses (no build, no objects), and non-ZIP bytes.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "support/implicit_3mf.hpp"
#include "support/same_mesh.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"

using namespace trellis;

namespace {

// What read_mesh gives: the mesh's vertices and triangles, or the error's type and message.
struct Outcome {
  bool read = false;
  std::string error;
  TriangleMesh mesh;
};

Outcome read_with(const std::string& path, std::size_t threads) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  Outcome o;
  try {
    o.mesh = read_mesh(path);
    o.read = true;
  } catch (const ParseError& e) {
    o.error = std::string("ParseError: ") + e.what();
  } catch (const Error& e) {
    o.error = std::string("Error: ") + e.what();
  }
  return o;
}

using test::same_mesh;

const char* const kCore = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";

}  // namespace

TEST(Mesh3mfRead, OneAndTwoThreadsGiveTheSameMeshOrTheSameError) {
  const trellis::test::TempDir dir("trellis_mesh_3mf_read");
  std::mt19937 rng(40);
  std::uniform_real_distribution<double> coord(-50, 50), size(1, 30);
  int meshes = 0, walk_errors = 0, lib3mf_errors = 0;
  for (int round = 0; round < 60; ++round) {
    const int objects = 1 + round % 3;
    double expected_volume = 0;
    std::string resources, build;
    for (int k = 1; k <= objects; ++k) {
      const std::array<double, 3> lo{coord(rng), coord(rng), coord(rng)};
      const std::array<double, 3> d{size(rng), size(rng), size(rng)};
      // The box is written with %.17g: lib3mf keeps floats, so the volume is compared loosely.
      resources += "<object id=\"" + std::to_string(k) + "\" type=\"model\">" +
                   trellis::test::box_mesh(lo, {lo[0] + d[0], lo[1] + d[1], lo[2] + d[2]}) +
                   "</object>\n";
      build += "<item objectid=\"" + std::to_string(k) + "\"/>\n";
      expected_volume += d[0] * d[1] * d[2];
    }
    std::string unit = "millimeter";
    const int damage = round % 8;  // 0, 1: none
    std::string expect;            // what the error says (walk or lib3mf)
    if (damage == 2) {             // lib3mf reads "zz" as 0; the walk refuses it
      resources.replace(resources.find("x=\"", resources.find("<vertex")) + 3, 1, "zz");
      expect = "is not a finite number";
    } else if (damage == 3) {  // a triangle's index beyond its mesh
      const std::size_t at = resources.find("v3=\"", resources.find("<triangle"));
      resources.replace(at + 4, 1, "99");
      expect = "refers to vertex 99";
    } else if (damage == 4) {
      unit = "furlong";
      expect = "unknown model unit";
    } else if (damage == 5) {  // a <mesh> left open
      resources.erase(resources.find("</mesh>"), 7);
      expect = "malformed XML";
    } else if (damage == 6) {  // an item naming an object the model lacks
      build += "<item objectid=\"77\"/>\n";
      expect = "refers to object 77";
    } else if (damage == 7) {  // no objects at all: the walk is content, lib3mf reads no mesh
      resources.clear();
      build.clear();
      expect = "3MF has no mesh triangles";
    }
    const std::string model = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<model unit=\"" + unit +
                              "\" xml:lang=\"en-US\" xmlns=\"" + kCore + "\">\n<resources>\n" +
                              resources + "</resources>\n<build>\n" + build +
                              "</build>\n</model>\n";
    const std::string path = dir.path().string() + "/m" + std::to_string(round) + ".3mf";
    trellis::test::write_3mf(path, model);
    const Outcome one = read_with(path, 1), two = read_with(path, 2);
    SCOPED_TRACE("round " + std::to_string(round) + ": " + one.error);
    EXPECT_EQ(one.read, two.read);
    EXPECT_EQ(one.error, two.error);
    if (expect.empty()) {
      ASSERT_TRUE(one.read && two.read);
      EXPECT_TRUE(same_mesh(one.mesh, two.mesh));
      EXPECT_EQ(one.mesh.triangles.size(), 12u * objects);
      EXPECT_TRUE(check_mesh(one.mesh).closed());
      EXPECT_NEAR(volume(one.mesh), expected_volume, 1e-4 * expected_volume);
      ++meshes;
    } else {
      EXPECT_FALSE(one.read || two.read);
      EXPECT_NE(one.error.find(expect), std::string::npos);
      EXPECT_NE(one.error.find(path), std::string::npos);  // the error names the file
      (damage == 7 ? lib3mf_errors : walk_errors)++;
    }
  }
  EXPECT_GT(meshes, 10);
  EXPECT_GT(walk_errors, 10);
  EXPECT_GT(lib3mf_errors, 3);
}

// Bytes that are not a ZIP package are refused by our walk alone (lib3mf 1.8 leaks its ZIP
// source when it refuses one), with one thread or two.
TEST(Mesh3mfRead, NotAZipIsRefusedTheSameWayWithOneOrTwoThreads) {
  const trellis::test::TempDir dir("trellis_mesh_3mf_notzip");
  std::mt19937 rng(41);
  for (int round = 0; round < 8; ++round) {
    std::string bytes(static_cast<std::size_t>(1 + 97 * round), '\0');
    for (char& c : bytes) c = static_cast<char>(rng());
    const std::string path = dir.path().string() + "/n" + std::to_string(round) + ".3mf";
    std::ofstream(path, std::ios::binary) << bytes;
    const Outcome one = read_with(path, 1), two = read_with(path, 2);
    EXPECT_FALSE(one.read || two.read);
    EXPECT_EQ(one.error, two.error);
    EXPECT_NE(one.error.find("not a ZIP package"), std::string::npos) << one.error;
  }
}
