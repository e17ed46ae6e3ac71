#include "trellis/geom/mesh_io.hpp"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <map>
#include <optional>

#include "mesh_3mf_module.hpp"
#include "mesh_weld.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/text.hpp"
#include "trellis/geom/contour.hpp"

namespace trellis {

namespace {

std::string lower_extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos) return {};
  std::string ext = path.substr(dot + 1);
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// Vertices must be finite and within ±1e6 mm (as lattice nodes are).
constexpr double kCoordinateLimit = 1e6;
bool valid_coordinate(const Vec3& p) {
  return is_finite(p) && std::abs(p.x) <= kCoordinateLimit && std::abs(p.y) <= kCoordinateLimit &&
         std::abs(p.z) <= kCoordinateLimit;
}
void check_coordinate(const Vec3& p, const std::string& name, long line,
                      const std::string& element = {}) {
  if (!valid_coordinate(p))
    throw ParseError("vertex coordinate is not finite or beyond ±1e6 mm", {name, line, element});
}

// The number at [p, end) when it is plain decimal ([-]digits[.digits][e[±]digits]) with at most
// 2^53 as its digits and a power of ten within ±22: then the digits and the power are exact
// doubles and one IEEE multiplication or division rounds their product correctly (Clinger's fast
// path), the same double std::from_chars gives. Returns where it stopped, or nullptr for anything
// else (from_chars reads those).
const char* decimal(const char* p, const char* end, double& out) {
  constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                               1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                               1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const bool negative = p < end && *p == '-';
  if (negative) ++p;
  std::uint64_t m = 0;
  int digits = 0, scale = 0;
  const char* const first = p;
  for (; p < end && *p >= '0' && *p <= '9'; ++p, ++digits)
    m = 10 * m + static_cast<unsigned>(*p - '0');
  const bool integer_part = p != first;
  if (p < end && *p == '.') {
    const char* const frac = ++p;
    for (; p < end && *p >= '0' && *p <= '9'; ++p, ++digits, --scale)
      m = 10 * m + static_cast<unsigned>(*p - '0');
    if (!integer_part && p == frac) return nullptr;  // "." or "-."
  } else if (!integer_part) {
    return nullptr;
  }
  if (digits > 19 || m > (std::uint64_t{1} << 53)) return nullptr;
  if (p < end && (*p == 'e' || *p == 'E')) {
    const char* q = p + 1;
    const bool minus = q < end && *q == '-';
    if (q < end && (*q == '-' || *q == '+')) ++q;
    if (q == end || *q < '0' || *q > '9') return nullptr;  // "1e", "1e+": from_chars decides
    int e = 0;
    for (; q < end && *q >= '0' && *q <= '9' && e < 1000; ++q) e = 10 * e + (*q - '0');
    if (q < end && *q >= '0' && *q <= '9') return nullptr;
    scale += minus ? -e : e;
    p = q;
  }
  if (scale < -22 || scale > 22) return nullptr;
  double v = static_cast<double>(m);
  v = scale < 0 ? v / kPow10[-scale] : v * kPow10[scale];
  out = negative ? -v : v;
  return p;
}

// Three numbers as sscanf("%lf %lf %lf") reads them, without its cost (a third of a large
// ASCII file's load): each is optional blanks, an optional '+', and what std::from_chars takes
// (the same correctly rounded double), followed by a blank or the end. Anything else (hex,
// overflow, a sign after '+', a number run into text) returns false and the caller asks sscanf,
// so every line reads as it did. `whole`: nothing but blanks may follow the third number.
bool three_numbers(std::string_view s, Vec3& out, bool whole) {
  auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
  const char* p = s.data();
  const char* const end = p + s.size();
  double v[3];
  for (double& x : v) {
    while (p < end && blank(*p)) ++p;
    if (p < end && *p == '+') {
      ++p;
      if (p < end && (*p == '+' || *p == '-')) return false;
    }
    const char* stop = decimal(p, end, x);
    if (!stop) {
      const auto r = std::from_chars(p, end, x);
      if (r.ec != std::errc()) return false;
      stop = r.ptr;
    }
    if (stop < end && !blank(*stop)) return false;
    p = stop;
  }
  if (whole) {
    while (p < end && blank(*p)) ++p;
    if (p != end) return false;
  }
  out = {v[0], v[1], v[2]};
  return true;
}

// Large texts are read in pieces of about this many bytes, in parallel (split at line starts).
constexpr std::size_t kTextPiece = 1 << 20;

// Where pieces of `text` start: 0, then for each multiple of `piece` the first line start at or
// after it whose line (trimmed) `opens` accepts. Lines are split at '\n' as the parsers split
// them.
template <class Opens>
std::vector<std::size_t> piece_starts(std::string_view text, std::size_t piece,
                                      const Opens& opens) {
  std::vector<std::size_t> starts{0};
  std::size_t want = piece;
  while (want < text.size()) {
    // The line start at or after `want`: just after the '\n' at want - 1 or later.
    const void* nl = std::memchr(text.data() + want - 1, '\n', text.size() - (want - 1));
    std::size_t at =
        nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - text.data()) + 1 : text.size();
    while (at < text.size()) {
      const void* e = std::memchr(text.data() + at, '\n', text.size() - at);
      const std::size_t end =
          e ? static_cast<std::size_t>(static_cast<const char*>(e) - text.data()) : text.size();
      if (opens(trim(text.substr(at, end - at)))) break;
      at = end + 1;
    }
    if (at >= text.size()) break;
    starts.push_back(at);
    want = at + piece;
  }
  starts.push_back(text.size());
  return starts;
}

// A text to read in pieces: in memory, or a file whose pieces are read (pread) into a buffer of
// the thread that parses them, so a large text is never held whole (reading a fresh buffer of a
// file's size costs more than the reading: a page fault every 4 KB).
struct TextInMemory {
  std::string_view text;
  std::size_t size() const { return text.size(); }
  template <class Opens>
  std::vector<std::size_t> starts(std::size_t piece, const Opens& opens) const {
    return piece_starts(text, piece, opens);
  }
  std::string_view piece(std::size_t from, std::size_t to, std::string&) const {
    return text.substr(from, to - from);
  }
};

struct TextInFile {
  const InputFile& file;
  std::size_t size() const { return static_cast<std::size_t>(file.size()); }
  // piece_starts' starts, found in a window of the file after each multiple of `piece`; none
  // (an empty list) when a start is not within its window (then the whole text is read).
  template <class Opens>
  std::vector<std::size_t> starts(std::size_t piece, const Opens& opens) const {
    constexpr std::size_t kWindow = 1 << 16;
    const std::size_t n = size();
    std::vector<std::size_t> out{0};
    std::string w;
    std::size_t want = piece;
    while (want < n) {
      const std::size_t from = want - 1, len = std::min(kWindow, n - from);
      w.resize(len);
      file.read_at(from, w.data(), len);
      const bool to_end = from + len == n;
      const std::string_view text(w);
      std::size_t at = text.find('\n');
      if (at == std::string_view::npos) {
        if (!to_end) return {};
        break;  // no line starts after `want`
      }
      ++at;
      bool found = false;
      while (at < text.size()) {
        std::size_t end = text.find('\n', at);
        if (end == std::string_view::npos) {
          if (!to_end) return {};  // the line runs past the window
          end = text.size();
        }
        if (opens(trim(text.substr(at, end - at)))) {
          found = true;
          break;
        }
        at = end + 1;
      }
      if (!found) {
        if (!to_end) return {};
        break;
      }
      out.push_back(from + at);
      want = from + at + piece;
    }
    out.push_back(n);
    return out;
  }
  std::string_view piece(std::size_t from, std::size_t to, std::string& scratch) const {
    scratch.resize(to - from);
    file.read_at(from, scratch.data(), to - from);
    return scratch;
  }
};

// The ASCII STL grammar over `text` (whole lines), from outside a facet, its triangles' corners
// appended to `corners`. A problem is `fail(message, line)` (line counted from 1 in `text`),
// which throws or returns false; then this returns false. `in_facet`: a facet is open at the
// end.
template <class Fail>
bool scan_ascii_stl(std::string_view text, std::vector<Vec3>& corners, bool& in_facet,
                    const Fail& fail) {
  std::size_t pos = 0;
  long line = 0;
  Vec3 v[3];
  int nv = 0;
  bool in_loop = false;
  in_facet = false;
  while (pos < text.size()) {
    const void* nl = std::memchr(text.data() + pos, '\n', text.size() - pos);
    const std::size_t end =
        nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - text.data()) : text.size();
    const std::string_view s = trim(std::string_view(text.data() + pos, end - pos));
    pos = end + 1;
    ++line;
    if (s.empty()) continue;
    if (s.starts_with("vertex")) {
      if (!in_loop || nv >= 3)
        return fail("'vertex' outside a facet's 'outer loop' or a fourth vertex", line);
      if (!three_numbers(s.substr(6), v[nv], true)) {
        double x, y, z;
        char extra;
        if (std::sscanf(std::string(s.substr(6)).c_str(), "%lf %lf %lf %c", &x, &y, &z, &extra) !=
            3)
          return fail("expected 'vertex x y z'", line);
        v[nv] = {x, y, z};
      }
      if (!valid_coordinate(v[nv]))
        return fail("vertex coordinate is not finite or beyond ±1e6 mm", line);
      ++nv;
    } else if (s.starts_with("facet")) {
      if (in_facet) return fail("'facet' inside a facet", line);
      in_facet = true;
      nv = 0;
    } else if (s.starts_with("endfacet")) {
      if (!in_facet || nv != 3) return fail("facet without exactly three vertices", line);
      if (in_loop) return fail("'endfacet' before the facet's 'endloop'", line);
      corners.insert(corners.end(), {v[0], v[1], v[2]});
      in_facet = false;
    } else if (s.starts_with("outer")) {
      if (!in_facet || in_loop || nv != 0)
        return fail("'outer loop' outside a facet or given twice", line);
      in_loop = true;
    } else if (s.starts_with("endloop")) {
      if (!in_loop) return fail("'endloop' without 'outer loop'", line);
      in_loop = false;
    } else if (s.starts_with("solid") || s.starts_with("endsolid")) {
      continue;
    } else {
      return fail("unexpected '" + std::string(s.substr(0, 40)) + "' in ASCII STL", line);
    }
  }
  if (in_facet) return fail("file ends inside a facet", line);
  return true;
}

// One line after another, each problem thrown as a ParseError naming its line.
TriangleMesh parse_ascii_stl_serial(const std::string& text, const std::string& name) {
  std::vector<Vec3> corners;
  bool open = false;
  scan_ascii_stl(text, corners, open, [&](const std::string& what, long line) -> bool {
    throw ParseError(what, {name, line, ""});
  });
  TriangleMesh mesh = weld_corners(corners);
  if (mesh.triangles.empty()) throw ParseError("STL has no triangles", {name, 0, ""});
  return mesh;
}

// Pieces starting at a 'facet' line, read in parallel, each welded on its own, then joined: the
// serial reading's mesh, since a valid file is outside any facet before each 'facet' line.
// A piece that is not valid read from there (or a facet open at a piece's end) sends the whole
// text to the serial reading, which throws what it always threw, at the line it always named.
// `text` (a TextInMemory or TextInFile) is read piece by piece; `whole()` gives all of it, for
// the serial reading. Nothing (false) when the pieces cannot be found in a file's windows.
template <class Text, class Whole>
std::optional<TriangleMesh> ascii_stl_in_pieces(const Text& text, const Whole& whole,
                                                const std::string& name, std::size_t piece) {
  const std::vector<std::size_t> at =
      text.starts(piece, [](std::string_view s) { return s.starts_with("facet"); });
  if (at.empty()) return std::nullopt;
  const std::size_t pieces = at.size() - 1;
  std::vector<WeldedRun> runs(pieces);
  struct Scratch {
    std::vector<Vec3> corners;
    WeldTable table;
    std::string bytes;  // a file's piece
  };
  tbb::enumerable_thread_specific<Scratch> scratch;
  std::atomic<bool> ok{true};
  tbb::parallel_for(std::size_t{0}, pieces, [&](std::size_t k) {
    if (!ok) return;
    Scratch& sc = scratch.local();
    std::vector<Vec3>& corners = sc.corners;
    corners.clear();
    bool open = false;
    if (!scan_ascii_stl(text.piece(at[k], at[k + 1], sc.bytes), corners, open,
                        [](const std::string&, long) { return false; })) {
      ok = false;
      return;
    }
    weld_run(corners.data(), corners.size(), runs[k], sc.table);
  });
  if (!ok) return parse_ascii_stl_serial(whole(), name);
  TriangleMesh mesh = join_runs(runs);
  if (mesh.triangles.empty()) throw ParseError("STL has no triangles", {name, 0, ""});
  return mesh;
}

TriangleMesh parse_ascii_stl(const std::string& text, const std::string& name, std::size_t piece) {
  if (text.size() < 2 * piece) return parse_ascii_stl_serial(text, name);
  return *ascii_stl_in_pieces(
      TextInMemory{text}, [&]() -> const std::string& { return text; }, name, piece);
}

}  // namespace

namespace {

// A binary STL of `count` triangles (its size says so), welded; the coordinates checked.
TriangleMesh binary_stl(const StlRecords& records, std::size_t count, const std::string& name) {
  std::size_t bad = count;
  TriangleMesh mesh = weld_binary_stl(records, count, bad, kCoordinateLimit);
  if (bad < count) {  // the lowest triangle with an invalid coordinate
    char rec[50];
    const char* r = records(bad, 1, rec);
    float f[9];
    std::memcpy(f, r + 12, 36);
    for (int k = 0; k < 3; ++k)
      check_coordinate({f[3 * k], f[3 * k + 1], f[3 * k + 2]}, name, 0,
                       "triangle " + std::to_string(bad));
  }
  if (mesh.triangles.empty()) throw ParseError("STL has no triangles", {name, 0, ""});
  return mesh;
}

// The triangle count of a binary STL of `size` bytes whose header is `head` (84 bytes), or -1
// when the size is not 84 + 50 per triangle (then it may be ASCII).
long long binary_stl_count(const char* head, std::uint64_t size) {
  if (size < 84) return -1;
  std::uint32_t count;
  std::memcpy(&count, head + 80, 4);
  return 84 + 50ull * count == size ? static_cast<long long>(count) : -1;
}

TriangleMesh ascii_or_not_stl(const std::string& bytes, const std::string& name,
                              std::size_t piece = kTextPiece) {
  const std::string head(trim(bytes.substr(0, std::min<std::size_t>(bytes.size(), 256))));
  if (head.rfind("solid", 0) == 0) return parse_ascii_stl(bytes, name, piece);
  throw ParseError(fmt::format("not an STL file: {} bytes is neither a binary STL (84 + 50 per "
                               "triangle) nor ASCII starting with 'solid'",
                               bytes.size()),
                   {name, 0, ""});
}

}  // namespace

TriangleMesh parse_stl(const std::string& bytes, const std::string& name, std::size_t piece) {
  if (const long long count = binary_stl_count(bytes.data(), bytes.size()); count >= 0) {
    const char* records = bytes.data() + 84;
    return binary_stl(
        [records](std::size_t first, std::size_t, char*) { return records + 50 * first; },
        static_cast<std::size_t>(count), name);
  }
  return ascii_or_not_stl(bytes, name, piece ? piece : kTextPiece);
}

TriangleMesh parse_stl(const std::string& bytes, const std::string& name) {
  return parse_stl(bytes, name, 0);
}

// A binary STL is read in pieces straight into the weld (never whole: 50 bytes a triangle, of
// which it keeps 36); anything else whole, as parse_stl reads it.
TriangleMesh read_stl(const std::string& path) {
  const InputFile file(path);
  char head[84] = {};
  const std::uint64_t size = file.size();
  if (size >= 84) file.read_at(0, head, 84);
  if (const long long count = binary_stl_count(head, size); count >= 0)
    return binary_stl(
        [&file](std::size_t first, std::size_t n, char* scratch) {
          file.read_at(84 + 50 * first, scratch, 50 * n);
          return static_cast<const char*>(scratch);
        },
        static_cast<std::size_t>(count), path);
  // A large ASCII STL in pieces from the file (the head says "solid"; otherwise, or when its
  // pieces are not found, the whole text is read as before).
  if (size >= 2 * kTextPiece && std::string_view(head, 84).find('\0') == std::string_view::npos &&
      trim(std::string_view(head, 84)).starts_with("solid")) {
    std::string all;
    auto whole = [&]() -> const std::string& { return all = read_file(path); };
    if (auto mesh = ascii_stl_in_pieces(TextInFile{file}, whole, path, kTextPiece))
      return std::move(*mesh);
  }
  return ascii_or_not_stl(read_file(path), path);
}

namespace {

// The integer at line[p] as strtol reads it: `v`, and where it stopped (p: none). Plain
// [-]digits by std::from_chars, in place; anything else (blanks or '+' before it, overflow) by
// strtol on a NUL-terminated copy in `copy`.
[[gnu::always_inline]] inline std::size_t face_index(std::string_view line, std::size_t p,
                                                     std::string& copy, long& v) {
  const char* const end = line.data() + line.size();
  const char* at = line.data() + p;
  auto digit = [](char c) { return c >= '0' && c <= '9'; };
  if (at < end && (digit(*at) || (*at == '-' && at + 1 < end && digit(at[1])))) {
    // Up to 18 digits cannot overflow: summed here (what from_chars gives), more by from_chars.
    const bool minus = *at == '-';
    const char* q = at + minus;
    long n = 0;
    int digits = 0;
    for (; q < end && digit(*q) && digits < 18; ++q, ++digits) n = 10 * n + (*q - '0');
    if (q == end || !digit(*q)) {
      v = minus ? -n : n;
      return static_cast<std::size_t>(q - line.data());
    }
    const auto [stop, ec] = std::from_chars(at, end, v);
    if (ec == std::errc()) return static_cast<std::size_t>(stop - line.data());
  }
  copy.assign(line.substr(p));
  char* stop = nullptr;
  v = std::strtol(copy.c_str(), &stop, 10);
  return p + static_cast<std::size_t>(stop - copy.c_str());
}

}  // namespace

namespace {

// The OBJ grammar over `text` (whole lines): vertices appended to `verts`, each face's fan of
// triangles to `corners` (indices into `verts`). A problem is `fail(message, line)` (line counted
// from 1 in `text`), which throws or returns false; then this returns false.
// kPiece: `text` is a piece of the file after vertices not seen here, so a face's index v (1 is
// the file's first vertex) is only checked to be at least 1: `need` becomes at least what the
// vertices before the piece must number for every index to name a vertex before its face, and a
// relative (negative) index is refused (the serial reading takes those).
template <bool kPiece, class Fail>
bool scan_obj(std::string_view text, std::vector<Vec3>& verts, std::vector<std::uint32_t>& corners,
              long& need, const Fail& fail) {
  std::string s;          // face_index's copy for strtol (its memory reused)
  std::vector<long> idx;  // a face's vertices (likewise)
  std::size_t pos = 0;
  long line = 0;
  while (pos < text.size()) {
    const void* nl = std::memchr(text.data() + pos, '\n', text.size() - pos);
    const std::size_t end =
        nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - text.data()) : text.size();
    const std::string_view sv = trim(std::string_view(text.data() + pos, end - pos));
    pos = end + 1;
    ++line;
    if (sv.size() < 2 || sv[0] == '#') continue;
    if (sv[0] == 'v' && sv[1] == ' ') {
      Vec3 p;
      if (!three_numbers(sv.substr(2), p, false)) {
        double x, y, z;
        if (std::sscanf(std::string(sv.substr(2)).c_str(), "%lf %lf %lf", &x, &y, &z) != 3)
          return fail("expected 'v x y z'", line);
        p = {x, y, z};
      }
      if (verts.size() >= 0xffffffffu) return fail("more than 4,294,967,294 vertices", line);
      verts.push_back(p);
      if (!valid_coordinate(p))
        return fail("vertex coordinate is not finite or beyond ±1e6 mm", line);
    } else if (sv[0] == 'f' && sv[1] == ' ') {
      idx.clear();
      std::size_t p = 2;
      while (p < sv.size()) {
        while (p < sv.size() && sv[p] == ' ') ++p;
        if (p >= sv.size()) break;
        long v = 0;
        const std::size_t stop = face_index(sv, p, s, v);
        const char after = stop < sv.size() ? sv[stop] : '\0';
        if (stop == p || (after != '\0' && after != ' ' && after != '/'))
          return fail("bad face index '" + std::string(sv.substr(p, sv.find(' ', p) - p)) +
                          "' (an integer, optionally /texture/normal)",
                      line);
        const long n = static_cast<long>(verts.size());
        long i;
        if constexpr (kPiece) {
          i = v - 1;
          if (v < 1 || i >= 0xffffffffl) return fail("", line);
          need = std::max(need, i + 1 - n);
        } else {
          i = v < 0 ? n + v : v - 1;
          if (i < 0 || i >= n)
            return fail(fmt::format("face refers to vertex {} of {}", v, n), line);
        }
        idx.push_back(i);
        p = stop;
        while (p < sv.size() && sv[p] != ' ') ++p;  // skip /vt/vn
      }
      if (idx.size() < 3) return fail("face with fewer than 3 vertices", line);
      for (std::size_t k = 1; k + 1 < idx.size(); ++k)
        corners.insert(corners.end(),
                       {static_cast<std::uint32_t>(idx[0]), static_cast<std::uint32_t>(idx[k]),
                        static_cast<std::uint32_t>(idx[k + 1])});
    }
  }
  return true;
}

// One line after another, each problem thrown as a ParseError naming its line.
TriangleMesh parse_obj_serial(const std::string& text, const std::string& name) {
  std::vector<Vec3> verts;
  std::vector<std::uint32_t> corners;  // triangle t: corners[3t..3t+2], indices into verts
  long need = 0;
  scan_obj<false>(text, verts, corners, need, [&](const std::string& what, long line) -> bool {
    throw ParseError(what, {name, line, ""});
  });
  TriangleMesh mesh = weld_indexed(verts, corners);
  if (mesh.triangles.empty()) throw ParseError("OBJ has no faces", {name, 0, ""});
  return mesh;
}

// Pieces (at line starts) read in parallel, their vertices and corners joined in order: the
// serial reading's lists when every piece reads and every index names a vertex before its face.
// Anything else (a problem, an index beyond the vertices so far, a relative index) sends the
// whole text to the serial reading, which throws what it always threw or reads it as always.
// `text` (a TextInMemory or TextInFile) is read piece by piece; `whole()` gives all of it, for
// the serial reading. Nothing when the pieces cannot be found in a file's windows.
template <class Text, class Whole>
std::optional<TriangleMesh> obj_in_pieces(const Text& text, const Whole& whole,
                                          const std::string& name, std::size_t piece) {
  const std::vector<std::size_t> at = text.starts(piece, [](std::string_view) { return true; });
  if (at.empty()) return std::nullopt;
  const std::size_t pieces = at.size() - 1;
  struct Piece {
    std::vector<Vec3> verts;
    std::vector<std::uint32_t> corners;
    long need = 0;
  };
  std::vector<Piece> part(pieces);
  std::atomic<bool> ok{true};
  tbb::enumerable_thread_specific<std::string> scratch;  // a file's piece
  tbb::parallel_for(std::size_t{0}, pieces, [&](std::size_t k) {
    if (!ok) return;
    Piece& p = part[k];
    const std::size_t bytes = at[k + 1] - at[k];
    p.verts.reserve(bytes / 48);  // a vertex line is some 30 bytes, a face's corner some 8
    p.corners.reserve(bytes / 6);
    if (!scan_obj<true>(text.piece(at[k], at[k + 1], scratch.local()), p.verts, p.corners, p.need,
                        [](const std::string&, long) { return false; }))
      ok = false;
  });
  std::vector<std::size_t> vfirst(pieces + 1, 0), cfirst(pieces + 1, 0);
  for (std::size_t k = 0; ok && k < pieces; ++k) {
    if (part[k].need > static_cast<long>(vfirst[k])) ok = false;
    vfirst[k + 1] = vfirst[k] + part[k].verts.size();
    cfirst[k + 1] = cfirst[k] + part[k].corners.size();
  }
  if (!ok || vfirst[pieces] >= 0xffffffffu) return parse_obj_serial(whole(), name);
  std::vector<Vec3> verts(vfirst[pieces]);
  std::vector<std::uint32_t> corners(cfirst[pieces]);
  tbb::parallel_for(std::size_t{0}, pieces, [&](std::size_t k) {
    std::copy(part[k].verts.begin(), part[k].verts.end(),
              verts.begin() + static_cast<long>(vfirst[k]));
    std::copy(part[k].corners.begin(), part[k].corners.end(),
              corners.begin() + static_cast<long>(cfirst[k]));
    part[k] = Piece{};
  });
  TriangleMesh mesh = weld_indexed(verts, corners);
  if (mesh.triangles.empty()) throw ParseError("OBJ has no faces", {name, 0, ""});
  return mesh;
}

}  // namespace

TriangleMesh parse_obj(const std::string& text, const std::string& name, std::size_t piece) {
  if (piece == 0) piece = kTextPiece;
  if (text.size() < 2 * piece) return parse_obj_serial(text, name);
  return *obj_in_pieces(
      TextInMemory{text}, [&]() -> const std::string& { return text; }, name, piece);
}

TriangleMesh parse_obj(const std::string& text, const std::string& name) {
  return parse_obj(text, name, 0);
}

// A large OBJ in pieces from the file (never held whole, as parse_obj would read it in pieces);
// a small one, anything but a regular file (read_file's errors), or one whose pieces are not
// found, read whole.
TriangleMesh read_obj(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec) &&
      std::filesystem::file_size(path, ec) >= 2 * kTextPiece && !ec) {
    const InputFile file(path);
    if (file.size() >= 2 * kTextPiece) {
      std::string all;
      auto whole = [&]() -> const std::string& { return all = read_file(path); };
      if (auto mesh = obj_in_pieces(TextInFile{file}, whole, path, kTextPiece))
        return std::move(*mesh);
    }
  }
  return parse_obj(read_file(path), path);
}

// lib3mf runs in the 3MF module (src/geom/mesh_3mf.cpp), loaded on first use; it returns the
// triangles as they are stored, welded and checked here like every other format.
TriangleMesh read_3mf(const std::string& path) {
  { const InputFile exists(path); }  // clear IoError for a missing file (nothing read)
  const TriangleMesh stored = detail::module_table<Mesh3mfModule>("3mf").read_3mf(path);
  for (const auto& v : stored.vertices) check_coordinate(v, path, 0);
  TriangleMesh mesh = weld(stored);
  if (mesh.triangles.empty()) throw ParseError("3MF has no mesh triangles", {path, 0, ""});
  return mesh;
}

void write_3mf(const std::string& path, const TriangleMesh& mesh, const std::string& unit) {
  detail::module_table<Mesh3mfModule>("3mf").write_3mf(path, mesh, unit);
}

std::string mesh_to_obj(const TriangleMesh& mesh, const std::string& name) {
  std::string out = "# Trellis\no " + (name.empty() ? std::string("trellis") : name) + "\n";
  out.reserve(out.size() + mesh.vertices.size() * 40 + mesh.triangles.size() * 24);
  auto back = std::back_inserter(out);
  for (const Vec3& v : mesh.vertices) fmt::format_to(back, "v {} {} {}\n", v.x, v.y, v.z);
  for (const auto& t : mesh.triangles)
    fmt::format_to(back, "f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
  return out;
}

bool is_mesh_output(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == "stl" || ext == "obj" || ext == "3mf";
}

void write_mesh(const std::string& path, const TriangleMesh& mesh, const std::string& name,
                const std::string& what) {
  const std::string ext = lower_extension(path);
  if (ext == "stl") return write_file_atomic(path, mesh_to_stl(mesh, name));
  if (ext == "obj") return write_file_atomic(path, mesh_to_obj(mesh, name));
  if (ext == "3mf") return write_3mf(path, mesh);
  if (is_stream_output(path)) return write_file_atomic(path, mesh_to_stl(mesh, name));
  throw SettingError("'" + path + "': a mesh is written as .stl (binary STL), .obj or .3mf",
                     {"", 0, what});
}

TriangleMesh read_mesh(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == "stl") return read_stl(path);
  if (ext == "obj") return read_obj(path);
  if (ext == "3mf") return read_3mf(path);
  throw ParseError("unknown mesh format '." + ext + "' (expected .stl, .obj or .3mf)",
                   {path, 0, ""});
}

void require_closed(const TriangleMesh& mesh, const std::string& name) {
  const MeshCheck c = check_mesh(mesh);
  if (c.closed()) return;
  throw GeometryError(fmt::format("mesh is not closed and manifold: {} open edges, {} non-manifold "
                                  "edges; first: {}",
                                  c.open_edges, c.nonmanifold_edges, c.first_problem),
                      {name, 0, ""});
}

BBox3 bounds(const TriangleMesh& mesh) {
  BBox3 b;
  for (const auto& v : mesh.vertices) b.add(v);
  return b;
}

double volume(const TriangleMesh& mesh) {
  double v = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    v += a.x * (b.y * c.z - b.z * c.y) - a.y * (b.x * c.z - b.z * c.x) +
         a.z * (b.x * c.y - b.y * c.x);
  }
  return v / 6.0;
}

namespace {

// The plane z's segments of one triangle, oriented with the solid on their left.
void cut_triangle(const TriangleMesh& mesh, const std::array<std::uint32_t, 3>& tri, double z,
                  std::vector<Segment2>& segments) {
  auto cross = [&](std::uint32_t i, std::uint32_t j) {
    if (i > j) std::swap(i, j);  // same point from both triangles sharing the edge
    const Vec3 a = mesh.vertices[i], b = mesh.vertices[j];
    const double t = (z - a.z) / (b.z - a.z);
    return Vec2{a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t};
  };
  const Vec3 p[3] = {mesh.vertices[tri[0]], mesh.vertices[tri[1]], mesh.vertices[tri[2]]};
  // A vertex exactly on the plane counts as below: consistent across triangles.
  const bool above[3] = {p[0].z > z, p[1].z > z, p[2].z > z};
  if (above[0] == above[1] && above[1] == above[2]) return;
  Vec2 pts[2];
  int n = 0;
  for (int k = 0; k < 3 && n < 2; ++k) {
    const int l = (k + 1) % 3;
    if (above[k] != above[l]) pts[n++] = cross(tri[k], tri[l]);
  }
  if (n != 2) return;
  // Orient so the solid lies on the left: direction along ez × n.
  const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  const double nx = e1.y * e2.z - e1.z * e2.y, ny = e1.z * e2.x - e1.x * e2.z;
  const Vec2 dir{-ny, nx};
  const Vec2 d = pts[1] - pts[0];
  if (d.x * dir.x + d.y * dir.y >= 0)
    segments.push_back({pts[0], pts[1]});
  else
    segments.push_back({pts[1], pts[0]});
}

}  // namespace

Regions slice_mesh(const TriangleMesh& mesh, double z, double stitch_tolerance) {
  std::vector<Segment2> segments;
  for (const auto& tri : mesh.triangles) cut_triangle(mesh, tri, z, segments);
  const StitchedLines lines = stitch_segments(segments, stitch_tolerance);
  return nest_oriented_rings(lines.loops);
}

Regions slice_mesh(const TriangleMesh& mesh, double z, const std::vector<std::uint32_t>& triangles,
                   double stitch_tolerance, bool overlapping) {
  std::vector<Segment2> segments;
  for (const std::uint32_t t : triangles) cut_triangle(mesh, mesh.triangles[t], z, segments);
  const StitchedLines lines = stitch_segments(segments, stitch_tolerance);
  return overlapping ? unite_oriented_rings(lines.loops) : nest_oriented_rings(lines.loops);
}

std::vector<std::vector<std::uint32_t>> triangles_by_plane(const TriangleMesh& mesh,
                                                           const std::vector<double>& zs) {
  std::vector<std::vector<std::uint32_t>> out(zs.size());
  // Planes in ascending order (a permutation if they are not).
  std::vector<std::size_t> order(zs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return zs[a] < zs[b]; });
  std::vector<double> sorted(zs.size());
  for (std::size_t i = 0; i < order.size(); ++i) sorted[i] = zs[order[i]];
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const double z0 =
        std::min({mesh.vertices[tri[0]].z, mesh.vertices[tri[1]].z, mesh.vertices[tri[2]].z});
    const double z1 =
        std::max({mesh.vertices[tri[0]].z, mesh.vertices[tri[1]].z, mesh.vertices[tri[2]].z});
    // Planes with z0 <= z < z1.
    for (auto it = std::lower_bound(sorted.begin(), sorted.end(), z0);
         it != sorted.end() && *it < z1; ++it)
      out[order[static_cast<std::size_t>(it - sorted.begin())]].push_back(
          static_cast<std::uint32_t>(t));
  }
  return out;
}

}  // namespace trellis
