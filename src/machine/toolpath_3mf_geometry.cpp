// The build's geometry in a 3MF toolpath package: the objects and build items its toolpath's
// parts name. Toolpath Extension v1.0 Part II §1.1.1: a layer's <part uuid> is "the UUID of the
// referenced build item present in the package", so every part a path names gets a build item
// carrying that UUID (Production Extension p:UUID). The geometry is the design's where the
// route has it — a triangle mesh (3MF Core v1.4 §4.1) and/or a strut lattice as the Beam
// Lattice Extension v1.2 writes one (Chapter 2: a <b:beamlattice> in the object's <mesh>, which
// may then hold no triangles) — and otherwise the beads the toolpath prints: a beam per path
// segment, of half the path's width. Part of the toolpath3mf module.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "toolpath_3mf_module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/laser.hpp"

namespace trellis::impl {

namespace {

using namespace tp3mf;

// Beam Lattice §2.1: a consumer ignores beams shorter than `minlength`; none shorter is written.
constexpr double kMinBeamLength = 1e-4;  // mm

void vertices_xml(std::string& out, const std::vector<Vec3>& vertices) {
  out += "<vertices>\n";
  for (const Vec3& v : vertices)
    fmt::format_to(std::back_inserter(out), "<vertex x=\"{}\" y=\"{}\" z=\"{}\"/>\n", num(v.x),
                   num(v.y), num(v.z));
  out += "</vertices>";
}

// The radius most beams have: the lattice's default (§2.1 `radius`), left off those beams.
double common_radius(const BeamLattice3mf& l) {
  std::map<double, std::size_t> count;
  for (const auto& b : l.beams) ++count[b.r1];
  return std::max_element(count.begin(), count.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; })
      ->first;
}

// §2.1: the beams (each checked: two distinct vertices of the mesh at least kMinBeamLength
// apart, positive radii), then a beam set per material when there is more than material 0
// (§2.1.4; read back as the strut's material by lattice/io.hpp).
void beam_lattice_xml(std::string& out, const BeamLattice3mf& l, const std::string& object) {
  const double radius = common_radius(l);
  out += fmt::format("<b:beamlattice minlength=\"{}\" radius=\"{}\" cap=\"sphere\"><b:beams>\n",
                     num(kMinBeamLength), num(radius));
  std::map<int, std::vector<std::size_t>> sets;
  for (std::size_t i = 0; i < l.beams.size(); ++i) {
    const auto& b = l.beams[i];
    const std::size_t n = l.vertices.size();
    if (b.v1 >= n || b.v2 >= n || b.v1 == b.v2 ||
        !(distance(l.vertices[b.v1], l.vertices[b.v2]) >= kMinBeamLength))
      throw GeometryError(
          fmt::format("3MF toolpath: {} beam {} joins vertices {} and {} of {}, "
                      "which are not two points at least {} mm apart",
                      object, i, b.v1, b.v2, n, kMinBeamLength));
    if (!(b.r1 > 0) || !(b.r2 > 0) || !std::isfinite(b.r1) || !std::isfinite(b.r2))
      throw GeometryError(
          fmt::format("3MF toolpath: {} beam {} has a radius that is not positive", object, i));
    fmt::format_to(std::back_inserter(out), "<b:beam v1=\"{}\" v2=\"{}\"", b.v1, b.v2);
    // §2.1.1.1: r1 defaults to the lattice's radius, r2 to r1.
    if (b.r1 != radius || b.r2 != b.r1) out += fmt::format(" r1=\"{}\"", num(b.r1));
    if (b.r2 != b.r1) out += fmt::format(" r2=\"{}\"", num(b.r2));
    out += "/>\n";
    sets[b.material].push_back(i);
  }
  out += "</b:beams>";
  if (sets.size() > 1 || sets.begin()->first != 0) {
    out += "<b:beamsets>";
    for (const auto& [material, refs] : sets) {
      out += fmt::format("<b:beamset name=\"material {0}\" identifier=\"{0}\">", material);
      for (std::size_t r : refs)
        fmt::format_to(std::back_inserter(out), "<b:ref index=\"{}\"/>", r);
      out += "</b:beamset>";
    }
    out += "</b:beamsets>";
  }
  out += "</b:beamlattice>";
}

// The beads part `part` prints: a beam per segment of its paths, radius half the path's width
// (else options.bead_width; a laser path's: the spot's; else its height), vertices shared where
// paths meet exactly.
BeamLattice3mf beads_of(const Toolpath& tp, int part, const Toolpath3mfOptions& o) {
  // Each laser's spot (Path::tool): the profile's lasers, else those the toolpath declares (a
  // build file read back and written again).
  std::vector<double> spots;
  if (o.laser)
    for (const LaserParameters& l : laser_parameters(*o.laser)) spots.push_back(l.spot_diameter);
  else
    for (const LaserParameters& l : tp.lasers) spots.push_back(l.spot_diameter);
  if (spots.empty() && o.laser) spots.push_back(o.laser->spot_diameter);
  const auto spot = [&](const Path& p) {
    return spots.empty() ? 0.0
                         : spots[static_cast<std::size_t>(
                               std::clamp(p.tool, 0, static_cast<int>(spots.size()) - 1))];
  };
  const auto width = [&](const Path& p) {
    return p.width > 0                        ? p.width
           : p.power > 0 && spot(p) > 0       ? spot(p)
           : p.power <= 0 && o.bead_width > 0 ? o.bead_width
                                              : p.height;
  };
  BeamLattice3mf l;
  std::map<std::tuple<double, double, double>, std::uint32_t> index;
  auto vertex = [&](const Vec3& p) {
    const auto [it, fresh] =
        index.emplace(std::tuple{p.x, p.y, p.z}, static_cast<std::uint32_t>(l.vertices.size()));
    if (fresh) l.vertices.push_back(p);
    return it->second;
  };
  for (const Layer& layer : tp.layers)
    for (const Path& p : layer.paths) {
      const double r = width(p) / 2;
      if (p.part != part || !(r > 0)) continue;
      for (std::size_t k = 1; k < p.points.size(); ++k)
        if (distance(p.points[k - 1], p.points[k]) >= kMinBeamLength)
          l.beams.push_back({vertex(p.points[k - 1]), vertex(p.points[k]), r, r, 0});
    }
  return l;
}

struct Object {
  const TriangleMesh* mesh = nullptr;
  const BeamLattice3mf* lattice = nullptr;
  bool surface = false;
};

std::string object_xml(const Object& o, int id, const std::string& uuid, const std::string& name) {
  // Core §4.1: "surface" objects may be open; a beam lattice only in a "model" (§2 of the
  // Beam Lattice Extension).
  std::string out = fmt::format("<object id=\"{}\" type=\"{}\" name=\"{}\" p:UUID=\"{}\"><mesh>",
                                id, o.surface && !o.lattice ? "surface" : "model", name, uuid);
  std::vector<Vec3> vertices = o.mesh ? o.mesh->vertices : std::vector<Vec3>{};
  const std::size_t offset = vertices.size();
  BeamLattice3mf shifted;
  if (o.lattice) {
    // The lattice's vertices after the mesh's; the core schema wants three at least (a lone
    // beam's mesh repeats its last one: a vertex no triangle uses, Beam Lattice §2.1.1.1).
    shifted = *o.lattice;
    vertices.insert(vertices.end(), o.lattice->vertices.begin(), o.lattice->vertices.end());
    shifted.vertices = vertices;
    for (auto& b : shifted.beams) b.v1 += offset, b.v2 += offset;
    while (!vertices.empty() && vertices.size() < 3) vertices.push_back(vertices.back());
  }
  vertices_xml(out, vertices);
  // A lattice alone has no <triangles> (Beam Lattice Chapter 2 lets its mesh have none; so its
  // Appendix D.1 example writes it).
  if (o.mesh) {
    out += "<triangles>\n";
    for (const auto& t : o.mesh->triangles)
      // Core §4.1.4.1: a triangle's three indices MUST be distinct; one that repeats a vertex
      // (marching cubes makes a few) has no area, and the surface is the same without it.
      if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        fmt::format_to(std::back_inserter(out), "<triangle v1=\"{}\" v2=\"{}\" v3=\"{}\"/>\n", t[0],
                       t[1], t[2]);
    out += "</triangles>";
  }
  if (o.lattice) beam_lattice_xml(out, shifted, name);
  return out + "</mesh></object>\n";
}

// Core §3.4.1: the matrix's 12 numbers; none for the identity.
std::string transform_attr(const Transform3mf& m) {
  if (m == kIdentity3mf) return {};
  std::string out = " transform=\"";
  for (std::size_t i = 0; i < m.size(); ++i) out += (i ? " " : "") + num(m[i] == 0 ? 0.0 : m[i]);
  return out + "\"";
}

}  // namespace

Geometry3mf geometry_xml(const Toolpath& tp, const Toolpath3mfOptions& options,
                         const std::vector<std::string>& part_uuids, const std::set<int>& parts) {
  Geometry3mf g;
  std::set<int> all = parts;
  if (options.mesh || options.lattice) all.insert(0);
  int id = 2;  // 1 is the toolpath resource
  // The objects written so far by their design (mesh, lattice): a design several parts share is
  // one object with a build item per part.
  std::map<std::pair<const TriangleMesh*, const BeamLattice3mf*>, int> written;
  for (int part : all) {
    const std::string label =
        part == 0 ? "design" : tp.part_labels[static_cast<std::size_t>(part - 1)];
    Design3mf d;
    if (part == 0)
      d = {options.mesh, options.mesh_is_surface, options.lattice, options.transform, "design"};
    else if (static_cast<std::size_t>(part) <= options.parts.size())
      d = options.parts[static_cast<std::size_t>(part - 1)];
    if (d.mesh && d.mesh->triangles.empty()) d.mesh = nullptr;
    if (d.lattice && d.lattice->beams.empty()) d.lattice = nullptr;
    BeamLattice3mf beads;
    std::string name = d.name.empty() ? label : d.name;
    if (!d.mesh && !d.lattice) {
      beads = beads_of(tp, part, options);
      d = {nullptr, false, &beads, kIdentity3mf, label + " (printed beads)"};
      name = d.name;
      if (beads.beams.empty())
        throw GeometryError(
            fmt::format("3MF toolpath: part '{}' has no geometry to be its build item (Part II "
                        "§1.1.1): no triangles, no struts and no path with a width",
                        label));
    }
    int object = 0;
    const auto key = std::pair{d.mesh, d.lattice};
    if (d.lattice == &beads || !written.count(key)) {
      object = id++;
      if (d.lattice != &beads) written[key] = object;
      g.beams = g.beams || d.lattice;
      g.objects +=
          object_xml({d.mesh, d.lattice, d.mesh_is_surface}, object,
                     uuid_of(part == 0 ? "object" : fmt::format("object {}", part)), esc(name));
    } else {
      object = written[key];
    }
    // Core §3.4.1: partnumber, "a unique identifier for the item": the part's label.
    g.items += fmt::format("<item objectid=\"{}\" p:UUID=\"{}\"{}{}/>", object,
                           part_uuids[static_cast<std::size_t>(part)],
                           part == 0 ? "" : fmt::format(" partnumber=\"{}\"", esc(label)),
                           transform_attr(d.transform));
  }
  return g;
}

}  // namespace trellis::impl
