#include "trellis/geom/mesh.hpp"

#include <cstring>

#include "trellis/core/file.hpp"

namespace trellis {

void TriangleMesh::add_prism(const std::vector<Vec2>& ring, double z0, double z1) {
  const auto n = static_cast<std::uint32_t>(ring.size());
  const auto base = static_cast<std::uint32_t>(vertices.size());
  for (auto p : ring) vertices.push_back({p.x, p.y, z0});
  for (auto p : ring) vertices.push_back({p.x, p.y, z1});
  for (std::uint32_t i = 1; i + 1 < n; ++i) {  // convex fan: bottom faces down, top faces up
    triangles.push_back({base, base + i + 1, base + i});
    triangles.push_back({base + n, base + n + i, base + n + i + 1});
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    triangles.push_back({base + i, base + j, base + n + j});
    triangles.push_back({base + i, base + n + j, base + n + i});
  }
}

std::string mesh_to_stl(const TriangleMesh& mesh, const std::string& header) {
  std::string out(80, '\0');
  std::memcpy(out.data(), header.data(), std::min<std::size_t>(header.size(), 80));
  const auto count = static_cast<std::uint32_t>(mesh.triangles.size());
  out.append(reinterpret_cast<const char*>(&count), 4);
  auto put = [&](double v) {
    const float f = static_cast<float>(v);
    out.append(reinterpret_cast<const char*>(&f), 4);
  };
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    const Vec3 u = b - a, v = c - a;
    Vec3 n{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
    const double len = norm(n);
    if (len > 0) n = n * (1 / len);
    for (double x : {n.x, n.y, n.z, a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z}) put(x);
    out.append(2, '\0');
  }
  return out;
}

void write_stl(const std::string& path, const TriangleMesh& mesh) {
  write_file_atomic(path, mesh_to_stl(mesh));
}

}  // namespace trellis
