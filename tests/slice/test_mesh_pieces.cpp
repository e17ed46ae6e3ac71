// A large ASCII STL or OBJ is read in pieces in parallel (split at line starts, each ASCII STL
// piece welded on its own, then joined). Reading a text in pieces of any size must give what
// reading it line after line gives: the same vertices (bytes, order), the same triangles, or the
// same error (type and message, which names the line) — on random meshes written with random
// layout (indentation, CRLF, blank lines, polygons, /vt/vn, relative indices) and on the same
// texts damaged at random (lines dropped, doubled, swapped, truncated, junk, bad numbers, indices
// beyond the vertices so far). Valid texts are also checked against weld_corners of the corners
// they were written from (an oracle that reads no text), on 1 and 2 threads.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <typeinfo>

#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"

using namespace trellis;

namespace {

struct Outcome {
  bool ok = false;
  TriangleMesh mesh;
  std::string error;  // type and message
};

template <class Parse>
Outcome run(const Parse& parse) {
  Outcome o;
  try {
    o.mesh = parse();
    o.ok = true;
  } catch (const std::exception& e) {
    o.error = std::string(typeid(e).name()) + ": " + e.what();
  }
  return o;
}

bool same_mesh(const TriangleMesh& a, const TriangleMesh& b) {
  return a.triangles == b.triangles && a.vertices.size() == b.vertices.size() &&
         (a.vertices.empty() ||
          std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(Vec3)) == 0);
}

std::string same(const Outcome& a, const Outcome& b) {
  if (a.ok != b.ok) return "one read, one refused: " + a.error + b.error;
  if (!a.ok) return a.error == b.error ? "" : "errors differ: " + a.error + " | " + b.error;
  return same_mesh(a.mesh, b.mesh) ? "" : "meshes differ";
}

// A random soup: coordinates from a small set (so corners repeat, as in a closed mesh), -0
// sometimes, a few degenerate triangles.
std::vector<Vec3> random_points(std::mt19937& rng, std::size_t n) {
  std::vector<Vec3> p;
  for (std::size_t i = 0; i < n; ++i) {
    auto c = [&] { return static_cast<double>(static_cast<int>(rng() % 9) - 4) * 0.25; };
    Vec3 v{c(), c(), c()};
    if (v.x == 0 && rng() % 2) v.x = -0.0;
    p.push_back(v);
  }
  return p;
}

std::string number(std::mt19937& rng, double v) {
  char b[64];
  switch (rng() % 4) {
    case 0:
      std::snprintf(b, sizeof b, "%.17g", v);
      break;
    case 1:
      std::snprintf(b, sizeof b, "%e", v);
      break;
    case 2:
      std::snprintf(b, sizeof b, "%+.6f", v);
      break;
    default:
      std::snprintf(b, sizeof b, "%g", v);
  }
  return b;
}

std::string indent(std::mt19937& rng) {
  static const char* s[] = {"", " ", "  ", "\t", "    "};
  return s[rng() % std::size(s)];
}

std::string eol(std::mt19937& rng, bool crlf) {
  return (crlf ? "\r\n" : "\n") + std::string(rng() % 20 == 0 ? "\n" : "");
}

std::string ascii_stl(std::mt19937& rng, const std::vector<Vec3>& corners) {
  const bool crlf = rng() % 4 == 0;
  std::string t = "solid random" + eol(rng, crlf);
  for (std::size_t i = 0; i + 3 <= corners.size(); i += 3) {
    t += indent(rng) + "facet normal 0 0 " + (rng() % 2 ? "1" : "-1") + eol(rng, crlf);
    t += indent(rng) + "outer loop" + eol(rng, crlf);
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = corners[i + k];
      t += indent(rng) + "vertex " + number(rng, p.x) + (rng() % 5 ? " " : "\t") +
           number(rng, p.y) + " " + number(rng, p.z) + indent(rng) + eol(rng, crlf);
    }
    t += indent(rng) + "endloop" + eol(rng, crlf);
    t += indent(rng) + "endfacet" + eol(rng, crlf);
    if (rng() % 200 == 0) t += "endsolid random" + eol(rng, crlf) + "solid again" + eol(rng, crlf);
  }
  t += "endsolid random";
  if (rng() % 2) t += eol(rng, crlf);
  return t;
}

// An OBJ of `points` and faces over them (fans of 3-5 corners); `corners` gets the triangles'
// coordinates. Vertices are interleaved with the faces (each face after its vertices), some
// indices relative (negative), some with /vt/vn.
std::string obj(std::mt19937& rng, const std::vector<Vec3>& points, std::vector<Vec3>& corners,
                bool relative) {
  const bool crlf = rng() % 4 == 0;
  std::string t = "# random" + eol(rng, crlf);
  std::size_t defined = 0;
  auto define = [&](std::size_t upto) {
    for (; defined < upto; ++defined) {
      const Vec3& p = points[defined];
      t += indent(rng) + "v " + number(rng, p.x) + " " + number(rng, p.y) + " " + number(rng, p.z) +
           eol(rng, crlf);
      if (rng() % 10 == 0) t += "vn 0 0 1" + eol(rng, crlf);
    }
  };
  define(std::min<std::size_t>(points.size(), 3));
  const std::size_t faces = points.size();
  for (std::size_t f = 0; f < faces; ++f) {
    if (defined < points.size() && rng() % 2)
      define(std::min(points.size(), defined + 1 + rng() % 3));
    const std::size_t n = 3 + (rng() % 5 == 0 ? rng() % 3 : 0);
    std::vector<std::size_t> idx;
    for (std::size_t k = 0; k < n; ++k) idx.push_back(rng() % defined);
    t += indent(rng) + "f";
    for (const std::size_t i : idx) {
      const bool rel = relative && rng() % 4 == 0;
      t += " " + (rel ? std::to_string(static_cast<long>(i) - static_cast<long>(defined))
                      : std::to_string(i + 1));
      if (rng() % 4 == 0) t += "/1/1";
    }
    t += eol(rng, crlf);
    for (std::size_t k = 1; k + 1 < n; ++k)
      corners.insert(corners.end(), {points[idx[0]], points[idx[k]], points[idx[k + 1]]});
    if (rng() % 50 == 0) t += "g part" + std::to_string(f) + eol(rng, crlf);
  }
  define(points.size());
  return t;
}

// The text damaged at random: lines dropped, doubled, swapped or cut; junk; a bad number; a face
// naming a vertex not yet given (a later one, 0, or beyond the end).
std::string damage(std::mt19937& rng, const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream in(text);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  if (lines.empty()) return text;
  const int hits = 1 + static_cast<int>(rng() % 3);
  for (int h = 0; h < hits; ++h) {
    const std::size_t i = rng() % lines.size();
    switch (rng() % 9) {
      case 0:
        lines.erase(lines.begin() + static_cast<long>(i));
        break;
      case 1:
        lines.insert(lines.begin() + static_cast<long>(i), lines[i]);
        break;
      case 2:
        std::swap(lines[i], lines[rng() % lines.size()]);
        break;
      case 3:
        lines[i] = lines[i].substr(0, rng() % (lines[i].size() + 1));
        break;
      case 4:
        lines.insert(lines.begin() + static_cast<long>(i), "junk here");
        break;
      case 5:
        lines[i] += " nan";
        break;
      case 6:
        lines.insert(lines.begin() + static_cast<long>(i), "vertex 1e400 0 0");
        break;
      case 7:
        lines.insert(lines.begin() + static_cast<long>(i),
                     "f 1 2 " + std::to_string(rng() % 3 ? lines.size() : 0));
        break;
      default:
        lines.insert(lines.begin() + static_cast<long>(i), "f -1 -2 -999999");
    }
    if (lines.empty()) return "";
  }
  std::string t;
  for (const std::string& l : lines) t += l + "\n";
  if (rng() % 3 == 0) t.resize(rng() % (t.size() + 1));  // cut anywhere
  return t;
}

// Reading `text` in pieces (sizes from a few bytes up) and line after line (one piece bigger
// than the text) gives the same outcome, on 1 and 2 threads; returns the line-by-line one.
template <class Parse>
Outcome pieces_agree(std::mt19937& rng, const std::string& text, const Parse& parse,
                     const std::string& what) {
  const Outcome serial = run([&] { return parse(text, text.size() + 1); });
  for (const std::size_t threads : {1u, 2u}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    for (const std::size_t piece :
         {std::size_t{1}, std::size_t{7 + rng() % 60}, std::size_t{64 + rng() % 2000}}) {
      const Outcome o = run([&] { return parse(text, piece); });
      const std::string diff = same(serial, o);
      EXPECT_EQ(diff, "") << what << ", pieces of " << piece << " bytes, " << threads << " threads";
    }
  }
  return serial;
}

}  // namespace

TEST(MeshPieces, AsciiStlInPiecesReadsAsLineByLine) {
  std::mt19937 rng(2811);
  int read = 0, refused = 0;
  for (int round = 0; round < 160; ++round) {
    const std::vector<Vec3> pts = random_points(rng, 4 + rng() % 40);
    std::vector<Vec3> corners;
    const std::size_t triangles = 1 + rng() % (round < 150 ? 60 : 3000);
    for (std::size_t t = 0; t < 3 * triangles; ++t) corners.push_back(pts[rng() % pts.size()]);
    const std::string text = ascii_stl(rng, corners);
    auto parse = [](const std::string& s, std::size_t piece) {
      return parse_stl(s, "r.stl", piece);
    };
    const Outcome good = pieces_agree(rng, text, parse, "round " + std::to_string(round));
    const TriangleMesh expected = weld_corners(corners);
    if (expected.triangles.empty()) {
      EXPECT_FALSE(good.ok);
    } else {
      ASSERT_TRUE(good.ok) << good.error;
      EXPECT_TRUE(same_mesh(good.mesh, expected)) << round;
    }
    for (int d = 0; d < 4; ++d) {
      const std::string bad = damage(rng, text);
      const Outcome o = pieces_agree(rng, bad, parse, "damaged round " + std::to_string(round));
      (o.ok ? read : refused)++;
    }
  }
  EXPECT_GT(refused, 200);  // damage mostly shows, and is named alike
  EXPECT_GT(read, 10);
}

TEST(MeshPieces, ObjInPiecesReadsAsLineByLine) {
  std::mt19937 rng(2812);
  int read = 0, refused = 0;
  for (int round = 0; round < 160; ++round) {
    const std::vector<Vec3> pts = random_points(rng, 4 + rng() % (round < 150 ? 80 : 3000));
    std::vector<Vec3> corners;
    const std::string text = obj(rng, pts, corners, round % 3 == 0);
    auto parse = [](const std::string& s, std::size_t piece) {
      return parse_obj(s, "r.obj", piece);
    };
    const Outcome good = pieces_agree(rng, text, parse, "round " + std::to_string(round));
    const TriangleMesh expected = weld_corners(corners);
    if (expected.triangles.empty()) {
      EXPECT_FALSE(good.ok);
    } else {
      ASSERT_TRUE(good.ok) << good.error;
      EXPECT_TRUE(same_mesh(good.mesh, expected)) << round;
    }
    for (int d = 0; d < 4; ++d) {
      const std::string bad = damage(rng, text);
      const Outcome o = pieces_agree(rng, bad, parse, "damaged round " + std::to_string(round));
      (o.ok ? read : refused)++;
    }
  }
  EXPECT_GT(refused, 100);
  EXPECT_GT(read, 100);  // OBJ ignores much (dropped lines, junk), so many damaged texts still read
}

// The fuzzer's mesh corpus (tests/fuzz/corpus/mesh: inputs that once reached new code in the
// readers), each as STL and as OBJ, in pieces of a few bytes: the same outcome as line by line.
TEST(MeshPieces, FuzzCorpusReadsAsLineByLine) {
  const std::filesystem::path dir =
      std::filesystem::path(TRELLIS_SOURCE_DIR) / "tests" / "fuzz" / "corpus" / "mesh";
  std::mt19937 rng(2813);
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string what = entry.path().filename().string();
    pieces_agree(
        rng, text,
        [](const std::string& s, std::size_t piece) { return parse_stl(s, "f.stl", piece); },
        what + " as STL");
    pieces_agree(
        rng, text,
        [](const std::string& s, std::size_t piece) { return parse_obj(s, "f.obj", piece); },
        what + " as OBJ");
    ++files;
  }
  EXPECT_GT(files, 100);
}

// A text of 2 MB or more is read from its file in pieces (each piece read into its thread's
// buffer; the file is never held whole): read_mesh of the file gives what parsing its bytes in
// memory gives (the same mesh, or the same error naming the same line), on 1 and 2 threads, for
// random meshes, the same damaged, and texts with a line longer than the window the pieces'
// starts are looked for in (then the file is read whole).
TEST(MeshPieces, LargeFilesReadFromTheFileAsFromMemory) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("trellis_pieces_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::mt19937 rng(2814);
  int read = 0;
  for (int round = 0; round < 12; ++round) {
    const bool stl = round % 2 == 0;
    std::vector<Vec3> corners;
    std::string text;
    if (stl) {
      const std::vector<Vec3> pts = random_points(rng, 400);
      for (std::size_t t = 0; t < 3 * 14000; ++t) corners.push_back(pts[rng() % pts.size()]);
      text = ascii_stl(rng, corners);
    } else {
      text = obj(rng, random_points(rng, 45000), corners, false);
    }
    ASSERT_GE(text.size(), std::size_t{2} << 20);
    if (round % 4 >= 2) text = damage(rng, text);
    if (round % 6 == 5) {  // a line of 100 KB around the first piece's end
      const std::size_t at = text.find('\n', (1 << 20) - 50000 + rng() % 20000) + 1;
      text.insert(at, (stl ? "solid " : "# ") + std::string(100000, 'x') + "\n");
    }
    const std::string path =
        (dir / ("r" + std::to_string(round) + (stl ? ".stl" : ".obj"))).string();
    std::ofstream(path, std::ios::binary) << text;
    const Outcome memory = run([&] { return stl ? parse_stl(text, path) : parse_obj(text, path); });
    for (const std::size_t threads : {1u, 2u}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const Outcome file = run([&] { return read_mesh(path); });
      EXPECT_EQ(same(memory, file), "") << "round " << round << ", " << threads << " threads";
    }
    if (round % 4 < 2 && round % 6 != 5) {
      ASSERT_TRUE(memory.ok) << memory.error;
      EXPECT_TRUE(same_mesh(memory.mesh, weld_corners(corners))) << round;
    }
    if (memory.ok) ++read;
  }
  std::filesystem::remove_all(dir);
  EXPECT_GT(read, 4);
}
