// The binary STL reader welds the file's float corners directly (12 bytes a corner): the mesh
// must be the one weld_corners makes from the same corners as doubles (same vertices in the
// same order, same triangles), with -0 and +0 one vertex, on any thread count; and the first
// invalid coordinate (lowest triangle) is the one reported.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>

#include "../support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/geom/mesh_io.hpp"

using namespace trellis;

namespace {

// A binary STL of `corners` (3 per triangle).
std::string binary_stl(const std::vector<std::array<float, 3>>& corners) {
  std::string s(80, ' ');
  const std::uint32_t n = static_cast<std::uint32_t>(corners.size() / 3);
  s.append(reinterpret_cast<const char*>(&n), 4);
  for (std::size_t t = 0; t < n; ++t) {
    const float normal[3] = {0, 0, 1};
    s.append(reinterpret_cast<const char*>(normal), 12);
    for (int k = 0; k < 3; ++k)
      s.append(reinterpret_cast<const char*>(corners[3 * t + k].data()), 12);
    s.append(2, '\0');
  }
  return s;
}

// Corners drawn from a small pool (so most are shared), with -0 for some zeros and some
// triangles degenerate (a corner repeated).
std::vector<std::array<float, 3>> random_corners(std::mt19937& rng, std::size_t triangles,
                                                 std::size_t pool_size) {
  std::uniform_real_distribution<float> coord(-50, 50);
  std::vector<std::array<float, 3>> pool(pool_size);
  for (auto& p : pool) p = {coord(rng), coord(rng), rng() % 5 == 0 ? 0.0f : coord(rng)};
  std::vector<std::array<float, 3>> corners;
  for (std::size_t t = 0; t < 3 * triangles; ++t) {
    std::array<float, 3> p = pool[rng() % pool.size()];
    if (p[2] == 0 && rng() % 2) p[2] = -0.0f;
    corners.push_back(p);
  }
  return corners;
}

}  // namespace

TEST(MeshWeld, BinaryStlWeldsAsWeldCorners) {
  std::mt19937 rng(40);
  for (int round = 0; round < 40; ++round) {
    const std::size_t triangles = 1 + rng() % (round < 30 ? 2000 : 200000);
    const auto corners = random_corners(rng, triangles, 1 + triangles / 2);
    std::vector<Vec3> doubles;
    for (const auto& c : corners) doubles.push_back({c[0], c[1], c[2]});
    const TriangleMesh expected = weld_corners(doubles);
    if (expected.triangles.empty()) continue;
    const std::string bytes = binary_stl(corners);
    for (const std::size_t threads : {1u, 2u}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const TriangleMesh m = parse_stl(bytes, "r.stl");
      ASSERT_EQ(m.vertices.size(), expected.vertices.size()) << round;
      ASSERT_EQ(m.triangles, expected.triangles) << round;
      for (std::size_t i = 0; i < m.vertices.size(); ++i) {
        ASSERT_EQ(std::memcmp(&m.vertices[i], &expected.vertices[i], sizeof(Vec3)), 0)
            << round << " vertex " << i;
        ASSERT_FALSE(std::signbit(m.vertices[i].z) && m.vertices[i].z == 0) << "-0 kept";
      }
    }
  }
}

// Corners in a mesh's file order, where neighbouring triangles share corners (the weld finds
// those in the previous triangle without hashing): strips of a grid on a few heights, some
// corners -0 where another is +0, some triangles repeated, flipped, degenerate or moved to
// another place: the same mesh as weld_corners makes, on 1 and 2 threads.
TEST(MeshWeld, BinaryStlInStripOrderWeldsAsWeldCorners) {
  std::mt19937 rng(29);
  for (int round = 0; round < 30; ++round) {
    const int nu = 2 + static_cast<int>(rng() % (round < 20 ? 40 : 400));
    const int nv = 2 + static_cast<int>(rng() % 60);
    auto at = [&](int i, int j) {
      std::array<float, 3> p{static_cast<float>(i % 7) * 0.5f, static_cast<float>(j % 5),
                             static_cast<float>((i + j) % 3) - 1.0f};
      if (p[0] == 0 && rng() % 2) p[0] = -0.0f;
      if (p[2] == 0 && rng() % 2) p[2] = -0.0f;
      return p;
    };
    std::vector<std::array<float, 3>> corners;
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j) {
        corners.insert(corners.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
        corners.insert(corners.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        switch (rng() % 16) {
          case 0:  // the last triangle again
            corners.insert(corners.end(), corners.end() - 3, corners.end());
            break;
          case 1:  // flipped
            std::swap(corners[corners.size() - 1], corners[corners.size() - 2]);
            break;
          case 2:  // degenerate: a corner of the previous triangle twice
            corners.insert(corners.end(), {at(i, j), at(i, j), at(i + 1, j + 1)});
            break;
          case 3: {  // a triangle from elsewhere
            const std::size_t t = rng() % (corners.size() / 3);
            corners.insert(corners.end(), corners.begin() + static_cast<long>(3 * t),
                           corners.begin() + static_cast<long>(3 * t + 3));
            break;
          }
          default:
            break;
        }
      }
    std::vector<Vec3> doubles;
    for (const auto& c : corners) doubles.push_back({c[0], c[1], c[2]});
    const TriangleMesh expected = weld_corners(doubles);
    if (expected.triangles.empty()) continue;
    const std::string bytes = binary_stl(corners);
    for (const std::size_t threads : {1u, 2u}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const TriangleMesh m = parse_stl(bytes, "strips.stl");
      ASSERT_EQ(m.triangles, expected.triangles) << round;
      ASSERT_EQ(m.vertices.size(), expected.vertices.size()) << round;
      ASSERT_EQ(std::memcmp(m.vertices.data(), expected.vertices.data(),
                            m.vertices.size() * sizeof(Vec3)),
                0)
          << round;
    }
  }
}

// read_stl reads a binary STL in pieces (never whole) into the weld: the same mesh as parse_stl
// of the file's bytes, over several pieces and on 1 and 2 threads; the same first invalid
// coordinate; a file that shrinks under the reader is an IoError naming it.
TEST(MeshWeld, BinaryStlFileReadInPiecesAsFromMemory) {
  std::mt19937 rng(41);
  test::TempDir dir;
  const std::string path = dir.file("r.stl");
  for (const std::size_t triangles : {1u, 16383u, 16384u, 16385u, 70001u}) {
    auto corners = random_corners(rng, triangles, 1 + triangles / 2);
    corners[0] = {1, 2, 3};  // not degenerate: the mesh is never empty
    corners[1] = {4, 5, 6};
    corners[2] = {7, 8, 9};
    const std::string bytes = binary_stl(corners);
    write_file_atomic(path, bytes);
    const TriangleMesh expected = parse_stl(bytes, "r.stl");
    for (const std::size_t threads : {1u, 2u}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const TriangleMesh m = read_mesh(path);
      ASSERT_EQ(m.triangles, expected.triangles) << triangles;
      ASSERT_EQ(m.vertices.size(), expected.vertices.size()) << triangles;
      ASSERT_EQ(std::memcmp(m.vertices.data(), expected.vertices.data(),
                            m.vertices.size() * sizeof(Vec3)),
                0)
          << triangles;
    }
  }
  auto corners = random_corners(rng, 40000, 20000);
  corners[3 * 33333 + 1][2] = std::numeric_limits<float>::infinity();
  write_file_atomic(path, binary_stl(corners));
  try {
    read_mesh(path);
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 33333"), std::string::npos) << e.what();
  }
  const InputFile file(path);
  char piece[100];
  file.read_at(file.size() - 100, piece, 100);
  std::filesystem::resize_file(path, file.size() - 50);
  EXPECT_THROW(file.read_at(file.size() - 100, piece, 100), IoError);
  EXPECT_THROW(read_mesh(path), ParseError);  // 50 bytes short: not a binary STL any more
  // Only regular files: a FIFO (which nobody writes) is refused at once, not waited on.
  const std::string fifo = dir.file("fifo.stl");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_THROW(read_mesh(fifo), IoError);
  EXPECT_THROW(read_mesh(dir.path().string() + "/missing.stl"), IoError);
}

TEST(MeshWeld, FirstInvalidCoordinateIsReported) {
  std::mt19937 rng(7);
  auto corners = random_corners(rng, 50000, 20000);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  corners[3 * 41000 + 1][0] = inf;
  corners[3 * 30123 + 2][1] = 2e6f;
  corners[3 * 45000][2] = nan;
  try {
    parse_stl(binary_stl(corners), "bad.stl");
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 30123"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.stl"), std::string::npos) << e.what();
  }
  corners[3 * 30123 + 2][1] = 1e6f;  // on the limit: valid
  corners[3 * 41000 + 1][0] = 0;
  try {
    parse_stl(binary_stl(corners), "bad.stl");
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 45000"), std::string::npos) << e.what();
  }
}

// OBJ (and weld(), the 3MF reader's) welds its vertex list, not the corners: the same mesh as
// weld_corners on the corners' coordinates, with repeated and unused vertices, -0, polygons (fans)
// and degenerate faces.
TEST(MeshWeld, ObjWeldsAsWeldCorners) {
  std::mt19937 rng(46);
  for (int round = 0; round < 60; ++round) {
    const std::size_t points = 3 + rng() % (round < 50 ? 300 : 30000);
    std::vector<Vec3> v;
    std::string text;
    for (std::size_t i = 0; i < points; ++i) {
      // Coordinates from a small set so that points repeat; zeros with either sign.
      auto c = [&] { return static_cast<double>(static_cast<int>(rng() % 7) - 3) * 0.5; };
      Vec3 p{c(), c(), c()};
      if (p.z == 0 && rng() % 2) p.z = -0.0;
      v.push_back(p);
      char line[128];
      std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x, p.y, p.z);
      text += line;
    }
    std::vector<Vec3> corners;
    const std::size_t faces = 1 + rng() % (3 * points);
    for (std::size_t f = 0; f < faces; ++f) {
      const std::size_t n = 3 + (rng() % 4 == 0 ? rng() % 3 : 0);
      std::vector<std::size_t> idx;
      for (std::size_t k = 0; k < n; ++k) idx.push_back(rng() % points);
      text += "f";
      for (const std::size_t i : idx)
        text += " " + std::to_string(i + 1) + (rng() % 3 ? "" : "/1/1");
      text += "\n";
      for (std::size_t k = 1; k + 1 < n; ++k)
        corners.insert(corners.end(), {v[idx[0]], v[idx[k]], v[idx[k + 1]]});
    }
    const TriangleMesh expected = weld_corners(corners);
    if (expected.triangles.empty()) continue;
    // weld() of an indexed mesh (the 3MF reader's) welds the same way.
    TriangleMesh indexed;
    indexed.vertices = corners;
    for (std::uint32_t i = 0; i + 2 < corners.size(); i += 3)
      indexed.triangles.push_back({i, i + 1, i + 2});
    const TriangleMesh welded = weld(indexed);
    ASSERT_EQ(welded.triangles, expected.triangles) << round;
    ASSERT_EQ(welded.vertices.size(), expected.vertices.size()) << round;
    for (std::size_t i = 0; i < welded.vertices.size(); ++i)
      ASSERT_EQ(std::memcmp(&welded.vertices[i], &expected.vertices[i], sizeof(Vec3)), 0) << round;
    for (const std::size_t threads : {1u, 2u}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const TriangleMesh m = parse_obj(text, "r.obj");
      ASSERT_EQ(m.triangles, expected.triangles) << round;
      ASSERT_EQ(m.vertices.size(), expected.vertices.size()) << round;
      for (std::size_t i = 0; i < m.vertices.size(); ++i)
        ASSERT_EQ(std::memcmp(&m.vertices[i], &expected.vertices[i], sizeof(Vec3)), 0)
            << round << " vertex " << i;
    }
  }
}
