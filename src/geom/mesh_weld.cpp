// Welding a triangle soup (STL stores every corner of every triangle) into an indexed mesh, in
// parallel and without a node-based map: corners are hashed, bucketed by the hash's top bits
// (a counting sort), and each bucket, small enough for the cache, is welded by its own
// open-addressing table. Equal coordinates (with -0 == +0) give one vertex; vertices are numbered
// in the order of their first corner, so the result does not depend on the thread count.
#include "mesh_weld.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "trellis/core/error.hpp"
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

Vec3 widen(const Vec3& v) {
  return v;
}
Vec3 widen(const Float3& v) {
  return {v.x, v.y, v.z};
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
// `corner(i)` gives point i (a Vec3 or a Float3); `seen(i, p)` is called once for every point,
// in parallel (the binary STL reader checks the coordinates there, in the pass that reads them
// anyway). `unique`: how many points are their own representative.
template <class Corner, class Seen>
std::vector<std::uint32_t> representatives(std::size_t n, const Corner& corner, const Seen& seen,
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
      const P p = corner(i);
      seen(i, p);
      ++cnt[bucket_of(hash_of(p))];
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
  std::vector<Entry> sorted(n);
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
  std::vector<std::uint32_t> rep(n);
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
template <class Corner, class Seen>
TriangleMesh weld_soup(std::size_t n, const Corner& corner, const Seen& seen) {
  std::size_t vertices = 0;
  std::vector<std::uint32_t> rep = representatives(n, corner, seen, vertices);
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
        const Vec3 v = widen(corner(i));
        mesh.vertices.push_back({v.x == 0 ? 0.0 : v.x, v.y == 0 ? 0.0 : v.y, v.z == 0 ? 0.0 : v.z});
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
  return weld_soup(
      corners.size() - corners.size() % 3, [&](std::size_t i) { return corners[i]; },
      [](std::size_t, const Vec3&) {});
}

TriangleMesh weld_indexed(const std::vector<Vec3>& points,
                          const std::vector<std::uint32_t>& corners) {
  if (corners.size() >= 0xffffffffull)
    throw GeometryError("more than 4,294,967,294 triangle corners");
  std::size_t unique_points = 0;
  const std::vector<std::uint32_t> rep = representatives(
      points.size(), [&](std::size_t i) { return points[i]; }, [](std::size_t, const Vec3&) {},
      unique_points);
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
        const Vec3 p = points[c];
        mesh.vertices.push_back({p.x == 0 ? 0.0 : p.x, p.y == 0 ? 0.0 : p.y, p.z == 0 ? 0.0 : p.z});
      }
      v[k] = id[c];
    }
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
    mesh.triangles.push_back({v[0], v[1], v[2]});
  }
  return mesh;
}

TriangleMesh weld_binary_stl(const char* records, std::size_t count, std::size_t& first_invalid,
                             double limit) {
  std::atomic<std::size_t> bad{count};
  TriangleMesh mesh = weld_soup(
      3 * count,
      [records](std::size_t i) {
        Float3 f;
        std::memcpy(&f, records + 50 * (i / 3) + 12 + 12 * (i % 3), 12);
        return f;
      },
      [&](std::size_t i, const Float3& f) {
        // NaN fails every comparison, infinity the bound: both invalid.
        if (std::abs(f.x) <= limit && std::abs(f.y) <= limit && std::abs(f.z) <= limit) return;
        std::size_t t = i / 3, was = bad.load();
        while (t < was && !bad.compare_exchange_weak(was, t)) {
        }
      });
  first_invalid = bad.load();
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
