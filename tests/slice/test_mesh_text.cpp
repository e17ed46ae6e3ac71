// ASCII STL and OBJ vertices are read by std::from_chars with sscanf as the fallback: every line
// must read as sscanf("%lf %lf %lf") reads it (the parsers' only reader before), on random
// number spellings: signs, exponents, '+', tabs, hex, inf/nan, overflow, underflow, junk.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"

using namespace trellis;

namespace {

std::string random_number(std::mt19937& rng) {
  static const char* special[] = {
      "inf", "-inf", "nan", "0x1p3", "1e400", "-1e400", "1e-400",      "4.9e-324",
      "abc", "",     "+-1", "++1",   "-+1",   "1e",     "1e+",         ".",
      "-.5", "5.",   "1,5", "0",     "-0",    "1e5x",   "999999.9999", "1000000.0000001",
      "1e6", "-1e6"};
  if (rng() % 6 == 0) return special[rng() % std::size(special)];
  std::string s;
  switch (rng() % 4) {
    case 0:
      s += '-';
      break;
    case 1:
      s += '+';
      break;
    default:
      break;
  }
  auto digits = [&](int n) {
    std::string d;
    for (int i = 0; i < n; ++i) d += static_cast<char>('0' + rng() % 10);
    return d;
  };
  switch (rng() % 4) {
    case 0:
      s += digits(1 + static_cast<int>(rng() % 7));
      break;
    case 1:
      s += digits(1 + static_cast<int>(rng() % 4)) + ".";
      break;
    case 2:
      s += "." + digits(1 + static_cast<int>(rng() % 12));
      break;
    default:
      s += digits(1 + static_cast<int>(rng() % 4)) + "." + digits(1 + static_cast<int>(rng() % 17));
  }
  if (rng() % 3 == 0) {
    s += rng() % 2 ? 'e' : 'E';
    if (rng() % 2) s += rng() % 2 ? '-' : '+';
    s += digits(1 + static_cast<int>(rng() % 2));
  }
  return s;
}

std::string blank(std::mt19937& rng) {
  static const char* b[] = {" ", "  ", "\t", " \t ", "\v", "\f"};
  return b[rng() % std::size(b)];
}

// sscanf's reading of `numbers` (the old parsers), or false when it does not find three.
bool oracle(const std::string& numbers, bool whole, Vec3& out) {
  double x, y, z;
  char extra;
  const int n = whole ? std::sscanf(numbers.c_str(), "%lf %lf %lf %c", &x, &y, &z, &extra)
                      : std::sscanf(numbers.c_str(), "%lf %lf %lf", &x, &y, &z);
  out = {x, y, z};
  return n == 3;
}

bool valid(const Vec3& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::abs(p.x) <= 1e6 &&
         std::abs(p.y) <= 1e6 && std::abs(p.z) <= 1e6;
}

bool same_value(double a, double b) {
  return a == b;
}  // -0 == +0 (the weld makes them 0)

}  // namespace

TEST(MeshText, VerticesReadAsSscanfReadsThem) {
  std::mt19937 rng(40);
  int read = 0, refused = 0;
  for (int round = 0; round < 20000; ++round) {
    std::string numbers = blank(rng) + random_number(rng) + blank(rng) + random_number(rng) +
                          blank(rng) + random_number(rng);
    if (rng() % 5 == 0) numbers += rng() % 2 ? " x" : "  ";
    const bool stl = round % 2 == 0;
    Vec3 expected;
    const bool ok = oracle(numbers, stl, expected);
    // The vertex under test first (vertex 0 of the welded mesh), then two fixed ones.
    const std::string text =
        stl ? "solid t\nfacet normal 0 0 1\nouter loop\nvertex" + numbers +
                  "\nvertex 123456.5 7 8\nvertex 9 123456.25 10\nendloop\nendfacet\nendsolid t\n"
            : "v " + numbers + "\nv 123456.5 7 8\nv 9 123456.25 10\nf 1 2 3\n";
    const std::string what = (stl ? "STL vertex" : "OBJ v") + numbers;
    if (!ok || !valid(expected)) {
      EXPECT_THROW(stl ? parse_stl(text, "t.stl") : parse_obj(text, "t.obj"), ParseError) << what;
      ++refused;
      continue;
    }
    if (expected.x == 123456.5 || expected.x == 9) continue;  // could weld with a fixed vertex
    TriangleMesh m;
    try {
      m = stl ? parse_stl(text, "t.stl") : parse_obj(text, "t.obj");
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": " << e.what();
      continue;
    }
    ASSERT_EQ(m.vertices.size(), 3u) << what;
    EXPECT_TRUE(same_value(m.vertices[0].x, expected.x) &&
                same_value(m.vertices[0].y, expected.y) && same_value(m.vertices[0].z, expected.z))
        << what << " read as " << m.vertices[0].x << " " << m.vertices[0].y << " "
        << m.vertices[0].z;
    ++read;
  }
  // Both kinds occur often enough to mean something.
  EXPECT_GT(read, 2000);
  EXPECT_GT(refused, 2000);
}

// OBJ face indices are read by std::from_chars, with strtol (the reader before) for anything but
// plain [-]digits: every face line reads as strtol reads it — the same triangle, or an error
// either way — on random spellings: '+', tabs, relative (negative) indices, overflow, /vt/vn,
// junk after the number.
TEST(MeshText, FaceIndicesReadAsStrtolReadsThem) {
  std::mt19937 rng(47);
  static const char* odd[] = {"+2",
                              "\t3",
                              "-1",
                              "-4",
                              "0",
                              "99999999999999999999",
                              "-99999999999999999999",
                              "2x",
                              "3/1/1",
                              "1//2",
                              "+-1",
                              "-",
                              "4.0",
                              "0x2",
                              "\v1"};
  auto token = [&] {
    return rng() % 3 ? std::to_string(1 + rng() % 4) : std::string(odd[rng() % std::size(odd)]);
  };
  int read = 0, refused = 0;
  for (int round = 0; round < 4000; ++round) {
    std::vector<std::string> tokens = {token(), token(), token()};
    // The old reading: strtol on the rest of the line, stopping at '\0', ' ' or '/'.
    std::vector<long> expected;
    bool ok = true;
    for (const std::string& t : tokens) {
      char* stop = nullptr;
      const long v = std::strtol(t.c_str(), &stop, 10);
      const long i = v < 0 ? 4 + v : v - 1;
      if (stop == t.c_str() || (*stop != '\0' && *stop != '/') || i < 0 || i >= 4) ok = false;
      expected.push_back(i);
    }
    ok = ok && expected[0] != expected[1] && expected[1] != expected[2] &&
         expected[0] != expected[2];
    const std::string face = "f " + tokens[0] + " " + tokens[1] + " " + tokens[2];
    const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n" + face + "\n";
    if (!ok) {
      EXPECT_THROW(parse_obj(text, "t.obj"), ParseError) << face;
      ++refused;
      continue;
    }
    const TriangleMesh m = parse_obj(text, "t.obj");
    ASSERT_EQ(m.triangles.size(), 1u) << face;
    // Vertices are numbered in order of first use: compare the points, not the numbers.
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = m.vertices[m.triangles[0][k]];
      const long i = expected[k];
      EXPECT_TRUE(p.x == (i == 1) && p.y == (i == 2) && p.z == (i == 3)) << face;
    }
    ++read;
  }
  EXPECT_GT(read, 500);
  EXPECT_GT(refused, 500);
}
