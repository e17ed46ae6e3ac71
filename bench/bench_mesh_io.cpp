// Issue 17 target: a 50 MB binary STL (1M triangles) loads at >= 300 MB/s (`dd` reads it at
// ~1.7 GB/s): parsed in parallel and welded once by the bucketed hash weld (geom/mesh_weld.cpp).
// The mesh is generated (a closed torus, every vertex shared by six triangles as in CAD
// exports), written to a temporary file, and read back by read_mesh; 1 and 2 threads.
// Issue 40: loading as the slicer does (read_mesh + check_mesh) within 2x of reading the file;
// CPU time of the whole process (all threads). TRELLIS_BENCH_STL=FILE uses that file instead
// (bench/mesh_vs_cat.sh passes the one bench/make_torus_stl.py wrote, and times `cat` on it).
// LoadFloor: reading the file in pieces and filling a mesh of its size, nothing else.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>

#include "trellis/core/file.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/slice/slice.hpp"

using namespace trellis;

namespace {

// A torus of 2·nu·nv triangles.
TriangleMesh torus(int nu, int nv) {
  TriangleMesh m;
  const double R = 60, r = 20;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * std::numbers::pi * i / nu, v = 2 * std::numbers::pi * j / nv;
      m.vertices.push_back({(R + r * std::cos(v)) * std::cos(u),
                            (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
    }
  auto id = [&](int i, int j) { return static_cast<std::uint32_t>((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

struct StlFile {
  std::string path;
  std::size_t bytes = 0;
  bool own = true;
  StlFile() {
    if (const char* given = std::getenv("TRELLIS_BENCH_STL"); given && *given) {
      path = given;
      own = false;
      bytes = std::filesystem::file_size(path);
      return;
    }
    path = (std::filesystem::temp_directory_path() /
            ("trellis_bench_1m_" + std::to_string(::getpid()) + ".stl"))
               .string();
    const TriangleMesh m = torus(1000, 500);  // 1,000,000 triangles, 50,000,084 bytes
    write_stl(path, m);
    bytes = std::filesystem::file_size(path);
  }
  ~StlFile() {
    if (own) std::filesystem::remove(path);
  }
};

const StlFile& big_stl() {
  static const StlFile f;
  return f;
}

void BM_ReadBinaryStl1M(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const StlFile& f = big_stl();
  std::size_t vertices = 0;
  for (auto _ : state) {
    const TriangleMesh m = read_mesh(f.path);
    vertices = m.vertices.size();
    benchmark::DoNotOptimize(m);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.bytes));
  state.counters["MB/s"] = benchmark::Counter(static_cast<double>(f.bytes) * 1e-6,
                                              benchmark::Counter::kIsIterationInvariantRate);
  state.counters["vertices"] = static_cast<double>(vertices);
}
BENCHMARK(BM_ReadBinaryStl1M)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

// What `cat` does, in process: the file read into memory (read_file: the loaders' first step).
void BM_ReadFileOnly(benchmark::State& state) {
  const StlFile& f = big_stl();
  for (auto _ : state) benchmark::DoNotOptimize(read_file(f.path));  // NOLINT
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.bytes));
}
BENCHMARK(BM_ReadFileOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();

// The floor of loading: the least any loader of this file does. It reads the file in pieces into
// one buffer (as `cat` does; read_stl's pieces are this size) and fills a mesh of the loaded
// mesh's size (vertices and triangles: fresh memory, as a loaded mesh is), and nothing else: no
// parsing, welding or checking. LoadAndCheckMesh / LoadFloor is what those cost.
void BM_LoadFloor(benchmark::State& state) {
  const StlFile& f = big_stl();
  const TriangleMesh loaded = read_mesh(f.path);
  std::vector<char> piece(50 << 14);
  for (auto _ : state) {
    const int fd = ::open(f.path.c_str(), O_RDONLY);  // plain pread: any baseline library runs it
    for (std::size_t at = 0; at < f.bytes; at += piece.size())
      if (::pread(fd, piece.data(), std::min(piece.size(), f.bytes - at), static_cast<off_t>(at)) <=
          0)
        state.SkipWithError("short read");
    ::close(fd);
    TriangleMesh m;
    m.vertices.resize(loaded.vertices.size());
    m.triangles.resize(loaded.triangles.size());
    benchmark::DoNotOptimize(piece.data());
    benchmark::DoNotOptimize(m);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.bytes));
}
BENCHMARK(BM_LoadFloor)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();

// What the slicer does before slicing: read, weld, and check the mesh is closed (the 1M-triangle
// binary STL, or TRELLIS_BENCH_STL in any format read_mesh reads).
void BM_LoadAndCheckMesh(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const StlFile& f = big_stl();
  for (auto _ : state) {
    const TriangleMesh m = read_mesh(f.path);
    if (!check_mesh(m).closed()) state.SkipWithError("the mesh is not closed");
    benchmark::DoNotOptimize(m);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.bytes));
}
BENCHMARK(BM_LoadAndCheckMesh)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

// Where the time of BM_LoadAndCheckMesh goes, stage by stage, on the same file (any format):
// read (BM_ReadFileOnly: the bytes into memory), parse and weld from those bytes in memory
// (BM_StageParseWeld: parse_stl or parse_obj; a 3MF is read from its file: inflating and lib3mf's
// reading are its parse), the weld alone on the same triangles in memory (BM_StageWeld: a binary
// or ASCII STL's corners by weld_corners, an OBJ's or 3MF's indexed triangles by weld) and the
// check alone (BM_StageCheck). Parsing alone is BM_StageParseWeld - BM_StageWeld.
std::string extension_of(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

void BM_StageParseWeld(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const StlFile& f = big_stl();
  const std::string ext = extension_of(f.path);
  const std::string bytes = ext == ".3mf" ? std::string() : read_file(f.path);
  for (auto _ : state) {
    const TriangleMesh m = ext == ".3mf"   ? read_mesh(f.path)
                           : ext == ".obj" ? parse_obj(bytes, f.path)
                                           : parse_stl(bytes, f.path);
    benchmark::DoNotOptimize(m);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.bytes));
}
BENCHMARK(BM_StageParseWeld)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

void BM_StageWeld(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const StlFile& f = big_stl();
  const bool indexed = extension_of(f.path) != ".stl";
  const TriangleMesh m = read_mesh(f.path);
  std::vector<Vec3> corners;
  if (!indexed) {
    corners.reserve(3 * m.triangles.size());
    for (const auto& t : m.triangles)
      for (auto i : t) corners.push_back(m.vertices[i]);
  }
  for (auto _ : state) benchmark::DoNotOptimize(indexed ? weld(m) : weld_corners(corners));
}
BENCHMARK(BM_StageWeld)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

void BM_StageCheck(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const TriangleMesh m = read_mesh(big_stl().path);
  for (auto _ : state) benchmark::DoNotOptimize(check_mesh(m));
}
BENCHMARK(BM_StageCheck)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

// The check alone, on the welded mesh in memory.
void BM_CheckMesh1M(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const TriangleMesh m = torus(1000, 500);
  for (auto _ : state) benchmark::DoNotOptimize(check_mesh(m));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * m.triangles.size()));
}
BENCHMARK(BM_CheckMesh1M)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

// The weld alone, on the same soup in memory.
void BM_WeldCorners3M(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const TriangleMesh m = torus(1000, 500);
  std::vector<Vec3> corners;
  corners.reserve(3 * m.triangles.size());
  for (const auto& t : m.triangles)
    for (auto i : t) corners.push_back(m.vertices[i]);
  for (auto _ : state) benchmark::DoNotOptimize(weld_corners(corners));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * corners.size()));
}
BENCHMARK(BM_WeldCorners3M)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
