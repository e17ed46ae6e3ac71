// Where a 3MF file is broken. lib3mf 1.8 refuses a bad package with a message but no position
// ("Space in XML attribute name", "Could not read ZIP file"), so when it does, this reads the
// package again on its own -- libzip for the ZIP container, expat streaming over the model part
// -- and names the part, line and column of the first problem: a ZIP that is not one, a missing
// part, malformed XML, or an element lib3mf would refuse (a vertex without a number, a triangle
// or beam naming a vertex its mesh lacks, a build item naming an object that does not exist).
// It walks the start part and every model part the start part names by p:path (Production
// Extension: OrcaSlicer's and Bambu Studio's 3D/Objects/object_N.model), whose problems lib3mf
// 1.8 otherwise reports without the part ("Could not find Object associated to Component") or
// not at all (a vertex x="1 0" read as 1).
// Hand-written because neither library reports positions; it checks only what it can locate and
// otherwise leaves lib3mf's own message standing. Part of the 3mf module (no cost at start-up).
#include <expat.h>
#include <zip.h>

#include <cerrno>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mesh_3mf_module.hpp"

namespace trellis::impl {

namespace {

struct Zip {
  zip_t* z = nullptr;
  ~Zip() {
    if (z) zip_discard(z);
  }
};

struct ZipFile {
  zip_file_t* f = nullptr;
  ~ZipFile() {
    if (f) zip_fclose(f);
  }
};

// Names are compared in place: the walk allocates nothing per element (a large model part has
// millions of <vertex> and <triangle> elements), only when it reports a problem.
const char* local_name(const XML_Char* name) {
  const char* space = std::strrchr(name, ' ');  // "namespace-uri local" (XML_ParserCreateNS)
  return space ? space + 1 : name;
}

// The element's name if it is in namespace `uri`, else "" (the slice extension has its own
// <vertex>, other extensions their own elements: only the core's and beam lattices' are checked).
std::string_view name_in(const XML_Char* name, std::string_view uri) {
  const char* space = std::strrchr(name, ' ');
  if (!space || std::string_view(name, static_cast<std::size_t>(space - name)) != uri) return {};
  return space + 1;
}

constexpr const char* kCore = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";
constexpr const char* kBeams = "http://schemas.microsoft.com/3dmanufacturing/beamlattice/2017/02";

const char* attribute(const XML_Char** atts, const char* name) {
  for (int i = 0; atts[i]; i += 2)
    if (std::strcmp(local_name(atts[i]), name) == 0) return atts[i + 1];
  return nullptr;
}

// Three attributes' values in one pass over `atts` (a vertex's x, y, z; a triangle's v1, v2,
// v3): each the first whose local name is names[k], as attribute() finds it, or nullptr.
void attributes3(const XML_Char** atts, const char* const (&names)[3], const char* (&out)[3]) {
  out[0] = out[1] = out[2] = nullptr;
  for (int i = 0; atts[i]; i += 2) {
    const char* n = local_name(atts[i]);
    for (int k = 0; k < 3; ++k)
      if (!out[k] && std::strcmp(n, names[k]) == 0) {
        out[k] = atts[i + 1];
        break;
      }
  }
}

// Whether strtod reads all of `s` as a finite number without ERANGE. Plain decimals that come
// out normal are settled by std::from_chars (the same correctly rounded double, a tenth of the
// cost); everything else (blanks, '+', hex, zero, tiny or huge values, text) is strtod's to say.
bool parse_number(const char* s, double& v) {
  if (!s || !*s) return false;
  const char* const stop = s + std::strlen(s);
  if (const auto r = std::from_chars(s, stop, v);
      r.ec == std::errc() && r.ptr == stop && std::abs(v) >= 4 * DBL_MIN && std::abs(v) <= DBL_MAX)
    return true;
  errno = 0;
  char* end = nullptr;
  v = std::strtod(s, &end);
  return end && *end == '\0' && errno != ERANGE && std::isfinite(v);
}

bool parse_index(const char* s, unsigned long long& v) {
  if (!s || !*s || *s == '-' || *s == '+') return false;
  // Plain digits by std::from_chars; blanks before them and overflow by strtoull.
  const char* const stop = s + std::strlen(s);
  if (const auto r = std::from_chars(s, stop, v); r.ec == std::errc() && r.ptr == stop) return true;
  errno = 0;
  char* end = nullptr;
  v = std::strtoull(s, &end, 10);
  return end && *end == '\0' && errno != ERANGE;
}

// Walks the model part's elements; stops at the first problem it can place.
struct Walker {
  XML_Parser parser = nullptr;
  std::string problem;
  long line = 0, column = 0;
  unsigned long long vertices = 0, triangles = 0, beams = 0;
  std::string object = "?";
  std::map<std::string, bool> objects;  // ids seen
  struct Ref {
    std::string id;
    long line, column;
    std::string what;
    std::string path;  // p:path, for an object in another model part
  };
  std::vector<Ref> refs;       // build items and components, checked at the end
  std::vector<Ref> elsewhere;  // those naming an object in another model part

  void fail(std::string what) {
    if (!problem.empty()) return;
    problem = std::move(what);
    line = static_cast<long>(XML_GetCurrentLineNumber(parser));
    column = static_cast<long>(XML_GetCurrentColumnNumber(parser)) + 1;
    XML_StopParser(parser, XML_FALSE);
  }

  // The element's name for a message: "vertex 12 of object 3".
  std::string element(const char* kind, unsigned long long number) const {
    return std::string(kind) + " " + std::to_string(number) + " of object " + object;
  }

  void index_attr(const XML_Char** atts, const char* name, const char* kind,
                  unsigned long long number) {
    index_value(attribute(atts, name), name, kind, number);
  }

  // The index attribute `name` whose value is `s` (nullptr: none).
  void index_value(const char* s, const char* name, const char* kind, unsigned long long number) {
    unsigned long long v = 0;
    if (!s)
      fail(element(kind, number) + " has no attribute " + name);
    else if (!parse_index(s, v))
      fail(element(kind, number) + ": " + name + "=\"" + s + "\" is not a vertex index");
    else if (v >= vertices)
      fail(element(kind, number) + " refers to vertex " + s + " but the mesh of object " + object +
           " has " + std::to_string(vertices) + " vertices");
  }

  void start(const XML_Char* name, const XML_Char** atts) {
    std::string_view n = name_in(name, kCore);
    if (n.empty() && name_in(name, kBeams) == "beam") n = "beam";
    if (n == "model") {
      const char* unit = attribute(atts, "unit");
      static const char* units[] = {"micron", "millimeter", "centimeter", "inch", "foot", "meter"};
      bool known = !unit;
      for (const char* u : units) known = known || std::strcmp(unit, u) == 0;
      if (!known) fail(std::string("unknown model unit \"") + unit + "\"");
    } else if (n == "object") {
      const char* id = attribute(atts, "id");
      if (!id) return fail("object has no id");
      object = id;
      objects[object] = true;
      vertices = triangles = beams = 0;
    } else if (n == "vertex") {
      static constexpr const char* axes[3] = {"x", "y", "z"};
      const char* value[3];
      attributes3(atts, axes, value);
      for (int k = 0; k < 3; ++k) {
        const char* const axis = axes[k];
        double v = 0;
        const char* s = value[k];
        if (!s) return fail(element("vertex", vertices) + " has no " + axis);
        if (!parse_number(s, v))
          return fail(element("vertex", vertices) + ": " + axis + "=\"" + s +
                      "\" is not a finite number");
      }
      ++vertices;
    } else if (n == "triangle") {
      static constexpr const char* corners[3] = {"v1", "v2", "v3"};
      const char* value[3];
      attributes3(atts, corners, value);
      for (int k = 0; k < 3; ++k) {
        index_value(value[k], corners[k], "triangle", triangles);
        if (!problem.empty()) return;
      }
      ++triangles;
    } else if (n == "beam") {
      for (const char* v : {"v1", "v2"}) {
        index_attr(atts, v, "beam", beams);
        if (!problem.empty()) return;
      }
      for (const char* r : {"r1", "r2"}) {
        double v = 0;
        const char* s = attribute(atts, r);
        if (s && (!parse_number(s, v) || v <= 0))
          return fail(element("beam", beams) + ": " + r + "=\"" + s +
                      "\" is not a positive radius");
      }
      ++beams;
    } else if (n == "item" || n == "component") {
      const char* id = attribute(atts, "objectid");
      if (!id) return fail(std::string(n) + " has no objectid");
      const long l = static_cast<long>(XML_GetCurrentLineNumber(parser));
      const long c = static_cast<long>(XML_GetCurrentColumnNumber(parser)) + 1;
      // An object in another model part (Production Extension: OrcaSlicer's and Bambu Studio's
      // 3D/Objects/object_N.model), checked when that part is walked.
      if (const char* path = attribute(atts, "path"))
        elsewhere.push_back({id, l, c, std::string(n), path});
      else
        refs.push_back({id, l, c, std::string(n), ""});
    }
  }

  void finish() {
    if (!problem.empty()) return;
    for (const auto& r : refs)
      if (!objects.count(r.id)) {
        problem = r.what + " refers to object " + r.id + ", which the model does not define";
        line = r.line;
        column = r.column;
        return;
      }
  }
};

std::string read_entry(zip_t* z, const char* name, std::size_t limit) {
  ZipFile f;
  f.f = zip_fopen(z, name, 0);
  if (!f.f) return {};
  std::string text;
  char buf[4096];
  zip_int64_t n = 0;
  while (text.size() < limit && (n = zip_fread(f.f, buf, sizeof buf)) > 0)
    text.append(buf, static_cast<std::size_t>(n));
  return text;
}

// A relationship's target as a part name inside the package (OPC: absolute "/3D/x.model", or
// relative to the folder the .rels part describes: "3D/_rels/a.model.rels" -> "3D/").
std::string target_part(const std::string& rels_name, std::string target) {
  if (!target.empty() && target[0] == '/') return target.substr(1);
  std::string base = rels_name.substr(0, rels_name.find("_rels/"));
  return base + target;
}

std::string attribute_text(const std::string& element, const char* name) {
  const std::string key = std::string(" ") + name + "=";
  std::size_t at = element.find(key);
  if (at == std::string::npos) return {};
  at += key.size();
  if (at >= element.size()) return {};
  const char quote = element[at];
  const std::size_t end = element.find(quote, at + 1);
  return end == std::string::npos ? std::string() : element.substr(at + 1, end - at - 1);
}

// The model part named by _rels/.rels (the 3MF start part), else the conventional name.
std::string start_part(zip_t* z) {
  const std::string fallback = "3D/3dmodel.model";
  const std::string text = read_entry(z, "_rels/.rels", 1u << 20);
  // <Relationship Target="/3D/3dmodel.model" ... Type=".../3dmodel"/>: a tolerant look-up, the
  // exact parse is lib3mf's.
  for (std::size_t at = text.find("<Relationship"); at != std::string::npos;
       at = text.find("<Relationship", at + 1)) {
    const std::size_t end = text.find('>', at);
    const std::string rel =
        text.substr(at, end == std::string::npos ? std::string::npos : end - at);
    if (rel.find("/3dmodel\"") == std::string::npos) continue;
    std::string target = attribute_text(rel, "Target");
    while (!target.empty() && target[0] == '/') target.erase(0, 1);
    if (!target.empty()) return target;
  }
  return fallback;
}

}  // namespace

// PrusaSlicer's command line writes a thumbnail relationship in _rels/.rels without the
// thumbnail part; lib3mf 1.8 then refuses the whole package ("Could not create OPC Part"). A
// relationship to a part the package lacks says nothing about the geometry, so such
// relationships are dropped (OPC, ECMA-376 part 2, 9.3: a relationship's target is a part name
// or an external URI) and lib3mf reads the package from memory. Returns the repaired package, or
// nothing when every relationship resolves.
std::vector<unsigned char> package_without_dangling_relationships(const std::string& path) {
  Zip zip;
  int code = 0;
  zip.z = zip_open(path.c_str(), ZIP_RDONLY, &code);
  if (!zip.z) return {};
  std::map<std::string, std::string> repaired;  // .rels part -> its text without dangling targets
  const zip_int64_t entries = zip_get_num_entries(zip.z, 0);
  for (zip_int64_t i = 0; i < entries; ++i) {
    const char* name = zip_get_name(zip.z, static_cast<zip_uint64_t>(i), 0);
    if (!name) continue;
    const std::string rels_name = name;
    if (rels_name.size() < 5 || rels_name.compare(rels_name.size() - 5, 5, ".rels") != 0) continue;
    std::string text = read_entry(zip.z, name, 1u << 20);
    bool changed = false;
    for (std::size_t at = text.find("<Relationship "); at != std::string::npos;) {
      const std::size_t end = text.find('>', at);
      if (end == std::string::npos) break;
      const std::string element = text.substr(at, end + 1 - at);
      const std::string target = attribute_text(element, "Target");
      const bool external = attribute_text(element, "TargetMode") == "External";
      if (!external && !target.empty() &&
          zip_name_locate(zip.z, target_part(rels_name, target).c_str(), ZIP_FL_NOCASE) < 0) {
        text.erase(at, end + 1 - at);
        changed = true;
        at = text.find("<Relationship ", at);
      } else {
        at = text.find("<Relationship ", end);
      }
    }
    if (changed) repaired[rels_name] = std::move(text);
  }
  if (repaired.empty()) return {};

  // Copy the package into memory with the repaired parts (libzip's in-memory source).
  std::vector<unsigned char> bytes;
  {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return {};
    unsigned char buf[1 << 16];
    std::size_t n = 0;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) bytes.insert(bytes.end(), buf, buf + n);
    std::fclose(f);
  }
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* source = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &error);
  if (!source) return {};
  zip_source_keep(source);
  zip_t* out = zip_open_from_source(source, 0, &error);
  if (!out) {
    zip_source_free(source);
    return {};
  }
  for (const auto& [name, text] : repaired) {
    zip_source_t* part = zip_source_buffer(out, text.data(), text.size(), 0);
    if (!part || zip_file_add(out, name.c_str(), part, ZIP_FL_OVERWRITE | ZIP_FL_ENC_UTF_8) < 0) {
      if (part) zip_source_free(part);
      zip_discard(out);
      zip_source_free(source);
      return {};
    }
  }
  if (zip_close(out) < 0) {  // the repaired texts live until here
    zip_discard(out);
    zip_source_free(source);
    return {};
  }
  std::vector<unsigned char> result;
  if (zip_source_open(source) == 0) {
    unsigned char buf[1 << 16];
    zip_int64_t n = 0;
    while ((n = zip_source_read(source, buf, sizeof buf)) > 0)
      result.insert(result.end(), buf, buf + n);
    zip_source_close(source);
  }
  zip_source_free(source);
  return result;
}

namespace {

// Walks one model part with `w`; "" when it is well-formed and `w` found nothing, else where
// and what.
Located3mf walk_part(zip_t* z, const std::string& part, Walker& w) {
  ZipFile file;
  file.f = zip_fopen(z, part.c_str(), ZIP_FL_NOCASE);
  if (!file.f) return {"", "the package has no model part " + part + ": " + zip_strerror(z)};
  std::unique_ptr<std::remove_pointer_t<XML_Parser>, void (*)(XML_Parser)> parser(
      XML_ParserCreateNS(nullptr, ' '), XML_ParserFree);
  if (!parser) return {};
  w.parser = parser.get();
  XML_SetUserData(parser.get(), &w);
  XML_SetElementHandler(
      parser.get(),
      [](void* u, const XML_Char* name, const XML_Char** atts) {
        static_cast<Walker*>(u)->start(name, atts);
      },
      nullptr);
  char buf[1 << 16];
  for (;;) {
    const zip_int64_t n = zip_fread(file.f, buf, sizeof buf);
    if (n < 0) return {part, std::string("cannot decompress: ") + zip_file_strerror(file.f)};
    const XML_Status s = XML_Parse(parser.get(), buf, static_cast<int>(n), n == 0);
    if (!w.problem.empty()) break;
    if (s == XML_STATUS_ERROR) {
      const long line = static_cast<long>(XML_GetCurrentLineNumber(parser.get()));
      const long column = static_cast<long>(XML_GetCurrentColumnNumber(parser.get())) + 1;
      return {part + " line " + std::to_string(line) + ", column " + std::to_string(column),
              std::string("malformed XML: ") + XML_ErrorString(XML_GetErrorCode(parser.get()))};
    }
    if (n == 0) break;
  }
  w.parser = nullptr;
  w.finish();
  if (w.problem.empty()) return {part, ""};
  return {part + " line " + std::to_string(w.line) + ", column " + std::to_string(w.column),
          w.problem};
}

}  // namespace

Located3mf locate_3mf_problem(const std::string& path) {
  Zip zip;
  int code = 0;
  zip.z = zip_open(path.c_str(), ZIP_RDONLY, &code);
  if (!zip.z) {
    zip_error_t e;
    zip_error_init_with_code(&e, code);
    std::string what =
        std::string("not a ZIP package (a 3MF file is one): ") + zip_error_strerror(&e);
    zip_error_fini(&e);
    return {"", what};
  }
  const std::string part = start_part(zip.z);
  Walker root;
  if (Located3mf at = walk_part(zip.z, part, root); !at.what.empty()) return at;

  // Production Extension (3MF Production Extension 1.1, 2.1.1 and 3.1): the start part's
  // components and items may name an object of another model part by p:path, an absolute part
  // name; those parts hold meshes (and components of their own part) only. Each named part is
  // walked once, with the same checks, and must define the objects named in it.
  std::map<std::string, Walker> parts;
  for (const auto& r : root.elsewhere) {
    const std::string where =
        part + " line " + std::to_string(r.line) + ", column " + std::to_string(r.column);
    std::string name = r.path;
    while (!name.empty() && name[0] == '/') name.erase(0, 1);
    if (zip_name_locate(zip.z, name.c_str(), ZIP_FL_NOCASE) < 0)
      return {where, r.what + " refers to object " + r.id + " in part " + r.path +
                         ", which the package does not contain"};
    auto [it, added] = parts.try_emplace(name);
    if (added)
      if (Located3mf at = walk_part(zip.z, name, it->second); !at.what.empty()) return at;
    if (!it->second.objects.count(r.id))
      return {where, r.what + " refers to object " + r.id + " in part " + r.path +
                         ", which that part does not define"};
  }
  return {part, ""};
}

}  // namespace trellis::impl
