// A 3MF package's Toolpath Extension v1.0 data → the toolpath IR (section numbers are the
// specification's, 3MFConsortium/spec_toolpath). libzip for the package, expat streaming over
// each XML part so that an error names the part, line and column. Part of the toolpath3mf module.
#include <expat.h>
#include <fmt/format.h>
#include <zip.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <optional>
#include <set>

#include "toolpath_3mf_module.hpp"
#include "trellis/core/error.hpp"

namespace trellis::impl {

namespace {

using namespace tp3mf;

class Package {
 public:
  explicit Package(const std::string& path) : path_(path) {
    int err = 0;
    zip_ = zip_open(path.c_str(), ZIP_RDONLY, &err);
    if (!zip_) {
      zip_error_t e;
      zip_error_init_with_code(&e, err);
      const std::string why = zip_error_strerror(&e);
      zip_error_fini(&e);
      throw ParseError("not a 3MF package (a ZIP file): " + why, {path});
    }
  }
  ~Package() {
    if (zip_) zip_discard(zip_);
  }
  Package(const Package&) = delete;
  Package& operator=(const Package&) = delete;

  // The part's bytes; nullopt when the package has no such part. `name` may start with '/'.
  std::optional<std::string> part(std::string name) const {
    if (!name.empty() && name[0] == '/') name.erase(0, 1);
    zip_stat_t st;
    if (zip_stat(zip_, name.c_str(), ZIP_FL_ENC_GUESS, &st) != 0) return std::nullopt;
    zip_file_t* f = zip_fopen(zip_, name.c_str(), 0);
    if (!f) throw ParseError("cannot open part /" + name + " of the package", {path_});
    std::string out(static_cast<std::size_t>(st.size), '\0');
    const zip_int64_t n = out.empty() ? 0 : zip_fread(f, out.data(), st.size);
    zip_fclose(f);
    if (n != static_cast<zip_int64_t>(st.size))
      throw ParseError("cannot read part /" + name + " of the package (damaged)", {path_});
    return out;
  }

 private:
  std::string path_;
  zip_t* zip_ = nullptr;
};

// Expat with namespaces: element and attribute names come as "uri local".
struct Name {
  std::string_view uri, local;
};
Name split(const XML_Char* name) {
  const char* space = std::strrchr(name, ' ');
  if (!space) return {{}, name};
  return {std::string_view(name, static_cast<std::size_t>(space - name)), space + 1};
}
bool is_tp(std::string_view uri) { return uri == kNamespace || uri == kOldNamespace; }

struct Attrs {
  const XML_Char** a;
  // The unqualified attribute `local` (or, with `uri`, the one in that namespace).
  const char* get(std::string_view local, std::string_view uri = {}) const {
    for (int i = 0; a[i]; i += 2) {
      const Name n = split(a[i]);
      if (n.local == local && n.uri == uri) return a[i + 1];
    }
    return nullptr;
  }
};

// Parses one XML part, calling `start`/`end`/`text` per element; they report a problem by
// returning a message, which stops the parse. Every problem → ParseError naming the part, line
// and column.
class XmlPart {
 public:
  using Start = std::function<std::string(Name, Attrs)>;
  using End = std::function<std::string(Name)>;
  using Text = std::function<void(std::string_view)>;
  XmlPart(const std::string& file, const std::string& part) : file_(file), part_(part) {}

  void parse(const std::string& bytes, Start start, End end, Text text = {}) {
    start_ = std::move(start);
    end_ = std::move(end);
    text_ = std::move(text);
    XML_Parser p = XML_ParserCreateNS("UTF-8", ' ');
    parser_ = p;
    XML_SetUserData(p, this);
    XML_SetElementHandler(p, &XmlPart::on_start, &XmlPart::on_end);
    if (text_) XML_SetCharacterDataHandler(p, &XmlPart::on_text);
    const XML_Status s = XML_Parse(p, bytes.data(), static_cast<int>(bytes.size()), XML_TRUE);
    const long line = static_cast<long>(XML_GetCurrentLineNumber(p));
    const long column = static_cast<long>(XML_GetCurrentColumnNumber(p)) + 1;
    std::string why = problem_;
    if (s == XML_STATUS_ERROR && why.empty()) why = XML_ErrorString(XML_GetErrorCode(p));
    XML_ParserFree(p);
    if (!why.empty())
      throw ParseError(fmt::format("{} line {}, column {}: {}", part_, line, column, why),
                       {file_, line, part_, column});
  }

 private:
  static void on_start(void* self, const XML_Char* name, const XML_Char** atts) {
    auto* x = static_cast<XmlPart*>(self);
    x->stop(x->start_(split(name), Attrs{atts}));
  }
  static void on_end(void* self, const XML_Char* name) {
    auto* x = static_cast<XmlPart*>(self);
    x->stop(x->end_(split(name)));
  }
  static void on_text(void* self, const XML_Char* s, int len) {
    static_cast<XmlPart*>(self)->text_(std::string_view(s, static_cast<std::size_t>(len)));
  }
  void stop(std::string why) {
    if (why.empty() || !problem_.empty()) return;
    problem_ = std::move(why);
    XML_StopParser(parser_, XML_FALSE);
  }
  std::string file_, part_, problem_;
  XML_Parser parser_ = nullptr;
  Start start_;
  End end_;
  Text text_;
};

bool to_double(const char* s, double& v) {
  if (!s || !*s) return false;
  char* e = nullptr;
  v = std::strtod(s, &e);
  return *e == '\0' && std::isfinite(v);
}
bool to_long(const char* s, long long& v) {
  if (!s || !*s) return false;
  char* e = nullptr;
  v = std::strtoll(s, &e, 10);
  return *e == '\0';
}

// §4.2: a modifier the reader applies (a constant one on a value the IR has).
struct Modifier {
  std::string attribute;
  double min = 0, max = 0;
};

struct Profile {
  std::string uuid, name;
  Path values;  // role, power, speed, width, height, tool, process values
  bool has_role = false, laser = false;
  std::optional<long long> laser_index;
  std::map<char, Modifier> modifiers;  // by factor e, f, g, h
};

struct LayerRef {
  std::string path;
  std::optional<long long> ztop;
  std::optional<double> z;  // ours, for 3-axis layers
};

struct Resource {
  long long id = 0;
  double unitfactor = 0;
  std::string type = "planar";
  std::vector<Profile> profiles;
  std::vector<LayerRef> layers;
  bool has_lasers = false;
  std::set<long long> lasers;
  std::optional<long long> default_laser;
  std::string source, job;
  std::map<std::string, int> part_of_uuid;  // our part labels: uuid → Path::part
  std::vector<std::string> part_labels;
};

struct Model {
  double mm = 1;  // millimetres per document unit
  std::vector<Resource> resources;
  std::optional<long long> toolpath_id;
};

double unit_mm(std::string_view unit) {
  if (unit == "micron") return 1e-3;
  if (unit == "millimeter") return 1;
  if (unit == "centimeter") return 10;
  if (unit == "inch") return 25.4;
  if (unit == "foot") return 304.8;
  if (unit == "meter") return 1000;
  return 0;
}

std::string read_profile(Profile& pr, Attrs a) {
  const char* uuid = a.get("uuid");
  const char* name = a.get("name");
  if (!uuid || !name) return "a <tp:toolpathprofile> without uuid or name (§4.1)";
  pr.uuid = uuid;
  pr.name = name;
  Path& v = pr.values;
  v.role = PathRole::Other;
  double d = 0;
  const auto number = [&](const char* key, double& into, std::string_view uri = {}) {
    if (const char* s = a.get(key, uri)) {
      if (!to_double(s, d)) return fmt::format("profile '{}': {}=\"{}\" is not a number", name, key, s);
      into = d;
    }
    return std::string();
  };
  std::string bad;
  for (const auto& [key, into] : {std::pair<const char*, double*>{"laserpower", &v.power},
                                  {"laserspeed", &v.speed}, {"depositionspeed", &v.speed},
                                  {"beadwidth", &v.width}, {"beadheight", &v.height}})
    if (bad.empty()) bad = number(key, *into);
  for (const auto& [key, into] : {std::pair<const char*, double*>{"power", &v.power},
                                  {"speed", &v.speed}, {"width", &v.width}, {"height", &v.height},
                                  {"temperature", &v.temperature}, {"flow", &v.flow}, {"fan", &v.fan}})
    if (bad.empty()) bad = number(key, *into, kTrellis);
  if (!bad.empty()) return bad;
  pr.laser = a.get("laserpower") || a.get("laserspeed");
  long long n = 0;
  if (const char* s = a.get("laserindex")) {
    if (!to_long(s, n) || n < 0) return fmt::format("profile '{}': laserindex=\"{}\"", name, s);
    pr.laser_index = n;
  }
  if (const char* s = a.get("tool", kTrellis)) {
    if (!to_long(s, n)) return fmt::format("profile '{}': t:tool=\"{}\"", name, s);
    v.tool = static_cast<int>(n);
  }
  if (const char* s = a.get("role", kTrellis)) {
    try {
      v.role = path_role_from_string(s);
    } catch (const Error& e) {
      return fmt::format("profile '{}': {}", name, e.message());
    }
    pr.has_role = true;
  }
  if (const char* s = a.get("mixture", kTrellis)) {
    std::string word;
    for (const char* c = s;; ++c) {
      if (*c == ' ' || *c == '\0') {
        if (!word.empty()) {
          if (!to_double(word.c_str(), d)) return fmt::format("profile '{}': t:mixture", name);
          v.mixture.push_back(d);
          word.clear();
        }
        if (*c == '\0') break;
      } else {
        word += *c;
      }
    }
  }
  return "";
}

// §4.2: only constant modifiers of the values the IR holds are applied; a consumer MUST reject
// a document with a modifier it does not support.
std::string read_modifier(Profile& pr, Attrs a) {
  const char* attribute = a.get("attribute");
  const char* type = a.get("type");
  const char* factor = a.get("factor");
  Modifier m;
  if (!attribute || !type || !factor || !to_double(a.get("minvalue"), m.min) ||
      !to_double(a.get("maxvalue"), m.max))
    return fmt::format("profile '{}': a <tp:modifier> needs attribute, type, factor, minvalue and "
                       "maxvalue (§4.2)",
                       pr.name);
  m.attribute = attribute;
  static const std::set<std::string> kHeld = {"laserpower", "laserspeed", "depositionspeed",
                                              "beadwidth", "beadheight"};
  if (std::string(type) != "constant")
    return fmt::format("profile '{}': a {} modifier of {}: Trellis applies constant modifiers only "
                       "(one value per path); §4.2 asks a consumer to refuse the file",
                       pr.name, type, attribute);
  if (!kHeld.count(m.attribute))
    return fmt::format("profile '{}': a modifier of '{}': Trellis modulates laserpower, laserspeed, "
                       "depositionspeed, beadwidth and beadheight only (§4.2)",
                       pr.name, attribute);
  const std::string f = factor;
  if (f.size() != 1 || std::string("efgh").find(f[0]) == std::string::npos)
    return fmt::format("profile '{}': modifier factor '{}' (e, f, g or h)", pr.name, f);
  pr.modifiers[f[0]] = m;
  return "";
}

Model read_model(const std::string& file, const std::string& part, const std::string& bytes) {
  Model m;
  Resource* res = nullptr;
  std::vector<std::string> stack;
  int data_depth = 0;  // inside <tp:toolpathdata>
  bool in_job = false;
  XmlPart x(file, part);
  x.parse(
      bytes,
      [&](Name n, Attrs a) -> std::string {
        stack.emplace_back(n.local);
        if (n.uri == kCore && n.local == "model") {
          const char* u = a.get("unit");
          m.mm = u ? unit_mm(u) : 1;
          if (m.mm == 0) return fmt::format("unknown model unit '{}'", u);
          return "";
        }
        if (n.uri == kCore && n.local == "build") {
          long long id = 0;
          const char* s = a.get("toolpathid", kNamespace);
          if (!s) s = a.get("toolpathid", kOldNamespace);
          if (s) {
            if (!to_long(s, id)) return fmt::format("<build tp:toolpathid=\"{}\">", s);
            m.toolpath_id = id;
          }
          return "";
        }
        if (data_depth > 0) {
          ++data_depth;
          if (n.uri == kTrellis && n.local == "job") in_job = true;
          if (n.uri == kTrellis && n.local == "trellis" && res)
            if (const char* s = a.get("source")) res->source = s;
          if (n.uri == kTrellis && n.local == "part" && res) {
            const char* uuid = a.get("uuid");
            const char* label = a.get("label");
            if (uuid && label) {
              res->part_labels.push_back(label);
              res->part_of_uuid[uuid] = static_cast<int>(res->part_labels.size());
            }
          }
          return "";
        }
        if (!is_tp(n.uri)) return "";
        if (n.local == "toolpathresource") {
          m.resources.emplace_back();
          res = &m.resources.back();
          if (!to_long(a.get("id"), res->id))
            return "a <tp:toolpathresource> without a numeric id (Chapter 4)";
          if (!to_double(a.get("unitfactor"), res->unitfactor) || !(res->unitfactor > 0))
            return "a <tp:toolpathresource> without a positive unitfactor (Chapter 4)";
          if (const char* t = a.get("toolpathtype")) res->type = t;
          if (res->type != "planar" && res->type != "3axis" && res->type != "6axis")
            return fmt::format("toolpathtype '{}' (planar, 3axis or 6axis, Chapter 4)", res->type);
          return "";
        }
        if (!res) return "";
        if (n.local == "toolpathdata") {
          data_depth = 1;
          return "";
        }
        if (n.local == "lasersources") {
          res->has_lasers = true;
          long long d = 0;
          if (const char* s = a.get("default")) {
            if (!to_long(s, d)) return fmt::format("<tp:lasersources default=\"{}\">", s);
            res->default_laser = d;
          }
          return "";
        }
        if (n.local == "lasersource") {
          long long i = 0;
          if (!to_long(a.get("index"), i)) return "a <tp:lasersource> without an index (§4.5)";
          if (!res->lasers.insert(i).second)
            return fmt::format("laser index {} declared twice (§4.5)", i);
          return "";
        }
        if (n.local == "toolpathprofile") {
          res->profiles.emplace_back();
          return read_profile(res->profiles.back(), a);
        }
        if (n.local == "modifier") {
          if (res->profiles.empty()) return "a <tp:modifier> outside a profile (§4.2)";
          return read_modifier(res->profiles.back(), a);
        }
        if (n.local == "toolpathlayer") {
          LayerRef l;
          const char* p = a.get("path");
          if (!p || !*p) return "a <tp:toolpathlayer> without a path (§4.3)";
          l.path = p;
          long long z = 0;
          if (const char* s = a.get("ztop")) {
            if (!to_long(s, z) || z < 0) return fmt::format("ztop=\"{}\" (§4.3)", s);
            l.ztop = z;
          }
          double d = 0;
          if (to_double(a.get("z", kTrellis), d)) l.z = d;
          res->layers.push_back(l);
        }
        return "";
      },
      [&](Name n) -> std::string {
        stack.pop_back();
        if (data_depth > 0) {
          --data_depth;
          if (n.uri == kTrellis && n.local == "job") in_job = false;
        }
        if (is_tp(n.uri) && n.local == "toolpathresource") res = nullptr;
        return "";
      },
      [&](std::string_view s) {
        if (in_job && res) res->job.append(s);
      });
  return m;
}

// Targets of the model part's relationships of the layer type (§3.2), as absolute part names.
std::set<std::string> layer_targets(const Package& pkg, const std::string& file,
                                    const std::string& model) {
  const std::size_t slash = model.rfind('/');
  const std::string dir = model.substr(0, slash + 1);
  const std::string rels = dir + "_rels/" + model.substr(slash + 1) + ".rels";
  std::set<std::string> out;
  const auto bytes = pkg.part(rels);
  if (!bytes) return out;
  XmlPart(file, rels).parse(
      *bytes,
      [&](Name n, Attrs a) -> std::string {
        if (n.local != "Relationship") return "";
        const char* type = a.get("Type");
        const char* target = a.get("Target");
        if (!type || !target) return "a <Relationship> without Type or Target";
        if (std::string(type) == kLayerRelationship || std::string(type) == kOldLayerRelationship)
          out.insert(target[0] == '/' ? target : dir + target);
        return "";
      },
      [](Name) { return std::string(); });
  return out;
}

std::string model_part_name(const Package& pkg, const std::string& file) {
  std::string model = "/3D/3dmodel.model";
  if (const auto rels = pkg.part("_rels/.rels"))
    XmlPart(file, "/_rels/.rels")
        .parse(
            *rels,
            [&](Name n, Attrs a) -> std::string {
              const char* type = a.get("Type");
              const char* target = a.get("Target");
              if (n.local == "Relationship" && type && target && std::string(type) == kModelRelationship)
                model = target[0] == '/' ? target : "/" + std::string(target);
              return "";
            },
            [](Name) { return std::string(); });
  return model;
}

// One layer part (Part II) → the IR layer.
class LayerReader {
 public:
  LayerReader(const Resource& r, double mm, Diagnostics* diag, std::set<long long>& lasers)
      : r_(r), scale_(r.unitfactor * mm), lasers_(lasers) {
    (void)diag;
  }

  Layer read(const std::string& file, const std::string& part, const std::string& bytes, double z) {
    layer_.z = z;
    XmlPart(file, part).parse(
        bytes, [&](Name n, Attrs a) { return start(n, a); }, [&](Name n) { return end(n); });
    return std::move(layer_);
  }

 private:
  std::string start(Name n, Attrs a) {
    if (n.uri == kTrellis && n.local == "via" && in_segment_) {
      Vec3 q;
      if (!coord(a, "x", q.x) || !coord(a, "y", q.y) || !coord(a, "z", q.z))
        return "<t:via> needs integer x, y and z";
      base_.via.push_back(q);
      return "";
    }
    if (!is_tp(n.uri)) return "";
    if (n.local == "part") {
      long long id = 0;
      const char* uuid = a.get("uuid");
      if (!to_long(a.get("id"), id) || !uuid) return "a <part> without id or uuid (§1.1.1)";
      const auto it = r_.part_of_uuid.find(uuid);
      parts_[id] = it == r_.part_of_uuid.end() ? 0 : it->second;
      return "";
    }
    if (n.local == "profile") {
      long long id = 0;
      const char* uuid = a.get("uuid");
      if (!to_long(a.get("id"), id) || !uuid) return "a <profile> without id or uuid (§1.1.2)";
      for (std::size_t k = 0; k < r_.profiles.size(); ++k)
        if (r_.profiles[k].uuid == uuid) {
          profiles_[id] = k;
          return "";
        }
      return fmt::format("<profile id=\"{}\"> names uuid {}, which no <tp:toolpathprofile> of the "
                         "resource has (§1.1.2)",
                         id, uuid);
    }
    if (n.local == "segment") return segment(a);
    if (n.local == "point" || n.local == "point3d" || n.local == "hatch" || n.local == "point6d")
      return element(n.local, a);
    if (n.local == "sub")
      return "a <sub> support point: nonlinear modifiers are not applied by Trellis (§4.2)";
    return "";
  }

  std::string end(Name n) {
    if (!is_tp(n.uri) || n.local != "segment") return "";
    in_segment_ = false;
    const std::size_t need = type_ == "loop" ? 3 : type_ == "hatch" ? 1 : 2;
    if (count_ < need)
      return fmt::format("a {} segment with {} {}; it needs at least {} (§1.3, §1.4)", type_,
                         count_, type_ == "hatch" ? "hatches" : "points", need);
    if (type_ == "loop") {
      Path& last = layer_.paths.back();
      // §1.3.2: the closing line back to the first point is implied (a repeated first point is
      // redundant); it carries the first point's factors, so it joins the first piece's values.
      const Vec3 first = layer_.paths[first_path_].points.front();
      if (distance(last.points.back(), first) > 0) {
        if (close_value_ == piece_value_) {
          last.points.push_back(first);
        } else {
          Path closing = base_;
          apply(closing, close_value_);
          closing.joined = true;
          closing.points = {last.points.back(), first};
          closing.via.clear();
          layer_.paths.push_back(std::move(closing));
        }
      }
    }
    return "";
  }

  bool coord(Attrs a, const char* key, double& v) const {
    long long n = 0;
    if (!to_long(a.get(key), n)) return false;
    v = static_cast<double>(n) * scale_;
    return true;
  }

  std::string segment(Attrs a) {
    const char* type = a.get("type");
    type_ = type ? type : "";
    long long profile = 0, part = 0;
    if (!to_long(a.get("profileid"), profile) || !to_long(a.get("partid"), part))
      return "a <segment> needs profileid and partid (§1.2)";
    const auto pr = profiles_.find(profile);
    if (pr == profiles_.end())
      return fmt::format("segment profileid {} is not declared in the layer's <profiles> (§1.1.2)",
                         profile);
    const auto pa = parts_.find(part);
    if (pa == parts_.end())
      return fmt::format("segment partid {} is not declared in the layer's <parts> (§1.1.1)", part);
    const bool planar = type_ == "loop" || type_ == "polyline" || type_ == "hatch";
    if (!planar && type_ != "polyline3d" && type_ != "polyline6d")
      return fmt::format("segment type '{}' (loop, polyline, hatch, polyline3d or polyline6d; §1.2 "
                         "asks a consumer to refuse the layer)",
                         type_);
    if (type_ == "polyline6d")
      return "a 6-axis segment: the toolpath IR has no tool orientation, Trellis does not read "
             "6-axis toolpaths (§1.4.2)";
    if (planar != (r_.type == "planar"))
      return fmt::format("a {} segment in a toolpath of type {} (§1.3, §1.4)", type_, r_.type);
    profile_ = &r_.profiles[pr->second];
    // §4.5: segment laserindex, else the profile's, else the lasersources default.
    std::optional<long long> laser = profile_->laser_index;
    long long li = 0;
    if (const char* s = a.get("laserindex")) {
      if (!to_long(s, li) || li < 0) return fmt::format("laserindex=\"{}\"", s);
      laser = li;
    }
    if (!laser) laser = r_.default_laser;
    if (laser && r_.has_lasers && !r_.lasers.count(*laser))
      return fmt::format("laser index {} is not declared in <tp:lasersources> (§4.5)", *laser);
    if (laser) lasers_.insert(*laser);
    base_ = profile_->values;
    if (!profile_->has_role)
      base_.role = type_ == "hatch" ? PathRole::Hatch
                   : profile_->laser ? PathRole::Contour
                   : planar          ? PathRole::Other
                                     : PathRole::Nonplanar;
    base_.part = pa->second;
    double d = 0;
    if (to_double(a.get("filament", kTrellis), d)) base_.filament = d;
    if (const char* s = a.get("joined", kTrellis)) base_.joined = std::string(s) == "1";
    if (const char* s = a.get("inside", kTrellis)) base_.inside = std::string(s) == "1";
    in_segment_ = true;
    count_ = 0;
    first_path_ = layer_.paths.size();
    return "";
  }

  // The modifier factors on an element (§4.2, Part II §1.2.1): the values they set.
  using Values = std::map<std::string, double>;
  std::string factors(Attrs a, Values& v) const {
    for (char f : std::string("efgh")) {
      const std::string one(1, f);
      const char* s = a.get(one);
      if (!s && (a.get(one + "1") || a.get(one + "2")))
        return fmt::format("a linear factor {}1/{}2: the profile's modifiers are constant (§4.2)", f, f);
      if (!s) continue;
      double x = 0;
      if (!to_double(s, x) || x < 0 || x > 1) return fmt::format("factor {}=\"{}\" (0..1)", f, s);
      const auto m = profile_->modifiers.find(f);
      if (m == profile_->modifiers.end())
        return fmt::format("factor {} on a segment of profile '{}', which declares no modifier {} "
                           "(§4.2)",
                           f, profile_->name, f);
      v[m->second.attribute] = m->second.min + x * (m->second.max - m->second.min);
    }
    return "";
  }

  static void apply(Path& p, const Values& v) {
    for (const auto& [attribute, x] : v) {
      if (attribute == "laserpower") p.power = x;
      if (attribute == "laserspeed" || attribute == "depositionspeed") p.speed = x;
      if (attribute == "beadwidth") p.width = x;
      if (attribute == "beadheight") p.height = x;
    }
  }

  std::string element(std::string_view name, Attrs a) {
    if (!in_segment_) return fmt::format("a <{}> outside a segment", name);
    Values v;
    if (std::string bad = factors(a, v); !bad.empty()) return bad;
    if (name == "hatch") {
      if (type_ != "hatch") return fmt::format("a <hatch> in a {} segment (§1.2.1)", type_);
      Path p = base_;
      apply(p, v);
      Vec3 s{0, 0, layer_.z}, e{0, 0, layer_.z};
      if (!coord(a, "x1", s.x) || !coord(a, "y1", s.y) || !coord(a, "x2", e.x) || !coord(a, "y2", e.y))
        return "a <hatch> needs integer x1, y1, x2 and y2 (§1.2.1)";
      p.points = {s, e};
      if (count_ > 0) p.via.clear(), p.joined = false, p.filament = 0, p.inside = false;
      layer_.paths.push_back(std::move(p));
      ++count_;
      return "";
    }
    const bool three = name == "point3d";
    if (type_ == "hatch" || three != (type_ == "polyline3d"))
      return fmt::format("a <{}> in a {} segment (§1.2.1)", name, type_);
    Vec3 q{0, 0, layer_.z};
    if (!coord(a, "x", q.x) || !coord(a, "y", q.y) || (three && !coord(a, "z", q.z)))
      return fmt::format("a <{}> needs integer x, y{} (§1.2.1)", name, three ? " and z" : "");
    // Each point after the first closes the line into it and carries that line's factors; a
    // change of value along the chain starts a new path joined to the previous one.
    if (count_ == 0) {
      close_value_ = v;
      piece_value_ = v;
      Path p = base_;
      apply(p, v);
      p.points = {q};
      layer_.paths.push_back(std::move(p));
    } else if (count_ == 1 || v == piece_value_) {
      if (count_ == 1 && v != piece_value_) {
        piece_value_ = v;
        apply(layer_.paths.back(), v);
      }
      layer_.paths.back().points.push_back(q);
    } else {
      Path p = base_;
      apply(p, v);
      p.joined = true;
      p.via.clear();
      p.points = {layer_.paths.back().points.back(), q};
      piece_value_ = v;
      layer_.paths.push_back(std::move(p));
    }
    ++count_;
    return "";
  }

  const Resource& r_;
  double scale_;
  std::set<long long>& lasers_;
  Layer layer_;
  std::map<long long, int> parts_;
  std::map<long long, std::size_t> profiles_;
  const Profile* profile_ = nullptr;
  Path base_;
  std::string type_;
  bool in_segment_ = false;
  std::size_t count_ = 0, first_path_ = 0;
  Values close_value_, piece_value_;
};

const Resource& chosen(const Model& m, const std::string& file) {
  if (m.resources.empty())
    throw ParseError("a 3MF with no toolpath in it (no <tp:toolpathresource> of the 3MF Toolpath "
                     "Extension): a mesh or lattice 3MF is a design — slice or plan it, or view it",
                     {file});
  // §4.6: the build's tp:toolpathid, else the only resource.
  if (m.toolpath_id) {
    for (const Resource& r : m.resources)
      if (r.id == *m.toolpath_id) return r;
    throw ParseError(fmt::format("<build tp:toolpathid=\"{}\"> names no toolpath resource (§4.6)",
                                 *m.toolpath_id),
                     {file});
  }
  if (m.resources.size() > 1)
    throw ParseError(fmt::format("{} toolpath resources and no <build tp:toolpathid> to choose one "
                                 "(§4.6)",
                                 m.resources.size()),
                     {file});
  return m.resources.front();
}

}  // namespace

Toolpath read_toolpath_3mf_file(const std::string& path, Diagnostics* diag) {
  const Package pkg(path);
  const std::string model_name = model_part_name(pkg, path);
  const auto model_bytes = pkg.part(model_name);
  if (!model_bytes) throw ParseError("the package has no model part " + model_name, {path});
  const Model m = read_model(path, model_name, *model_bytes);
  const Resource& r = chosen(m, path);
  if (r.type == "6axis")
    throw ParseError("a 6-axis toolpath: the toolpath IR has no tool orientation, Trellis does not "
                     "read 6-axis toolpaths (§2.2)",
                     {path});
  const std::set<std::string> targets = layer_targets(pkg, path, model_name);
  Toolpath tp;
  tp.source = r.source.empty() ? path : r.source;
  tp.job = r.job;
  tp.part_labels = r.part_labels;
  std::set<long long> lasers;
  for (std::size_t i = 0; i < r.layers.size(); ++i) {
    const LayerRef& l = r.layers[i];
    // §4.3/§3.2: the layer's path must also be a target of a layer relationship.
    if (!targets.count(l.path))
      throw ParseError(fmt::format("toolpath layer {} names part {}, which is not the target of a "
                                   "layer relationship from {} (§3.2)",
                                   i + 1, l.path, model_name),
                       {path});
    if (r.type == "planar" && !l.ztop)
      throw ParseError(fmt::format("toolpath layer {} ({}) has no ztop, which planar layers need "
                                   "(§4.3)",
                                   i + 1, l.path),
                       {path});
    const auto bytes = pkg.part(l.path);
    if (!bytes)
      throw ParseError(fmt::format("toolpath layer {}: the package has no part {}", i + 1, l.path),
                       {path});
    const double z = l.ztop ? static_cast<double>(*l.ztop) * r.unitfactor * m.mm : l.z.value_or(0);
    LayerReader reader(r, m.mm, diag, lasers);
    Layer layer = reader.read(path, l.path, *bytes, z);
    if (!l.ztop && !l.z && !layer.paths.empty()) layer.z = layer.paths.front().points.front().z;
    tp.layers.push_back(std::move(layer));
  }
  if (lasers.size() > 1 && diag)
    diag->warn("3mf_lasers",
               fmt::format("{}: the toolpath uses {} lasers; the toolpath IR has no laser index, so "
                           "their paths are read as one laser's, in document order",
                           path, lasers.size()));
  return tp;
}

Toolpath3mfKind toolpath_3mf_kind(const std::string& path) {
  try {
    const Package pkg(path);
    const std::string name = model_part_name(pkg, path);
    const auto model = pkg.part(name);
    if (!model) return Toolpath3mfKind::None;
    const Model m = read_model(path, name, *model);
    if (m.resources.empty()) return Toolpath3mfKind::None;
    const Resource& r = chosen(m, path);
    for (const Profile& p : r.profiles)
      if (p.laser) return Toolpath3mfKind::Laser;
    return Toolpath3mfKind::Deposition;
  } catch (const ParseError&) {
    return Toolpath3mfKind::None;
  }
}

}  // namespace trellis::impl

TRELLIS_MODULE_ENTRY(toolpath3mf, trellis::Toolpath3mfModule, &trellis::impl::write_toolpath_3mf,
                     &trellis::impl::read_toolpath_3mf_file, &trellis::impl::toolpath_3mf_kind)
