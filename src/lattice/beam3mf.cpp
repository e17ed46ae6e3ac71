// 3MF Beam Lattice extension (the exchange format of nTop, Netfabb, OpenVCAD) through lib3mf,
// in the run-time module trellis_3mf (geom/mesh_3mf_module.hpp; libtrellis calls it through
// lattice/beam3mf_forward.cpp)
// 1.8's C interface: beams are struts, a beam's radius the strut radius, beam sets materials.
#include <Model/COM/NMR_DLLInterfaces.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>

#include "../geom/lib3mf_write.hpp"
#include "../geom/mesh_3mf_module.hpp"
#include "beam3mf_module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"

namespace trellis {

namespace {

using namespace NMR;

// Every lib3mf handle released on every path.
struct Handle {
  PLib3MFBase* p = nullptr;
  Handle() = default;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (p) lib3mf_release(p);
  }
};

std::string last_error(PLib3MFBase* obj) {
  DWORD code = 0;
  LPCSTR text = nullptr;
  if (obj && lib3mf_getlasterror(obj, &code, &text) == LIB3MF_OK && text)
    return std::string(": ") + text;
  return "";
}

std::string utf8(PLib3MFBase* set, bool identifier) {
  ULONG needed = 0;
  auto get = identifier ? lib3mf_beamset_getidentifierutf8 : lib3mf_beamset_getnameutf8;
  if (get(set, nullptr, 0, &needed) != LIB3MF_OK || needed == 0) return "";
  std::string s(needed + 1, '\0');
  if (get(set, s.data(), static_cast<ULONG>(s.size()), &needed) != LIB3MF_OK) return "";
  s.resize(std::strlen(s.c_str()));
  return s;
}

// The material a beam set stands for: its identifier (or name) if that is an integer 0..255,
// "material N" as written by Trellis, else the set's position among the sets.
int set_material(const std::string& identifier, const std::string& name, std::size_t index) {
  for (std::string s : {identifier, name}) {
    if (s.rfind("material ", 0) == 0) s = s.substr(9);
    char* end = nullptr;
    const long v = std::strtol(s.c_str(), &end, 10);
    if (!s.empty() && end && *end == '\0' && v >= 0 && v <= 255) return static_cast<int>(v);
  }
  return static_cast<int>(std::min<std::size_t>(index, 255));
}

struct Reader {
  const std::string& path;
  Diagnostics& diag;
  LatticeInput in;
  std::vector<double> radius_sum;  // per edge, for the tapered-beam warning
  std::size_t tapered = 0;

  [[noreturn]] void fail(const std::string& what, const std::string& element = "") const {
    throw ParseError(what, {path, 0, element});
  }

  void add_object(PLib3MFBase* object, const MODELTRANSFORM* tf, std::size_t object_index) {
    DWORD nv = 0, nb = 0, nsets = 0;
    lib3mf_meshobject_getvertexcount(object, &nv);
    lib3mf_meshobject_getbeamcount(object, &nb);
    if (nb == 0) return;
    const std::string obj = "object " + std::to_string(object_index);
    std::vector<MODELMESHVERTEX> verts(nv);
    if (nv) lib3mf_meshobject_getvertices(object, verts.data(), nv, nullptr);
    std::vector<MODELMESHBEAM> beams(nb);
    if (lib3mf_meshobject_getbeamindices(object, beams.data(), nb, nullptr) != LIB3MF_OK)
      fail("cannot read the beams" + last_error(object), obj);
    // Beam sets: a material per set; a beam in no set keeps material 0.
    std::vector<int> material(nb, 0);
    std::vector<char> in_set(nb, 0);
    lib3mf_meshobject_getbeamsetcount(object, &nsets);
    for (DWORD s = 0; s < nsets; ++s) {
      Handle set;
      if (lib3mf_meshobject_getbeamset(object, s, &set.p) != LIB3MF_OK) continue;
      const int m = set_material(utf8(set.p, true), utf8(set.p, false), s);
      DWORD count = 0;
      lib3mf_beamset_getrefcount(set.p, &count);
      std::vector<DWORD> refs(count);
      if (count) lib3mf_beamset_getrefs(set.p, refs.data(), count, nullptr);
      for (DWORD r : refs) {
        if (r >= nb)
          fail("beam set " + std::to_string(s) + " refers to beam " + std::to_string(r) + " of " +
                   std::to_string(nb),
               obj);
        if (in_set[r] && material[r] != m)
          diag.warn("beam_in_two_sets", path + ": " + obj + " beam " + std::to_string(r) +
                                            " is in beam sets of materials " +
                                            std::to_string(material[r]) + " and " +
                                            std::to_string(m) + "; the first is kept");
        if (!in_set[r]) material[r] = m;
        in_set[r] = 1;
      }
    }
    // Only vertices that beams use become nodes.
    std::map<DWORD, NodeId> node_of;
    auto node = [&](DWORD v, DWORD beam) {
      if (v >= nv)
        fail("beam " + std::to_string(beam) + " refers to vertex " + std::to_string(v) + " of " +
                 std::to_string(nv),
             obj);
      auto [it, fresh] = node_of.emplace(v, static_cast<NodeId>(in.graph.nodes.size()));
      if (fresh) {
        const float* f = verts[v].m_fPosition;
        Vec3 p{f[0], f[1], f[2]};
        if (tf) {
          const auto& m = tf->m_fFields;
          p = {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
               m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
               m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
        }
        if (!is_finite(p) || std::abs(p.x) > kMaxCoordinate || std::abs(p.y) > kMaxCoordinate ||
            std::abs(p.z) > kMaxCoordinate)
          fail("vertex " + std::to_string(v) + " is not finite or beyond ±1e6 mm", obj);
        in.graph.nodes.push_back(p);
      }
      return it->second;
    };
    for (DWORD i = 0; i < nb; ++i) {
      const MODELMESHBEAM& b = beams[i];
      Edge e;
      e.a = node(b.m_nIndices[0], i);
      e.b = node(b.m_nIndices[1], i);
      e.material = material[i];
      const double r0 = b.m_dRadius[0], r1 = b.m_dRadius[1];
      if (!(r0 > 0) || !(r1 > 0) || !std::isfinite(r0) || !std::isfinite(r1))
        fail("beam " + std::to_string(i) + " has a radius that is not positive", obj);
      if (std::abs(r0 - r1) > 1e-9 * std::max(r0, r1)) ++tapered;
      e.radius = 0.5 * (r0 + r1);
      in.graph.edges.push_back(e);
      in.edge_where.push_back(path + ": " + obj + " beam " + std::to_string(i));
    }
  }
};

}  // namespace

namespace impl {

LatticeInput read_beam_lattice_3mf(const std::string& path, Diagnostics& diag) {
  (void)read_file(path);  // a clear IoError for a missing file
  // The 3mf module's walk first (see read_3mf): places problems by part, line and column and
  // refuses what lib3mf 1.8 would read without a word.
  if (const Located3mf at = detail::module_table<Mesh3mfModule>("3mf").locate(path);
      !at.what.empty())
    throw ParseError(at.what, {path, 0, at.where});
  Handle model, reader;
  if (lib3mf_createmodel(&model.p) != LIB3MF_OK)
    throw ParseError("cannot create a 3MF model", {path});
  if (lib3mf_model_queryreader(model.p, "3mf", &reader.p) != LIB3MF_OK)
    throw ParseError("cannot create a 3MF reader" + last_error(model.p), {path});
  if (lib3mf_reader_readfromfileutf8(reader.p, path.c_str()) != LIB3MF_OK)
    throw ParseError("not a readable 3MF file" + last_error(reader.p), {path});
  Reader r{path, diag, {}, {}, 0};
  // Build items (with their transforms); without any, every mesh object as stored.
  Handle items;
  std::size_t built = 0, index = 0;
  if (lib3mf_model_getbuilditems(model.p, &items.p) == LIB3MF_OK) {
    BOOL more = false;
    while (lib3mf_builditemiterator_movenext(items.p, &more) == LIB3MF_OK && more) {
      Handle item, obj;
      if (lib3mf_builditemiterator_getcurrent(items.p, &item.p) != LIB3MF_OK) break;
      if (lib3mf_builditem_getobjectresource(item.p, &obj.p) != LIB3MF_OK || !obj.p) continue;
      BOOL is_mesh = false;
      lib3mf_object_ismeshobject(obj.p, &is_mesh);
      ++built;
      if (!is_mesh) {
        diag.warn("3mf_components_skipped",
                  path + ": build item " + std::to_string(built - 1) +
                      " is a components object; only mesh objects' beams are read");
        continue;
      }
      BOOL has_tf = false;
      MODELTRANSFORM tf;
      lib3mf_builditem_hasobjecttransform(item.p, &has_tf);
      if (has_tf) lib3mf_builditem_getobjecttransform(item.p, &tf);
      r.add_object(obj.p, has_tf ? &tf : nullptr, index++);
    }
  }
  if (built == 0) {
    Handle objects;
    if (lib3mf_model_getmeshobjects(model.p, &objects.p) == LIB3MF_OK) {
      BOOL more = false;
      while (lib3mf_resourceiterator_movenext(objects.p, &more) == LIB3MF_OK && more) {
        Handle res;
        if (lib3mf_resourceiterator_getcurrent(objects.p, &res.p) != LIB3MF_OK) break;
        r.add_object(res.p, nullptr, index++);
      }
    }
  }
  if (r.in.graph.edges.empty())
    throw ParseError("no beams found (a 3MF lattice needs the Beam Lattice extension)", {path});
  if (r.tapered)
    diag.warn("tapered_beams_averaged", path + ": " + std::to_string(r.tapered) +
                                            " beam(s) with two different end radii read with "
                                            "their mean radius");
  return std::move(r.in);
}

void write_beam_lattice_3mf(const std::string& path, const Graph& g, double default_radius) {
  if (!(default_radius > 0) || !std::isfinite(default_radius))
    throw SettingError("the beam radius must be positive");
  if (g.edges.empty()) throw GeometryError("the lattice has no struts to write", {path});
  Handle model, object, item, writer;
  std::vector<MODELMESHVERTEX> verts(g.nodes.size());
  for (std::size_t i = 0; i < verts.size(); ++i) {
    verts[i].m_fPosition[0] = static_cast<float>(g.nodes[i].x);
    verts[i].m_fPosition[1] = static_cast<float>(g.nodes[i].y);
    verts[i].m_fPosition[2] = static_cast<float>(g.nodes[i].z);
  }
  std::vector<MODELMESHBEAM> beams(g.edges.size());
  std::map<int, std::vector<DWORD>> by_material;
  for (std::size_t i = 0; i < beams.size(); ++i) {
    const Edge& e = g.edges[i];
    beams[i].m_nIndices[0] = e.a;
    beams[i].m_nIndices[1] = e.b;
    beams[i].m_dRadius[0] = beams[i].m_dRadius[1] = e.radius > 0 ? e.radius : default_radius;
    by_material[e.material].push_back(static_cast<DWORD>(i));
  }
  auto fail = [&](const std::string& what, PLib3MFBase* obj) {
    throw IoError(what + last_error(obj), {path});
  };
  if (lib3mf_createmodel(&model.p) != LIB3MF_OK) fail("cannot create a 3MF model", nullptr);
  if (lib3mf_model_addmeshobject(model.p, &object.p) != LIB3MF_OK)
    fail("cannot add a mesh object", model.p);
  for (auto& v : verts)  // one by one: setgeometry wants triangles, a lattice has none
    if (lib3mf_meshobject_addvertex(object.p, &v, nullptr) != LIB3MF_OK)
      fail("cannot set the lattice's vertices", object.p);
  if (lib3mf_meshobject_setbeamlattice_radius(object.p, default_radius) != LIB3MF_OK ||
      lib3mf_meshobject_setbeamlattice_minlength(object.p, 1e-4) != LIB3MF_OK ||
      lib3mf_meshobject_setbeamindices(object.p, beams.data(), static_cast<DWORD>(beams.size())) !=
          LIB3MF_OK)
    fail("cannot set the beams", object.p);
  for (auto& [material, refs] : by_material) {
    Handle set;
    const std::string name = "material " + std::to_string(material);
    if (lib3mf_meshobject_addbeamset(object.p, &set.p) != LIB3MF_OK ||
        lib3mf_beamset_setnameutf8(set.p, name.c_str()) != LIB3MF_OK ||
        lib3mf_beamset_setidentifierutf8(set.p, std::to_string(material).c_str()) != LIB3MF_OK ||
        lib3mf_beamset_setrefs(set.p, refs.data(), static_cast<DWORD>(refs.size())) != LIB3MF_OK)
      fail("cannot write the beam set of material " + std::to_string(material), object.p);
  }
  if (lib3mf_model_addbuilditem(model.p, object.p, nullptr, &item.p) != LIB3MF_OK)
    fail("cannot add the build item", model.p);
  if (lib3mf_model_querywriter(model.p, "3mf", &writer.p) != LIB3MF_OK)
    fail("cannot create a 3MF writer", model.p);
  if (!detail::write_3mf_package(writer.p, path)) fail("cannot write 3MF", writer.p);
}

}  // namespace impl

}  // namespace trellis

TRELLIS_MODULE_ENTRY(beam3mf, trellis::Beam3mfModule, &trellis::impl::read_beam_lattice_3mf,
                     &trellis::impl::write_beam_lattice_3mf)
