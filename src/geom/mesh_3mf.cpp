// 3MF files through lib3mf 1.8's C interface, built as the run-time module trellis_3mf (see
// src/core/module.hpp): lib3mf and libzip load only when a 3MF file is read or written.
#include <Model/COM/NMR_DLLInterfaces.h>

#include <array>
#include <cstdio>
#include <functional>
#include <vector>

#include "lib3mf_write.hpp"
#include "mesh_3mf_module.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

namespace impl {

namespace {

double millimetres_per_unit(DWORD unit) {
  switch (unit) {
    case NMR::MODELUNIT_MICROMETER:
      return 1e-3;
    case NMR::MODELUNIT_MILLIMETER:
      return 1.0;
    case NMR::MODELUNIT_CENTIMETER:
      return 10.0;
    case NMR::MODELUNIT_INCH:
      return 25.4;
    case NMR::MODELUNIT_FOOT:
      return 304.8;
    case NMR::MODELUNIT_METER:
      return 1000.0;
    default:
      return 0.0;
  }
}

DWORD unit_of(const std::string& name) {
  if (name == "micron") return NMR::MODELUNIT_MICROMETER;
  if (name == "millimeter") return NMR::MODELUNIT_MILLIMETER;
  if (name == "centimeter") return NMR::MODELUNIT_CENTIMETER;
  if (name == "inch") return NMR::MODELUNIT_INCH;
  if (name == "foot") return NMR::MODELUNIT_FOOT;
  if (name == "meter") return NMR::MODELUNIT_METER;
  throw SettingError("unknown 3MF unit '" + name +
                     "' (micron, millimeter, centimeter, inch, foot or meter)");
}

// The package read by lib3mf, its build's meshes returned as stored (transformed, in
// millimetres), not yet checked.
TriangleMesh read_with_lib3mf(const std::string& path) {
  using namespace NMR;
  // lib3mf 1.8 C interface; every handle released on every path.
  struct Handle {
    PLib3MFBase* p = nullptr;
    ~Handle() {
      if (p) lib3mf_release(p);
    }
  };
  auto fail = [&](const std::string& what, PLib3MFBase* obj) {
    std::string msg = what;
    if (obj) {
      DWORD code = 0;
      LPCSTR text = nullptr;
      if (lib3mf_getlasterror(obj, &code, &text) == LIB3MF_OK && text)
        msg += ": " + std::string(text);
    }
    throw ParseError(msg, {path, 0, ""});
  };
  Handle model, reader;
  if (lib3mf_createmodel(&model.p) != LIB3MF_OK) fail("cannot create a 3MF model", nullptr);
  if (lib3mf_model_queryreader(model.p, "3mf", &reader.p) != LIB3MF_OK)
    fail("cannot create a 3MF reader", model.p);
  std::vector<unsigned char> repaired = package_without_dangling_relationships(path);
  const bool read_ok =
      repaired.empty()
          ? lib3mf_reader_readfromfileutf8(reader.p, path.c_str()) == LIB3MF_OK
          : lib3mf_reader_readfrombuffer(reader.p, repaired.data(), repaired.size()) == LIB3MF_OK;
  if (!read_ok) {
    DWORD code = 0;
    LPCSTR text = nullptr;
    std::string lib3mf_text;
    if (lib3mf_getlasterror(reader.p, &code, &text) == LIB3MF_OK && text)
      lib3mf_text = ": " + std::string(text);
    throw ParseError("not a readable 3MF file" + lib3mf_text, {path, 0, ""});
  }

  // Millimetres per model unit (3MF core spec: the <model unit="..."> attribute, default mm).
  DWORD unit = MODELUNIT_MILLIMETER;
  if (lib3mf_model_getunit(model.p, &unit) != LIB3MF_OK)
    fail("cannot read the model unit", model.p);
  const double mm = millimetres_per_unit(unit);
  if (!(mm > 0)) fail("unknown model unit " + std::to_string(unit), nullptr);

  TriangleMesh b;
  // 3MF core spec 3.4: a transform is 3 x 4 (row-major here: p' = M p + t); an item's
  // transform applies after its components' own (4.1.1: a component is placed in its parent).
  using Transform = std::array<std::array<double, 4>, 3>;
  const Transform identity{{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
  auto from = [](const MODELTRANSFORM& t) {
    Transform m;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) m[r][c] = t.m_fFields[r][c];
    return m;
  };
  auto compose = [](const Transform& outer, const Transform& inner) {  // outer after inner
    Transform m{};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) {
        double v = c == 3 ? outer[r][3] : 0.0;
        for (int k = 0; k < 3; ++k) v += outer[r][k] * inner[k][c];
        m[r][c] = v;
      }
    return m;
  };
  auto add_mesh = [&](PLib3MFBase* object, const Transform& m) {
    DWORD nv = 0, nt = 0;
    lib3mf_meshobject_getvertexcount(object, &nv);
    lib3mf_meshobject_gettrianglecount(object, &nt);
    std::vector<MODELMESHVERTEX> verts(nv);
    std::vector<MODELMESHTRIANGLE> tris(nt);
    if (nv) lib3mf_meshobject_getvertices(object, verts.data(), nv, nullptr);
    if (nt) lib3mf_meshobject_gettriangleindices(object, tris.data(), nt, nullptr);
    auto at = [&](DWORD i) {
      const float* f = verts[i].m_fPosition;
      const Vec3 p{f[0], f[1], f[2]};
      return Vec3{m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
                  m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
                  m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]} *
             mm;
    };
    // Vertices as stored (transformed): welding and coordinate checks are mesh_io's.
    const auto base = static_cast<std::uint32_t>(b.vertices.size());
    for (DWORD i = 0; i < nv; ++i) b.vertices.push_back(at(i));
    for (const auto& t : tris) {
      for (DWORD i : t.m_nIndices)
        if (i >= nv) fail("triangle refers to a missing vertex", nullptr);
      b.triangles.push_back(
          {base + t.m_nIndices[0], base + t.m_nIndices[1], base + t.m_nIndices[2]});
    }
  };
  // A build item's object: a mesh, or components (other objects, each with its transform, to any
  // depth -- PrusaSlicer's multi-part objects, Bambu Studio's and OrcaSlicer's assemblies).
  std::function<bool(PLib3MFBase*, const Transform&, int)> add_object =
      [&](PLib3MFBase* object, const Transform& m, int depth) -> bool {
    if (depth > 64) fail("3MF components nest deeper than 64 levels (a cycle?)", nullptr);
    BOOL is_mesh = false;
    lib3mf_object_ismeshobject(object, &is_mesh);
    if (is_mesh) {
      add_mesh(object, m);
      return true;
    }
    BOOL is_comp = false;
    lib3mf_object_iscomponentsobject(object, &is_comp);
    if (!is_comp) return false;
    DWORD count = 0;
    lib3mf_componentsobject_getcomponentcount(object, &count);
    bool any = false;
    for (DWORD i = 0; i < count; ++i) {
      Handle component, child;
      if (lib3mf_componentsobject_getcomponent(object, i, &component.p) != LIB3MF_OK) continue;
      if (lib3mf_component_getobjectresource(component.p, &child.p) != LIB3MF_OK || !child.p)
        fail("a 3MF component names an object the model does not define", component.p);
      BOOL has_tf = false;
      MODELTRANSFORM tf;
      lib3mf_component_hastransform(component.p, &has_tf);
      Transform placed = m;
      if (has_tf && lib3mf_component_gettransform(component.p, &tf) == LIB3MF_OK)
        placed = compose(m, from(tf));
      any = add_object(child.p, placed, depth + 1) || any;
    }
    return any;
  };

  Handle items;
  std::size_t built = 0;
  if (lib3mf_model_getbuilditems(model.p, &items.p) == LIB3MF_OK) {
    BOOL more = false;
    while (lib3mf_builditemiterator_movenext(items.p, &more) == LIB3MF_OK && more) {
      Handle item;
      if (lib3mf_builditemiterator_getcurrent(items.p, &item.p) != LIB3MF_OK) break;
      Handle obj;  // a new reference: released like every other handle
      if (lib3mf_builditem_getobjectresource(item.p, &obj.p) != LIB3MF_OK || !obj.p) continue;
      BOOL has_tf = false;
      MODELTRANSFORM tf;
      lib3mf_builditem_hasobjecttransform(item.p, &has_tf);
      Transform m = identity;
      if (has_tf && lib3mf_builditem_getobjecttransform(item.p, &tf) == LIB3MF_OK) m = from(tf);
      if (!add_object(obj.p, m, 0)) continue;
      ++built;
    }
  }
  if (built == 0) {
    Handle objects;
    if (lib3mf_model_getmeshobjects(model.p, &objects.p) == LIB3MF_OK) {
      BOOL more = false;
      while (lib3mf_resourceiterator_movenext(objects.p, &more) == LIB3MF_OK && more) {
        Handle res;
        if (lib3mf_resourceiterator_getcurrent(objects.p, &res.p) != LIB3MF_OK) break;
        add_mesh(res.p, identity);
      }
    }
  }
  return b;
}

}  // namespace

// Our own walk first (src/geom/locate_3mf.cpp): it places a problem by part, line and column,
// refuses what lib3mf 1.8 reads without a word (a coordinate "zz" as 0, an unknown unit as
// millimetres), and keeps damaged and non-ZIP input away from lib3mf 1.8, which leaks its ZIP
// source when it refuses one. Running the two side by side was tried (session 30): no wall time
// was shown to be saved, and lib3mf would then read every package the walk refuses.
TriangleMesh read_3mf(const std::string& path) {
  if (const Located3mf at = locate_3mf_problem(path); !at.what.empty())
    throw ParseError(at.what, {path, 0, at.where});
  return read_with_lib3mf(path);
}

void write_3mf(const std::string& path, const TriangleMesh& mesh, const std::string& unit_name) {
  using namespace NMR;
  const DWORD unit = unit_of(unit_name);
  const double scale = 1.0 / millimetres_per_unit(unit);
  struct Handle {
    PLib3MFBase* p = nullptr;
    ~Handle() {
      if (p) lib3mf_release(p);
    }
  };
  Handle model, object, item, writer;
  std::vector<MODELMESHVERTEX> verts(mesh.vertices.size());
  for (std::size_t i = 0; i < verts.size(); ++i) {
    verts[i].m_fPosition[0] = static_cast<float>(mesh.vertices[i].x * scale);
    verts[i].m_fPosition[1] = static_cast<float>(mesh.vertices[i].y * scale);
    verts[i].m_fPosition[2] = static_cast<float>(mesh.vertices[i].z * scale);
  }
  std::vector<MODELMESHTRIANGLE> tris(mesh.triangles.size());
  for (std::size_t i = 0; i < tris.size(); ++i)
    for (int k = 0; k < 3; ++k) tris[i].m_nIndices[k] = mesh.triangles[i][k];
  if (lib3mf_createmodel(&model.p) != LIB3MF_OK ||
      lib3mf_model_setunit(model.p, unit) != LIB3MF_OK ||
      lib3mf_model_addmeshobject(model.p, &object.p) != LIB3MF_OK ||
      lib3mf_meshobject_setgeometry(object.p, verts.data(), static_cast<DWORD>(verts.size()),
                                    tris.data(), static_cast<DWORD>(tris.size())) != LIB3MF_OK ||
      lib3mf_model_addbuilditem(model.p, object.p, nullptr, &item.p) != LIB3MF_OK ||
      lib3mf_model_querywriter(model.p, "3mf", &writer.p) != LIB3MF_OK ||
      !detail::write_3mf_package(writer.p, path))
    throw IoError("cannot write 3MF", {path, 0, ""});
}

}  // namespace impl

}  // namespace trellis

TRELLIS_MODULE_ENTRY(3mf, trellis::Mesh3mfModule, &trellis::impl::read_3mf,
                     &trellis::impl::write_3mf, &trellis::impl::locate_3mf_problem)
