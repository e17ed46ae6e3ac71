// Welding a triangle soup (STL stores every corner of every triangle) into an indexed mesh, in
// parallel and without a node-based map: corners are hashed, bucketed by the hash's top bits
// (a counting sort), and each bucket, small enough for the cache, is welded by its own
// open-addressing table. Equal coordinates (with -0 == +0) give one vertex; vertices are numbered
// in the order of their first corner, so the result does not depend on the thread count.
#include "mesh_weld.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <memory>
#include <type_traits>

#include "trellis/core/error.hpp"
#include "trellis/core/memory.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis {

namespace {

std::uint64_t bits(double d) {
  const double z = d == 0 ? 0.0 : d;  // -0 and +0 weld
  std::uint64_t b;
  std::memcpy(&b, &z, 8);
  return b;
}

std::uint32_t bits(float f) {
  const float z = f == 0 ? 0.0f : f;
  std::uint32_t b;
  std::memcpy(&b, &z, 4);
  return b;
}

// A binary STL's corner as stored (float): 12 bytes where a Vec3 takes 24, so the bucketed
// copy below moves 20 bytes a corner, not 32. Floats are equal exactly when the doubles they
// widen to are, so the weld is the same.
struct Float3 {
  float x, y, z;
};

// A welded point as the mesh's vertex: in double, -0 written as +0.
template <class P>
Vec3 vertex_of(const P& p) {
  const double x = p.x, y = p.y, z = p.z;
  return {x == 0 ? 0.0 : x, y == 0 ? 0.0 : y, z == 0 ? 0.0 : z};
}

std::uint64_t hash_of(const Vec3& v) {
  std::uint64_t h = bits(v.x) * 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 29) ^ bits(v.y)) * 0xBF58476D1CE4E5B9ull;
  h = (h ^ (h >> 31) ^ bits(v.z)) * 0x94D049BB133111EBull;
  return h ^ (h >> 32);
}

std::uint64_t hash_of(const Float3& v) {
  std::uint64_t h = (std::uint64_t{bits(v.x)} << 32 | bits(v.y)) * 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 31) ^ bits(v.z)) * 0x94D049BB133111EBull;
  return h ^ (h >> 32);
}

template <class P>
bool same(const P& a, const P& b) {
  return bits(a.x) == bits(b.x) && bits(a.y) == bits(b.y) && bits(a.z) == bits(b.z);
}

constexpr std::size_t kGrain = 1 << 15;  // corners per task

// Each of n points' representative: the first point with the same coordinates (rep[i] <= i).
// `corner(i)` gives point i (a Vec3 or a Float3). `unique`: how many points are their own
// representative.
template <class Corner>
std::vector<std::uint32_t> representatives(std::size_t n, const Corner& corner,
                                           std::size_t& unique_points) {
  using P = std::decay_t<decltype(corner(0))>;
  if (n >= 0xffffffffull) throw GeometryError("more than 4,294,967,294 triangle corners");
  // Buckets of ~4,096 corners (~1,000 vertices): each bucket's table stays in the cache.
  const int bucket_bits = static_cast<int>(std::min<std::size_t>(std::bit_width(n / 4096), 16));
  const std::size_t buckets = std::size_t{1} << bucket_bits;
  const std::size_t chunks = (n + kGrain - 1) / kGrain;
  std::vector<std::uint32_t> count(chunks * buckets, 0);  // per chunk, per bucket
  auto bucket_of = [&](std::uint64_t h) {
    return bucket_bits ? static_cast<std::size_t>(h >> (64 - bucket_bits)) : 0;
  };
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::uint32_t* cnt = count.data() + c * buckets;
    for (std::size_t i = c * kGrain, e = std::min(n, i + kGrain); i < e; ++i) {
      ++cnt[bucket_of(hash_of(corner(i)))];
    }
  });
  // Counting sort by bucket, stable: within a bucket corners stay in file order.
  std::vector<std::size_t> start(buckets + 1, 0);
  std::vector<std::uint32_t> offset(chunks * buckets);
  {
    std::size_t at = 0;
    for (std::size_t b = 0; b < buckets; ++b) {
      start[b] = at;
      for (std::size_t c = 0; c < chunks; ++c) {
        offset[c * buckets + b] = static_cast<std::uint32_t>(at);
        at += count[c * buckets + b];
      }
    }
    start[buckets] = at;
  }
  // Each corner with its coordinates goes to its bucket, so a bucket is welded from memory
  // that is contiguous and in the cache, not by random reads across the whole soup.
  struct Entry {
    P p;
    std::uint32_t index;
    std::uint32_t hash;  // the low bits (the top ones chose the bucket)
  };
  // Every entry is written below: the buffer is not zeroed first (a pass over n · 20 bytes).
  const std::unique_ptr<Entry[]> sorted(new Entry[n]);
  advise_huge_pages(sorted.get(), n * sizeof(Entry));
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::uint32_t* off = offset.data() + c * buckets;
    for (std::size_t i = c * kGrain, e = std::min(n, i + kGrain); i < e; ++i) {
      const P p = corner(i);
      const std::uint64_t h = hash_of(p);  // again: cheaper than storing it
      sorted[off[bucket_of(h)]++] = {p, static_cast<std::uint32_t>(i),
                                     static_cast<std::uint32_t>(h)};
    }
  });
  // Each corner's representative: the first corner with the same coordinates.
  std::vector<std::uint32_t> rep;
  resize_filled(rep, n);
  std::vector<std::size_t> unique(buckets, 0);  // vertices per bucket
  tbb::parallel_for(std::size_t{0}, buckets, [&](std::size_t b) {
    const std::size_t lo = start[b], hi = start[b + 1];
    if (lo == hi) return;
    const std::size_t size = std::bit_ceil(2 * (hi - lo));
    constexpr std::uint32_t kEmpty = 0xffffffffu;
    std::vector<std::uint32_t> table(size, kEmpty);  // positions in `sorted`
    for (std::size_t k = lo; k < hi; ++k) {
      const Entry& e = sorted[k];
      for (std::size_t s = e.hash & (size - 1);; s = (s + 1) & (size - 1)) {
        const std::uint32_t j = table[s];
        if (j == kEmpty) {
          table[s] = static_cast<std::uint32_t>(k);
          rep[e.index] = e.index;
          ++unique[b];
          break;
        }
        if (sorted[j].hash == e.hash && same(sorted[j].p, e.p)) {
          rep[e.index] = sorted[j].index;
          break;
        }
      }
    }
  });
  unique_points = 0;
  for (const std::size_t u : unique) unique_points += u;
  return rep;
}

// A triangle soup of n corners (n a multiple of 3) welded: representatives, then vertex numbers
// in order of first appearance.
template <class Corner>
TriangleMesh weld_soup(std::size_t n, const Corner& corner) {
  std::size_t vertices = 0;
  std::vector<std::uint32_t> rep = representatives(n, corner, vertices);
  // Vertex numbers in order of first appearance, written over `rep` in one pass: a corner's
  // representative comes before it (or is itself), so its slot already holds the number.
  TriangleMesh mesh;
  mesh.vertices.reserve(vertices);
  mesh.triangles.reserve(n / 3);
  std::uint32_t* id = rep.data();
  for (std::size_t t = 0; t < n; t += 3) {
    for (std::size_t i = t; i < t + 3; ++i) {
      if (id[i] == i) {
        id[i] = static_cast<std::uint32_t>(mesh.vertices.size());
        mesh.vertices.push_back(vertex_of(corner(i)));
      } else {
        id[i] = id[id[i]];
      }
    }
    const std::uint32_t a = id[t], b = id[t + 1], c = id[t + 2];
    if (a == b || b == c || a == c) continue;  // degenerate: two corners coincide
    mesh.triangles.push_back({a, b, c});
  }
  return mesh;
}

}  // namespace

TriangleMesh weld_corners(const std::vector<Vec3>& corners) {
  return weld_soup(corners.size() - corners.size() % 3, [&](std::size_t i) { return corners[i]; });
}

TriangleMesh weld_indexed(const std::vector<Vec3>& points,
                          const std::vector<std::uint32_t>& corners) {
  if (corners.size() >= 0xffffffffull)
    throw GeometryError("more than 4,294,967,294 triangle corners");
  std::size_t unique_points = 0;
  const std::vector<std::uint32_t> rep = representatives(
      points.size(), [&](std::size_t i) { return points[i]; }, unique_points);
  // Numbered in order of first use by a corner, as weld_corners numbers them.
  constexpr std::uint32_t kNone = 0xffffffffu;
  std::vector<std::uint32_t> id(points.size(), kNone);
  TriangleMesh mesh;
  mesh.vertices.reserve(unique_points);
  mesh.triangles.reserve(corners.size() / 3);
  for (std::size_t t = 0; t + 3 <= corners.size(); t += 3) {
    std::uint32_t v[3];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t c = rep[corners[t + k]];
      if (id[c] == kNone) {
        id[c] = static_cast<std::uint32_t>(mesh.vertices.size());
        mesh.vertices.push_back(vertex_of(points[c]));
      }
      v[k] = id[c];
    }
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
    mesh.triangles.push_back({v[0], v[1], v[2]});
  }
  return mesh;
}

// A binary STL welded in two levels. Each chunk of triangles (read into a scratch buffer of its
// thread: the file is never held whole) is welded first on its own, in a table that stays in
// the cache: neighbouring triangles share most corners, so a chunk of 3·K corners leaves some
// K/2 points. Those points, listed chunk by chunk in order of first use, are then welded with
// one another (representatives), which numbers the vertices in order of first use as
// weld_corners does. The triangles array holds each corner's point in its chunk until the end,
// then its vertex.
namespace {
constexpr std::size_t kChunk = 1 << 14;  // triangles: 800 KB of records, 48k corners
constexpr std::size_t kSlots = 1 << 17;  // a chunk's table, at most 3/8 full
constexpr std::uint32_t kEmpty = 0xffffffffu;

// The second level: the runs' points (each run's in order of first use) in one list, welded with
// one another (representatives), which numbers the vertices in order of first use as
// weld_corners does. `remap(r, vid)` then renumbers run r's triangles in `mesh` (vid: run r's
// point -> vertex; runs in parallel) and says whether any came out degenerate; those are dropped.
template <class P, class Remap>
void join_points(std::vector<std::vector<P>>& points, TriangleMesh& mesh, const Remap& remap) {
  const std::size_t runs = points.size();
  std::vector<std::size_t> offset(runs + 1, 0);
  for (std::size_t c = 0; c < runs; ++c) offset[c + 1] = offset[c] + points[c].size();
  const std::size_t total = offset[runs];
  const std::unique_ptr<P[]> all(new P[total]);  // filled below, not zeroed first
  advise_huge_pages(all.get(), total * sizeof(P));
  tbb::parallel_for(std::size_t{0}, runs, [&](std::size_t c) {
    std::copy(points[c].begin(), points[c].end(), all.get() + offset[c]);
    std::vector<P>().swap(points[c]);
  });
  std::size_t vertices = 0;
  std::vector<std::uint32_t> id = representatives(
      total, [&](std::size_t i) { return all[i]; }, vertices);
  // A point's vertex: numbered when it is its own representative (the first of its
  // coordinates); `id` is written over the representatives, which come first.
  mesh.vertices.reserve(vertices);
  advise_huge_pages(mesh.vertices.data(), vertices * sizeof(Vec3));
  for (std::size_t i = 0; i < total; ++i) {
    if (id[i] == i) {
      id[i] = static_cast<std::uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back(vertex_of(all[i]));
    } else {
      id[i] = id[id[i]];
    }
  }
  std::atomic<bool> degenerate{false};
  tbb::parallel_for(std::size_t{0}, runs, [&](std::size_t c) {
    if (remap(c, id.data() + offset[c])) degenerate = true;
  });
  if (degenerate)  // two corners coincide: the triangle is dropped
    std::erase_if(mesh.triangles,
                  [](const auto& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; });
}

}  // namespace

TriangleMesh weld_binary_stl(const StlRecords& records, std::size_t count,
                             std::size_t& first_invalid, double limit) {
  if (3 * count >= 0xffffffffull) throw GeometryError("more than 4,294,967,294 triangle corners");
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  struct Scratch {
    std::unique_ptr<char[]> bytes{new char[50 * kChunk]};  // only read_stl's pieces fill it
    std::vector<std::uint32_t> table = std::vector<std::uint32_t>(kSlots, kEmpty);
    std::vector<std::uint32_t> used;  // the table's filled slots, emptied after each chunk
  };
  tbb::enumerable_thread_specific<Scratch> scratch;
  std::vector<std::vector<Float3>> points(chunks);  // each chunk's, in order of first use
  TriangleMesh mesh;
  resize_filled(mesh.triangles, count);
  std::atomic<std::size_t> bad{count};
  // A coordinate is valid when |x| <= limit: for a float, when its bits without the sign are at
  // most those of the largest float <= limit (NaN's and infinity's bits are above every finite
  // float's).
  float limit_f = limit >= FLT_MAX ? FLT_MAX : static_cast<float>(limit);
  if (static_cast<double>(limit_f) > limit) limit_f = std::nextafter(limit_f, 0.0f);
  const std::uint32_t limit_bits = bits(limit_f) & 0x7fffffffu;
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    Scratch& s = scratch.local();
    const std::size_t t0 = c * kChunk, n = std::min(count, t0 + kChunk) - t0;
    const char* rec = records(t0, n, s.bytes.get());
    std::vector<Float3>& pts = points[c];
    pts.reserve(n);
    // A corner is its coordinates' bits with -0 as +0 (a point is stored so), compared as such.
    // The previous triangle's corners and points are looked at first: in a mesh's file order
    // neighbouring triangles share corners (strips, fans), so most corners are found there
    // without hashing.
    struct Key {
      std::uint32_t x, y, z;
    };
    auto equal = [](const Key& a, const Key& b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
    Key prev[3] = {};
    std::uint32_t prev_id[3] = {kEmpty, kEmpty, kEmpty};
    for (std::size_t t = 0; t < n; ++t) {
      std::uint32_t raw[9];
      std::memcpy(raw, rec + 50 * t + 12, 36);
      std::uint32_t widest = 0;
      for (std::uint32_t& b : raw) {
        widest = std::max(widest, b & 0x7fffffffu);
        if ((b & 0x7fffffffu) == 0) b = 0;  // -0 as +0
      }
      if (widest > limit_bits) {  // not finite or beyond the limit
        std::size_t was = bad.load();
        while (t0 + t < was && !bad.compare_exchange_weak(was, t0 + t)) {
        }
      }
      std::uint32_t ids[3];
      for (int k = 0; k < 3; ++k) {
        const Key key{raw[3 * k], raw[3 * k + 1], raw[3 * k + 2]};
        std::uint32_t id = kEmpty;
        for (int q = 0; q < 3; ++q)
          if (prev_id[q] != kEmpty && equal(key, prev[q])) id = prev_id[q];
        if (id == kEmpty) {
          Float3 p;
          std::memcpy(&p, &key, 12);
          std::uint64_t h = (std::uint64_t{key.x} << 32 | key.y) * 0x9E3779B97F4A7C15ull;
          h = (h ^ (h >> 31) ^ key.z) * 0x94D049BB133111EBull;
          for (std::size_t slot = (h ^ (h >> 32)) & (kSlots - 1);;
               slot = (slot + 1) & (kSlots - 1)) {
            const std::uint32_t j = s.table[slot];
            if (j == kEmpty) {
              id = static_cast<std::uint32_t>(pts.size());
              s.table[slot] = id;
              s.used.push_back(static_cast<std::uint32_t>(slot));
              pts.push_back(p);
              break;
            }
            Key other;
            std::memcpy(&other, &pts[j], 12);
            if (equal(other, key)) {
              id = j;
              break;
            }
          }
        }
        ids[k] = id;
      }
      for (int k = 0; k < 3; ++k) {
        mesh.triangles[t0 + t][k] = ids[k];
        prev_id[k] = ids[k];
        prev[k] = {raw[3 * k], raw[3 * k + 1], raw[3 * k + 2]};
      }
    }
    for (const std::uint32_t slot : s.used) s.table[slot] = kEmpty;
    s.used.clear();
  });
  first_invalid = bad.load();
  join_points(points, mesh, [&](std::size_t c, const std::uint32_t* vid) {
    bool any = false;
    for (std::size_t t = c * kChunk, e = std::min(count, t + kChunk); t < e; ++t) {
      auto& tri = mesh.triangles[t];
      tri = {vid[tri[0]], vid[tri[1]], vid[tri[2]]};
      any = any || tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
    }
    return any;
  });
  return mesh;
}

void weld_run(const Vec3* corners, std::size_t n, WeldedRun& run, WeldTable& s) {
  if (n >= 0xffffffffull) throw GeometryError("more than 4,294,967,294 triangle corners");
  // At most a third full.
  const std::size_t slots = std::max<std::size_t>(std::bit_ceil(3 * n), 1024);
  if (s.slots.size() < slots) s.slots.assign(slots, kEmpty);
  const std::size_t mask = slots - 1;
  run.points.clear();
  run.points.reserve(n / 2 + 3);
  run.triangles.resize(n / 3);
  for (std::size_t i = 0; i + 3 <= n; i += 3) {
    for (std::size_t k = 0; k < 3; ++k) {
      const Vec3& p = corners[i + k];
      std::uint32_t id = kEmpty;
      for (std::size_t slot = hash_of(p) & mask;; slot = (slot + 1) & mask) {
        const std::uint32_t j = s.slots[slot];
        if (j == kEmpty) {
          id = static_cast<std::uint32_t>(run.points.size());
          s.slots[slot] = id;
          s.used.push_back(static_cast<std::uint32_t>(slot));
          run.points.push_back(p);
          break;
        }
        if (same(run.points[j], p)) {
          id = j;
          break;
        }
      }
      run.triangles[i / 3][k] = id;
    }
  }
  for (const std::uint32_t slot : s.used) s.slots[slot] = kEmpty;
  s.used.clear();
}

TriangleMesh join_runs(std::vector<WeldedRun>& runs) {
  std::vector<std::size_t> first(runs.size() + 1, 0);  // run r's triangles in the mesh
  for (std::size_t r = 0; r < runs.size(); ++r) first[r + 1] = first[r] + runs[r].triangles.size();
  if (3 * first.back() >= 0xffffffffull)
    throw GeometryError("more than 4,294,967,294 triangle corners");
  TriangleMesh mesh;
  resize_filled(mesh.triangles, first.back());
  std::vector<std::vector<Vec3>> points(runs.size());
  for (std::size_t r = 0; r < runs.size(); ++r) points[r].swap(runs[r].points);
  join_points(points, mesh, [&](std::size_t r, const std::uint32_t* vid) {
    bool any = false;
    std::array<std::uint32_t, 3>* out = mesh.triangles.data() + first[r];
    for (const auto& t : runs[r].triangles) {
      const std::array<std::uint32_t, 3> tri{vid[t[0]], vid[t[1]], vid[t[2]]};
      *out++ = tri;
      any = any || tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
    }
    std::vector<std::array<std::uint32_t, 3>>().swap(runs[r].triangles);
    return any;
  });
  return mesh;
}

// The vertices welded, not the corners (a third as many): the same mesh (weld_indexed).
TriangleMesh weld(const TriangleMesh& mesh) {
  std::vector<std::uint32_t> corners(3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) corners[3 * t + k] = mesh.triangles[t][k];
  return weld_indexed(mesh.vertices, corners);
}

}  // namespace trellis
