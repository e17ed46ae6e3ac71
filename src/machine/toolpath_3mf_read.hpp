// The reader's shared pieces (src/machine/toolpath_3mf_read.cpp, toolpath_3mf_layer.cpp): the
// package, expat over one XML part, and what the model part says (resources, profiles, layers).
#pragma once
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
#include <string>
#include <vector>

#include "toolpath_3mf_module.hpp"
#include "trellis/core/error.hpp"

namespace trellis::impl::tp3mf_read {

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
inline Name split(const XML_Char* name) {
  const char* space = std::strrchr(name, ' ');
  if (!space) return {{}, name};
  return {std::string_view(name, static_cast<std::size_t>(space - name)), space + 1};
}
inline bool is_tp(std::string_view uri) {
  return uri == kNamespace || uri == kOldNamespace;
}

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

inline bool to_double(const char* s, double& v) {
  if (!s || !*s) return false;
  char* e = nullptr;
  v = std::strtod(s, &e);
  return *e == '\0' && std::isfinite(v);
}
inline bool to_long(const char* s, long long& v) {
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
  bool set = false;  // t:set: the name is a laser parameter set's (Toolpath::parameter_sets)
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
  std::vector<LaserParameters> lasers_declared;  // our <t:laser> metadata (Toolpath::lasers)
};

struct Model {
  double mm = 1;  // millimetres per document unit
  std::vector<Resource> resources;
  std::optional<long long> toolpath_id;
};

// One layer part (Part II) → the IR layer at height `z` (mm); `mm`: millimetres per document
// unit; the laser indices its segments resolve to are added to `lasers`.
Layer read_layer_part(const Resource& resource, double mm, const std::string& file,
                      const std::string& part, const std::string& bytes, double z,
                      std::set<long long>& lasers);

}  // namespace trellis::impl::tp3mf_read
