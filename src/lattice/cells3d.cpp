#include "trellis/lattice/cells3d.hpp"

#include <array>
#include <cmath>
#include <numbers>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

struct CellName {
  UnitCell cell;
  const char* name;
};
constexpr CellName kCells[] = {{UnitCell::Cubic, "cubic"},
                               {UnitCell::Bcc, "bcc"},
                               {UnitCell::Fcc, "fcc"},
                               {UnitCell::Octet, "octet"},
                               {UnitCell::Diamond, "diamond"},
                               {UnitCell::Kelvin, "kelvin"},
                               {UnitCell::RhombicDodecahedron, "rhombic-dodecahedron"}};

using Seg = std::array<Vec3, 2>;  // in units of the cell side

void add(std::vector<Seg>& out, Vec3 a, Vec3 b) {
  out.push_back({a, b});
}

std::vector<Vec3> corners() {
  std::vector<Vec3> c;
  for (int i = 0; i < 8; ++i)
    c.push_back({double(i & 1), double((i >> 1) & 1), double((i >> 2) & 1)});
  return c;
}

// Face centres with the four corners of each face.
void fcc_struts(std::vector<Seg>& out) {
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      Vec3 centre{0.5, 0.5, 0.5};
      (&centre.x)[axis] = side;
      for (int k = 0; k < 4; ++k) {
        Vec3 corner{};
        (&corner.x)[axis] = side;
        (&corner.x)[(axis + 1) % 3] = k & 1;
        (&corner.x)[(axis + 2) % 3] = (k >> 1) & 1;
        add(out, centre, corner);
      }
    }
}

// Edges of a polyhedron given by vertices (units of cell/4) joined when at distance d (same
// units), translated to `centre` (cell/4 units), kept if inside the cell [0,4]^3.
void polyhedron(std::vector<Seg>& out, const std::vector<std::array<int, 3>>& verts, int d2,
                std::array<int, 3> centre) {
  for (std::size_t i = 0; i < verts.size(); ++i)
    for (std::size_t j = i + 1; j < verts.size(); ++j) {
      int dd = 0;
      for (int k = 0; k < 3; ++k) dd += (verts[i][k] - verts[j][k]) * (verts[i][k] - verts[j][k]);
      if (dd != d2) continue;
      std::array<int, 3> a{}, b{};
      bool inside = true;
      for (int k = 0; k < 3; ++k) {
        a[k] = verts[i][k] + centre[k];
        b[k] = verts[j][k] + centre[k];
        inside &= a[k] >= 0 && a[k] <= 4 && b[k] >= 0 && b[k] <= 4;
      }
      if (inside)
        add(out, {a[0] / 4.0, a[1] / 4.0, a[2] / 4.0}, {b[0] / 4.0, b[1] / 4.0, b[2] / 4.0});
    }
}

std::vector<Seg> cell_struts(UnitCell cell) {
  std::vector<Seg> out;
  switch (cell) {
    case UnitCell::Cubic:
      for (const Vec3 c : corners())
        for (int axis = 0; axis < 3; ++axis)
          if ((&c.x)[axis] == 0) {
            Vec3 d = c;
            (&d.x)[axis] = 1;
            add(out, c, d);
          }
      break;
    case UnitCell::Bcc:
      for (const Vec3 c : corners()) add(out, {0.5, 0.5, 0.5}, c);
      break;
    case UnitCell::Fcc:
      fcc_struts(out);
      break;
    case UnitCell::Octet: {
      fcc_struts(out);
      std::vector<Vec3> faces;
      for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
          Vec3 c{0.5, 0.5, 0.5};
          (&c.x)[axis] = side;
          faces.push_back(c);
        }
      for (std::size_t i = 0; i < faces.size(); ++i)
        for (std::size_t j = i + 1; j < faces.size(); ++j)
          if (i / 2 != j / 2) add(out, faces[i], faces[j]);  // not the opposite face
      break;
    }
    case UnitCell::Diamond: {
      // Diamond cubic: the fcc sites f shifted by (¼,¼,¼) bond to f, f+(½,½,0), f+(½,0,½) and
      // f+(0,½,½); the four shifted sites inside the cell come from these f.
      const Vec3 fs[4] = {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}};
      const Vec3 bonds[4] = {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}};
      for (const Vec3 f : fs)
        for (const Vec3 b : bonds) add(out, f + Vec3{0.25, 0.25, 0.25}, f + b);
      break;
    }
    case UnitCell::Kelvin: {
      // Truncated octahedron: all permutations of (0, ±1, ±2), edge √2, in bcc packing.
      std::vector<std::array<int, 3>> v;
      const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
      for (const auto& p : perms)
        for (int s1 = -1; s1 <= 1; s1 += 2)
          for (int s2 = -1; s2 <= 1; s2 += 2) {
            int vals[3] = {0, s1 * 1, s2 * 2};
            std::array<int, 3> q{};
            for (int k = 0; k < 3; ++k) q[p[k]] = vals[k];
            v.push_back(q);
          }
      polyhedron(out, v, 2, {2, 2, 2});
      for (int i = 0; i < 8; ++i)
        polyhedron(out, v, 2, {4 * (i & 1), 4 * ((i >> 1) & 1), 4 * ((i >> 2) & 1)});
      break;
    }
    case UnitCell::RhombicDodecahedron: {
      // (±1, ±1, ±1) and (±2, 0, 0) permutations; edges join the two kinds (length √3).
      std::vector<std::array<int, 3>> v;
      for (int i = 0; i < 8; ++i)
        v.push_back({(i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1});
      for (int axis = 0; axis < 3; ++axis)
        for (int s = -2; s <= 2; s += 4) {
          std::array<int, 3> q{0, 0, 0};
          q[axis] = s;
          v.push_back(q);
        }
      for (int i = 0; i < 8; ++i)
        polyhedron(out, v, 3, {4 * (i & 1), 4 * ((i >> 1) & 1), 4 * ((i >> 2) & 1)});
      for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
          std::array<int, 3> c{2, 2, 2};
          c[axis] = 4 * side;
          polyhedron(out, v, 3, c);
        }
      break;
    }
  }
  return out;
}

}  // namespace

UnitCell unit_cell_from_string(const std::string& name) {
  for (const auto& c : kCells)
    if (name == c.name) return c.cell;
  std::string names;
  for (const auto& n : unit_cell_names()) names += (names.empty() ? "" : ", ") + n;
  throw SettingError("unknown unit cell '" + name + "' (expected one of: " + names + ")");
}

std::string to_string(UnitCell cell) {
  for (const auto& c : kCells)
    if (c.cell == cell) return c.name;
  return "?";
}

std::vector<std::string> unit_cell_names() {
  std::vector<std::string> out;
  for (const auto& c : kCells) out.push_back(c.name);
  return out;
}

Graph cell_lattice(const CellLatticeParams& p) {
  if (!(p.size > 0) || !std::isfinite(p.size) || p.size > 1e5)
    throw SettingError("the cell size must be in (0, 100000] mm");
  for (int n : {p.nx, p.ny, p.nz})
    if (n < 1 || n > 1000) throw SettingError("cell counts must be in 1..1000");
  const std::vector<Seg> unit = cell_struts(p.cell);
  const double cells = double(p.nx) * p.ny * p.nz;
  if (cells * static_cast<double>(unit.size()) > 1e7)
    throw SettingError("more than 10 million struts: use fewer cells");
  Graph raw;
  raw.nodes.reserve(static_cast<std::size_t>(cells * unit.size() * 2));
  for (int k = 0; k < p.nz; ++k)
    for (int j = 0; j < p.ny; ++j)
      for (int i = 0; i < p.nx; ++i)
        for (const auto& s : unit) {
          const Vec3 o{double(i), double(j), double(k)};
          const auto a = static_cast<NodeId>(raw.nodes.size());
          raw.nodes.push_back((s[0] + o) * p.size);
          raw.nodes.push_back((s[1] + o) * p.size);
          raw.edges.push_back({a, a + 1, 0, false});
        }
  Diagnostics quiet;  // shared faces give duplicates by design
  CleanOptions clean;
  clean.merge_tolerance = p.size * 1e-6;
  clean.split_t_junctions = false;
  return clean_graph(raw, clean, quiet);
}

void assign_materials(Graph& g, MaterialRule rule, double tolerance, double cone_half_angle_deg) {
  std::vector<int> comp;
  if (rule == MaterialRule::Component) comp = connected_components(g);
  const double cos_cone = std::cos(cone_half_angle_deg * std::numbers::pi / 180);
  for (auto& e : g.edges) {
    const Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
    switch (rule) {
      case MaterialRule::None:
        e.material = 0;
        break;
      case MaterialRule::XyPlane:
        e.material = std::abs(a.z - b.z) <= tolerance ? 0 : 1;
        break;
      case MaterialRule::Component:
        e.material = std::max(0, comp[e.a]);
        break;
      case MaterialRule::Vertical: {
        const double len = distance(a, b);
        e.material = len > 0 && std::abs(a.z - b.z) >= len * cos_cone ? 1 : 0;
        break;
      }
    }
  }
}

}  // namespace trellis
