// Reads 3MF level-set designs (implicit_3mf.hpp): libzip for the package, expat for the model
// part (implicit_xml.hpp: a small element tree with every element's line and column), the
// objects, meshes and build here, the function graphs in implicit_compile.cpp. Section numbers: 3MF
// Volumetric & Implicit Extension v1.0, Part I (volumetric) and Part II (implicit).
#include <expat.h>
#include <fmt/format.h>
#include <zip.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "implicit_3mf_module.hpp"
#include "implicit_compile.hpp"
#include "implicit_graph.hpp"
#include "implicit_image.hpp"
#include "mesh_sdf_module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"

namespace trellis::implicit {

namespace {

// ---------------------------------------------------------------- package and XML

std::optional<std::string> read_part(zip_t* z, std::string name, const std::string& file) {
  if (!name.empty() && name[0] == '/') name.erase(0, 1);
  zip_stat_t st;
  if (zip_stat(z, name.c_str(), ZIP_FL_ENC_GUESS, &st) != 0) return std::nullopt;
  zip_file_t* f = zip_fopen(z, name.c_str(), 0);
  if (!f) throw ParseError("cannot open part /" + name + " of the package", {file});
  std::string out(static_cast<std::size_t>(st.size), '\0');
  const zip_int64_t n = out.empty() ? 0 : zip_fread(f, out.data(), st.size);
  zip_fclose(f);
  if (n != static_cast<zip_int64_t>(st.size))
    throw ParseError("cannot read part /" + name + " of the package (damaged)", {file});
  return out;
}

struct Zip {
  zip_t* z = nullptr;
  ~Zip() {
    if (z) zip_discard(z);
  }
};

// Voxels a mesh node's distance field may take (OpenVDB floats, ~5 bytes each).
constexpr double kMaxDistanceVoxels = 1e8;

// Elements nested deeper than this are refused (the tree is freed recursively; 3MF models nest
// a handful of levels).
constexpr std::size_t kMaxDepth = 200;

struct Tree {
  std::unique_ptr<El> root;
  std::vector<El*> stack;
  XML_Parser parser = nullptr;
  std::string problem;
};

std::pair<std::string, std::string> split_name(const XML_Char* s) {
  const char* space = std::strrchr(s, ' ');
  if (!space) return {{}, s};
  return {std::string(s, static_cast<std::size_t>(space - s)), space + 1};
}

void on_start(void* self, const XML_Char* name, const XML_Char** atts) {
  auto* t = static_cast<Tree*>(self);
  if (t->stack.size() >= kMaxDepth) {
    t->problem = fmt::format("elements nest deeper than {} levels", kMaxDepth);
    XML_StopParser(t->parser, XML_FALSE);
    return;
  }
  auto e = std::make_unique<El>();
  std::tie(e->uri, e->name) = split_name(name);
  for (int i = 0; atts[i]; i += 2) e->attrs.emplace_back(split_name(atts[i]).second, atts[i + 1]);
  e->line = static_cast<long>(XML_GetCurrentLineNumber(t->parser));
  e->column = static_cast<long>(XML_GetCurrentColumnNumber(t->parser)) + 1;
  El* raw = e.get();
  if (t->stack.empty())
    t->root = std::move(e);
  else
    t->stack.back()->kids.push_back(std::move(e));
  t->stack.push_back(raw);
}

void on_end(void* self, const XML_Char*) {
  auto* t = static_cast<Tree*>(self);
  if (!t->stack.empty()) t->stack.pop_back();
}

std::unique_ptr<El> parse_xml(const std::string& bytes, const std::string& file,
                              const std::string& part) {
  Tree t;
  XML_Parser p = XML_ParserCreateNS("UTF-8", ' ');
  t.parser = p;
  XML_SetUserData(p, &t);
  XML_SetElementHandler(p, on_start, on_end);
  const XML_Status s = XML_Parse(p, bytes.data(), static_cast<int>(bytes.size()), XML_TRUE);
  const long line = static_cast<long>(XML_GetCurrentLineNumber(p));
  const long column = static_cast<long>(XML_GetCurrentColumnNumber(p)) + 1;
  std::string why = t.problem;
  if (why.empty() && s == XML_STATUS_ERROR) why = XML_ErrorString(XML_GetErrorCode(p));
  XML_ParserFree(p);
  if (!why.empty()) throw ParseError(why, {file, line, part, column});
  return std::move(t.root);
}

// The model part: the start part of the package's relationships (3MF Core §2.1), else the
// usual /3D/3dmodel.model.
std::string model_part_name(zip_t* z, const std::string& file) {
  if (auto rels = read_part(z, "_rels/.rels", file)) {
    try {
      auto root = parse_xml(*rels, file, "/_rels/.rels");
      for (const auto& r : root->kids) {
        const char* type = r->attr("Type");
        const char* target = r->attr("Target");
        if (type && target && std::string(type).ends_with("/3dmodel")) return target;
      }
    } catch (const ParseError&) {
      // The model part's usual name below; a broken .rels is not what this reader checks.
    }
  }
  return "/3D/3dmodel.model";
}

// OPC part names compare without case (ECMA-376 Part 2 §9.1.1.1); a relative target is resolved
// against the folder of the part that holds the relationship.
std::string part_key(std::string name, const std::string& from_folder) {
  if (name.empty() || name[0] != '/') name = from_folder + name;
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return name;
}

// The parts the model part relates to by the 3D Texture relationship (its .rels part, 3MF Core
// §2.1.1), as part_key()s. A malformed .rels part is an error naming it.
std::set<std::string> texture_parts(zip_t* z, const std::string& file, const std::string& part) {
  const std::size_t slash = part.rfind('/');
  const std::string folder = part.substr(0, slash + 1);
  const std::string rels_name = folder + "_rels/" + part.substr(slash + 1) + ".rels";
  std::set<std::string> out;
  const auto rels = read_part(z, rels_name.substr(1), file);
  if (!rels) return out;
  const auto root = parse_xml(*rels, file, rels_name);
  for (const auto& r : root->kids) {
    const char* type = r->attr("Type");
    const char* target = r->attr("Target");
    if (type && target && std::string(type) == kTextureRelationship)
      out.insert(part_key(target, folder));
  }
  return out;
}

// ---------------------------------------------------------------- the model

// A 3MF ST_Matrix3D (Core §3.3: row vectors, p' = [x y z 1] · M, the last row the translation)
// as an Affine.
Affine matrix3d(const Ctx& c, const El& e, const char* attr) {
  Affine a;
  const std::vector<double> m = numbers(c, e, attr, 12);
  if (m.empty()) return a;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) a.l[i][j] = m[static_cast<std::size_t>(j * 3 + i)];
    a.t[i] = m[static_cast<std::size_t>(9 + i)];
  }
  return a;
}

Affine compose(const Affine& outer, const Affine& inner) {  // outer ∘ inner
  Affine r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      r.l[i][j] = 0;
      for (int k = 0; k < 3; ++k) r.l[i][j] += outer.l[i][k] * inner.l[k][j];
    }
    r.t[i] = outer.t[i];
    for (int k = 0; k < 3; ++k) r.t[i] += outer.l[i][k] * inner.t[k];
  }
  return r;
}

std::optional<Affine> inverse(const Affine& a) {
  const auto& m = a.l;
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (!(std::abs(det) > 1e-300)) return std::nullopt;
  Affine r;
  r.l[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / det;
  r.l[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
  r.l[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
  r.l[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / det;
  r.l[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
  r.l[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
  r.l[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / det;
  r.l[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det;
  r.l[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
  for (int i = 0; i < 3; ++i)
    r.t[i] = -(r.l[i][0] * a.t[0] + r.l[i][1] * a.t[1] + r.l[i][2] * a.t[2]);
  return r;
}

double unit_mm(const Ctx& c, const El& model) {
  const char* u = model.attr("unit");
  if (!u) return 1;  // Core §3.4: millimeter by default
  const std::string s = u;
  if (s == "micron") return 0.001;
  if (s == "millimeter") return 1;
  if (s == "centimeter") return 10;
  if (s == "inch") return 25.4;
  if (s == "foot") return 304.8;
  if (s == "meter") return 1000;
  c.fail(model, "unknown unit \"" + s + "\"");
}

// Whether an element is a function resource (Part I §2.1): <i:implicitfunction>, the 2022
// draft's <v:function> holding nodes, or another type (functionfromimage3d, private).
bool is_function(const El& e) {
  return e.name == "implicitfunction" || e.name == "function" || e.name == "functionfromimage3d";
}

// ---------------------------------------------------------------- objects and the build

bool truthy(const char* s) {
  return s && (std::string(s) == "true" || std::string(s) == "1");
}

// A core <mesh> (Core §4.1) in build millimetres: vertices through the item transform `m`.
TriangleMesh mesh_of(const Ctx& c, const El& mesh, const Affine& m, double mm) {
  TriangleMesh tm;
  const El* vs = child(mesh, "vertices");
  const El* ts = child(mesh, "triangles");
  if (!vs || !ts) c.fail(mesh, "<mesh> has no <vertices> or no <triangles>");
  for (const auto& v : vs->kids) {
    const Vec3 p = m.apply({number(c, *v, "x"), number(c, *v, "y"), number(c, *v, "z")});
    tm.vertices.push_back(p * mm);
  }
  for (const auto& t : ts->kids) {
    std::array<std::uint32_t, 3> tri{};
    const char* names[3] = {"v1", "v2", "v3"};
    for (int i = 0; i < 3; ++i) {
      const double v = number(c, *t, names[i]);
      if (!(v >= 0 && v < static_cast<double>(tm.vertices.size())) || v != std::floor(v))
        c.fail(*t, fmt::format("<triangle> {}={} names no vertex of the mesh ({} vertices)",
                               names[i], v, tm.vertices.size()));
      tri[static_cast<std::size_t>(i)] = static_cast<std::uint32_t>(v);
    }
    tm.triangles.push_back(tri);
  }
  if (tm.vertices.empty() || tm.triangles.empty()) c.fail(mesh, "the mesh is empty");
  return tm;
}

// Whether the mesh is its own bounding box (every vertex a corner of it, 12 triangles): then
// clipping to the box is clipping to the mesh.
bool is_box(const TriangleMesh& m, const BBox3& b) {
  if (m.triangles.size() != 12) return false;
  auto corner = [](double v, double lo, double hi) { return v == lo || v == hi; };
  for (const Vec3& v : m.vertices)
    if (!corner(v.x, b.min.x, b.max.x) || !corner(v.y, b.min.y, b.max.y) ||
        !corner(v.z, b.min.z, b.max.z))
      return false;
  return true;
}

struct Model {
  const Ctx& ctx;
  double mm = 1;
  std::map<long long, const El*> objects, images;
  Resources res;
  const VcadOptions& options;
  PartReader part;
  std::map<long long, std::shared_ptr<const Image3d>> loaded;  // image3d id → its voxels
  BBox3 domain;  // the level set being compiled: its evaluation box in function coordinates
  std::vector<long long> placing;  // objects being placed (components nest; cycles refused)
  double min_feature = 0;  // mm: the smallest minfeaturesize of the level sets read (0 = none)
  std::set<std::string> textures;  // parts with a 3D Texture relationship from the model part
};

// Volumetric data (Part I ch. 5: <color>, <composite>, <property> inside the object's shape) is
// not read: a shape that applies some (volumeid on a <levelset> or <mesh>, §4.1.1 and §5.1, or
// the 2022 draft's <volumedata> children beside its <boundary>) is refused by name rather than
// sliced without it.
void refuse_volume_data(const Ctx& c, const El& shape) {
  if (const char* id = shape.attr("volumeid"))
    c.fail(shape, fmt::format("<{}> volumeid=\"{}\" applies volumetric data (Part I ch. 5: "
                              "colour, material composite, properties), which this reader does "
                              "not read; remove the attribute to slice the shape alone",
                              shape.name, id));
  if (shape.name != "volumedata") return;
  for (const auto& k : shape.kids)
    if (k->name != "boundary")
      c.fail(*k, fmt::format("<volumedata><{}> (Part I ch. 5 volumetric data) is not read; "
                             "remove it to slice the shape alone",
                             k->name));
}

// Elements nested through components deeper than this are refused.
constexpr std::size_t kMaxComponentDepth = 64;

// The voxels of image3d `id`, read once per package (Part I ch. 3).
std::shared_ptr<const Image3d> image3d(Model& md, long long id, const El& at) {
  if (auto it = md.loaded.find(id); it != md.loaded.end()) return it->second;
  auto e = md.images.find(id);
  if (e == md.images.end()) md.ctx.fail(at, fmt::format("there is no <image3d> with id {}", id));
  const std::string folder = md.ctx.part.substr(0, md.ctx.part.rfind('/') + 1);
  return md.loaded[id] = read_image3d(md.ctx, *e->second, md.part, [&](const std::string& name) {
           return md.textures.count(part_key(name, folder)) > 0;
         });
}

// The distance to mesh object `id` (Part II ch. 5, mesh and unsignedmesh): the kernel's distance
// field of the mesh in its object's coordinates (model units), at slice.mesh_voxel, its band wide
// enough to hold the exact distance everywhere in the level set's domain: the mesh touches every
// face of its bounding box B, so no point p is farther from it than d(p, B) + diam(B).
Field mesh_distance(Model& md, long long id, bool sign, const El& at) {
  const Ctx& c = md.ctx;
  auto o = md.objects.find(id);
  if (o == md.objects.end() || !child(*o->second, "mesh"))
    c.fail(at, fmt::format("<{}>: object {} is not a mesh object (the node measures the distance "
                           "to one)",
                           at.name, id));
  const TriangleMesh mesh = mesh_of(c, *child(*o->second, "mesh"), Affine{}, 1);
  BBox3 b;
  for (const Vec3& v : mesh.vertices) b.add(v);
  const Vec3 size = b.max - b.min;
  double reach = 0;  // max over the domain of d(p, B): at one of its corners
  for (int k = 0; k < 8; ++k) {
    const Vec3 c{k & 1 ? md.domain.max.x : md.domain.min.x,
                 k & 2 ? md.domain.max.y : md.domain.min.y,
                 k & 4 ? md.domain.max.z : md.domain.min.z};
    const Vec3 out{std::max({b.min.x - c.x, 0.0, c.x - b.max.x}),
                   std::max({b.min.y - c.y, 0.0, c.y - b.max.y}),
                   std::max({b.min.z - c.z, 0.0, c.z - b.max.z})};
    reach = std::max(reach, std::hypot(out.x, out.y, out.z));
  }
  const double band = reach + std::hypot(size.x, size.y, size.z);
  MeshSdfOptions mo;
  mo.voxel = md.options.mesh_voxel / md.mm;
  mo.band_voxels = std::max(mo.band_voxels, band / mo.voxel);
  const Vec3 span = size + Vec3{2 * band, 2 * band, 2 * band};  // what the band fills
  const double voxels = span.x * span.y * span.z / (mo.voxel * mo.voxel * mo.voxel);
  if (!(voxels <= kMaxDistanceVoxels))
    c.fail(at, fmt::format("<{}>: the distance to object {} over the level set's domain needs "
                           "{:.3g} voxels of {} mm: more than {:.3g}; set a coarser "
                           "slice.mesh_voxel",
                           at.name, id, voxels, md.options.mesh_voxel, kMaxDistanceVoxels));
  try {
    const std::string name = fmt::format("object {}", id);
    return sign ? mesh_field(mesh, mo, name)
                : detail::module_table<MeshSdfModule>("vdb").unsigned_mesh_field(mesh, mo, name);
  } catch (const GeometryError& e) {
    c.fail(at, fmt::format("<{}>: {}", at.name, e.what()));
  }
}

// The field of a level-set object placed by `placement` (object → build, model units): its level
// set (Part I §4.1.1) or the 2022 draft's <volumedata><boundary>, clipped to its mesh; `box`
// grows by the mesh's box.
Field level_set_field(Model& md, const El& obj, long long oid, const Affine& placement,
                      BBox3& box) {
  const Ctx& c = md.ctx;
  const El* ls = child(obj, "levelset");
  const El* boundary = nullptr;
  if (const El* vd = child(obj, "volumedata")) {
    boundary = child(*vd, "boundary");
    refuse_volume_data(c, *vd);
  }
  const El& at = ls ? *ls : *boundary;
  refuse_volume_data(c, at);
  // minfeaturesize (§4.1.1): the smallest feature the consumer should resolve; kept (in mm) for
  // the routes to warn when their resolution is coarser, as the specification asks.
  if (const double f = number(c, at, "minfeaturesize", 0.0) * md.mm; f > 0)
    md.min_feature = md.min_feature > 0 ? std::min(md.min_feature, f) : f;
  long long fid = 0;
  std::string channel;
  const El* domain = nullptr;
  Affine to_function;  // object → function coordinates
  bool bbox_only = false;
  if (ls) {
    fid = resource_id(c, *ls, "functionid");
    const char* ch = ls->attr("channel");
    if (!ch) c.fail(*ls, "<levelset> has no channel (the function output it uses)");
    channel = ch;
    const long long meshid = resource_id(c, *ls, "meshid");
    auto mo = md.objects.find(meshid);
    if (mo == md.objects.end() || !child(*mo->second, "mesh"))
      c.fail(*ls, fmt::format("meshid {} names no mesh object (Part I §4.1.1: the mesh bounds "
                              "the level set)",
                              meshid));
    domain = child(*mo->second, "mesh");
    to_function = matrix3d(c, *ls, "transform");
    bbox_only = truthy(ls->attr("meshbboxonly"));
  } else {
    fid = resource_id(c, *boundary, boundary->attr("functionId") ? "functionId" : "functionid");
    if (const char* ch = boundary->attr("channel")) channel = ch;
    domain = child(obj, "mesh");
    if (!domain) c.fail(obj, fmt::format("object {} has a boundary but no mesh to bound it", oid));
  }
  const double fallback = number(c, at, "fallbackvalue", 0.0);

  md.domain = BBox3{};
  for (const Vec3& v : mesh_of(c, *domain, to_function, 1).vertices) md.domain.add(v);
  auto program = std::make_shared<Program>();
  compile_level_set(c, md.res, fid, channel, at, *program);

  const auto inv = inverse(placement);
  if (!inv) c.fail(obj, fmt::format("object {} is placed by a singular transform", oid));
  Affine from_mm;
  for (int i = 0; i < 3; ++i) from_mm.l[i][i] = 1 / md.mm;
  const Field graph = graph_field(program, compose(to_function, compose(*inv, from_mm)), fallback);

  const TriangleMesh mesh = mesh_of(c, *domain, placement, md.mm);
  BBox3 b;
  for (const Vec3& v : mesh.vertices) b.add(v);
  box.add(b.min);
  box.add(b.max);
  Field f = clip_box(graph, b.min, b.max);
  if (!bbox_only && !is_box(mesh, b)) {
    // The level set intersected with the mesh itself (Part I §4.1.1, meshbboxonly false).
    MeshSdfOptions mo;
    mo.voxel = md.options.mesh_voxel;
    const Vec3 n = (b.max - b.min) * (1 / mo.voxel);
    if (!(n.x * n.y * n.z <= 1e10))
      c.fail(at, fmt::format("the mesh that bounds object {} spans {:.3g} voxels of {} mm: too "
                             "many for its distance field; set meshbboxonly=\"true\" or a "
                             "coarser slice.mesh_voxel",
                             oid, n.x * n.y * n.z, mo.voxel));
    f = intersect({f, mesh_field(mesh, mo, fmt::format("{} object {}", c.file, oid))});
  }
  return f;
}

Field object_field(Model& md, long long oid, const El& placed_by, const Affine& placement,
                   BBox3& box);

// The object an <item> or a <component> `e` places (its objectid, its transform after `outer`:
// the placement of the object holding the component). An object of another model part (the
// Production Extension's p:path) is refused.
Field placed_object(Model& md, const El& e, const Affine& outer, BBox3& box) {
  if (const char* path = e.attr("path"))
    md.ctx.fail(e, fmt::format("<{}> p:path=\"{}\" places an object of another model part (3MF "
                               "Production Extension), which this reader does not read",
                               e.name, path));
  return object_field(md, resource_id(md.ctx, e, "objectid"), e,
                      compose(outer, matrix3d(md.ctx, e, "transform")), box);
}

// The field of object `oid` placed by `placement` (object → build, model units; `placed_by` the
// item or component that placed it): a level-set object, a mesh object (its distance field at
// slice.mesh_voxel: the mesh must be closed), or an object made of components (Core §4.2: each
// placed by its transform inside the object; the union of their fields).
Field object_field(Model& md, long long oid, const El& placed_by, const Affine& placement,
                   BBox3& box) {
  const Ctx& c = md.ctx;
  auto o = md.objects.find(oid);
  if (o == md.objects.end()) c.fail(placed_by, fmt::format("no object has id {}", oid));
  const El& obj = *o->second;
  const El* vd = child(obj, "volumedata");
  if (child(obj, "levelset") || (vd && child(*vd, "boundary")))
    return level_set_field(md, obj, oid, placement, box);
  if (const El* mesh = child(obj, "mesh")) {
    refuse_volume_data(c, *mesh);
    const TriangleMesh m = mesh_of(c, *mesh, placement, md.mm);
    for (const Vec3& v : m.vertices) box.add(v);
    MeshSdfOptions mo;
    mo.voxel = md.options.mesh_voxel;
    return mesh_field(m, mo, fmt::format("{} object {}", c.file, oid));
  }
  const El* components = child(obj, "components");
  if (!components)
    c.fail(obj, fmt::format("object {} has no <levelset>, <mesh> or <components>", oid));
  if (std::find(md.placing.begin(), md.placing.end(), oid) != md.placing.end())
    c.fail(placed_by, fmt::format("object {} contains itself through its components", oid));
  if (md.placing.size() >= kMaxComponentDepth)
    c.fail(placed_by, fmt::format("components nest deeper than {} objects", kMaxComponentDepth));
  md.placing.push_back(oid);
  std::vector<Field> parts;
  for (const auto& k : components->kids) {
    if (k->name != "component") continue;
    parts.push_back(placed_object(md, *k, placement, box));
  }
  md.placing.pop_back();
  if (parts.empty()) c.fail(*components, fmt::format("object {} has no <component>", oid));
  return parts.size() == 1 ? parts[0] : unite(std::move(parts));
}

bool is_implicit(const std::string& path) {
  Zip z;
  int err = 0;
  z.z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z.z) return false;
  std::optional<std::string> bytes;
  try {
    bytes = read_part(z.z, model_part_name(z.z, path), path);
  } catch (const ParseError&) {
    return false;
  }
  if (!bytes) return false;
  const bool extension = bytes->find("3dmanufacturing/volumetric/") != std::string::npos ||
                         bytes->find("3dmanufacturing/implicit/") != std::string::npos;
  return extension && (bytes->find("levelset") != std::string::npos ||
                       bytes->find("boundary") != std::string::npos);
}

VcadDesign read(const std::string& path, const VcadOptions& options) {
  Zip z;
  int err = 0;
  z.z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z.z) {
    zip_error_t e;
    zip_error_init_with_code(&e, err);
    const std::string why = zip_error_strerror(&e);
    zip_error_fini(&e);
    throw ParseError("not a 3MF package (a ZIP file): " + why, {path});
  }
  const std::string part = model_part_name(z.z, path);
  const auto bytes = read_part(z.z, part, path);
  if (!bytes) throw ParseError("the package has no model part " + part, {path});
  const Ctx ctx{path, part[0] == '/' ? part : "/" + part};
  const auto root = parse_xml(*bytes, path, ctx.part);
  if (root->name != "model") ctx.fail(*root, "the model part's root is not <model>");
  Model md{ctx, unit_mm(ctx, *root), {}, {}, {}, options, {}, {}, {}, {}, 0, {}};
  md.part = [&](const std::string& name) { return read_part(z.z, name, path); };
  md.textures = texture_parts(z.z, path, ctx.part);
  md.res.image = [&md](const El& fn) {
    return image_function(md.ctx, fn, [&](long long id) { return image3d(md, id, fn); });
  };
  md.res.mesh = [&md](long long id, bool sign, const El& at) {
    return mesh_distance(md, id, sign, at);
  };
  const El* resources = child(*root, "resources");
  const El* build = child(*root, "build");
  if (!resources || !build) ctx.fail(*root, "<model> has no <resources> or no <build>");
  for (const auto& k : resources->kids) {
    if (is_function(*k)) md.res.functions[resource_id(ctx, *k, "id")] = k.get();
    if (k->name == "object") md.objects[resource_id(ctx, *k, "id")] = k.get();
    if (k->name == "image3d") md.images[resource_id(ctx, *k, "id")] = k.get();
  }
  std::vector<Field> parts;
  BBox3 box;
  for (const auto& item : build->kids) {
    if (item->name != "item") continue;
    parts.push_back(placed_object(md, *item, Affine{}, box));
  }
  if (parts.empty()) ctx.fail(*build, "the build places no object");
  VcadDesign d;
  d.field = parts.size() == 1 ? parts[0] : unite(std::move(parts));
  d.has_root = true;
  d.root_min = box.min;
  d.root_max = box.max;
  d.min_feature_size = md.min_feature;
  d.source = path;
  return d;
}

}  // namespace
}  // namespace trellis::implicit

TRELLIS_MODULE_ENTRY(implicit3mf, trellis::Implicit3mfModule, &trellis::implicit::is_implicit,
                     &trellis::implicit::read)
