// A 3MF package's Toolpath Extension v1.0 data → the toolpath IR (section numbers are the
// specification's, 3MFConsortium/spec_toolpath): the package's model part (resources, profiles,
// laser sources, layer references and relationships), then each layer part
// (toolpath_3mf_layer.cpp). libzip for the package, expat streaming over each XML part so that an
// error names the part, line and column. Part of the toolpath3mf module.
#include "toolpath_3mf_read.hpp"

namespace trellis::impl {

namespace {

using namespace tp3mf_read;

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
      if (!to_double(s, d))
        return fmt::format("profile '{}': {}=\"{}\" is not a number", name, key, s);
      into = d;
    }
    return std::string();
  };
  std::string bad;
  for (const auto& [key, into] : {std::pair<const char*, double*>{"laserpower", &v.power},
                                  {"laserspeed", &v.speed},
                                  {"depositionspeed", &v.speed},
                                  {"beadwidth", &v.width},
                                  {"beadheight", &v.height}})
    if (bad.empty()) bad = number(key, *into);
  for (const auto& [key, into] : {std::pair<const char*, double*>{"power", &v.power},
                                  {"speed", &v.speed},
                                  {"width", &v.width},
                                  {"height", &v.height},
                                  {"temperature", &v.temperature},
                                  {"flow", &v.flow},
                                  {"fan", &v.fan}})
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
  if (const char* s = a.get("set", kTrellis)) {
    pr.name = s;
    pr.set = true;
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
    return fmt::format(
        "profile '{}': a <tp:modifier> needs attribute, type, factor, minvalue and "
        "maxvalue (§4.2)",
        pr.name);
  m.attribute = attribute;
  static const std::set<std::string> kHeld = {"laserpower", "laserspeed", "depositionspeed",
                                              "beadwidth", "beadheight"};
  if (std::string(type) != "constant")
    return fmt::format(
        "profile '{}': a {} modifier of {}: Trellis applies constant modifiers only "
        "(one value per path); §4.2 asks a consumer to refuse the file",
        pr.name, type, attribute);
  if (!kHeld.count(m.attribute))
    return fmt::format(
        "profile '{}': a modifier of '{}': Trellis modulates laserpower, laserspeed, "
        "depositionspeed, beadwidth and beadheight only (§4.2)",
        pr.name, attribute);
  const std::string f = factor;
  if (f.size() != 1 || std::string("efgh").find(f[0]) == std::string::npos)
    return fmt::format("profile '{}': modifier factor '{}' (e, f, g or h)", pr.name, f);
  pr.modifiers[f[0]] = m;
  return "";
}

// Our <t:laser index=…> (toolpath_3mf_write.cpp laser_xml): one of the lasers that differ, every
// value given; a missing or malformed one is refused by name.
std::string read_declared_laser(std::vector<LaserParameters>& lasers, Attrs a) {
  long long i = 0;
  if (!to_long(a.get("index"), i) || i < 0 || i > 1000)
    return "a <t:laser> without an index from 0 to 1000";
  const auto k = static_cast<std::size_t>(i);
  if (lasers.size() <= k) lasers.resize(k + 1);
  LaserParameters& l = lasers[k];
  ScanTiming& t = l.timing;
  for (const auto& [key, into] : std::initializer_list<std::pair<const char*, double*>>{
           {"contourpower", &l.contour_power},
           {"contourspeed", &l.contour_speed},
           {"hatchpower", &l.hatch_power},
           {"hatchspeed", &l.hatch_speed},
           {"spotdiameter", &l.spot_diameter},
           {"jumpspeed", &t.jump_speed},
           {"jumpdelay", &t.jump_delay},
           {"markdelay", &t.mark_delay},
           {"polygondelay", &t.polygon_delay},
           {"laserondelay", &t.laser_on_delay},
           {"laseroffdelay", &t.laser_off_delay}})
    if (!to_double(a.get(key), *into) || !std::isfinite(*into) || *into < 0)
      return fmt::format("<t:laser index=\"{}\"> without a number {} of 0 or more", i, key);
  t.contour_speed = l.contour_speed, t.hatch_speed = l.hatch_speed;
  // Skywriting (written since it is per laser; a package without it: the laser does not skywrite).
  if (const char* s = a.get("skywriting")) {
    const std::string_view v(s);
    if (v != "true" && v != "false")
      return fmt::format("<t:laser index=\"{}\"> skywriting=\"{}\" (expected true or false)", i, v);
    t.skywriting = v == "true";
  }
  if (a.get("skywritingtime") && (!to_double(a.get("skywritingtime"), t.skywriting_time) ||
                                  !std::isfinite(t.skywriting_time) || t.skywriting_time < 0))
    return fmt::format("<t:laser index=\"{}\"> without a number skywritingtime of 0 or more", i);
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
          if (n.uri == kTrellis && n.local == "laser" && res)
            return read_declared_laser(res->lasers_declared, a);
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
  XmlPart(file, rels)
      .parse(
          *bytes,
          [&](Name n, Attrs a) -> std::string {
            if (n.local != "Relationship") return "";
            const char* type = a.get("Type");
            const char* target = a.get("Target");
            if (!type || !target) return "a <Relationship> without Type or Target";
            if (std::string(type) == kLayerRelationship ||
                std::string(type) == kOldLayerRelationship)
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
              if (n.local == "Relationship" && type && target &&
                  std::string(type) == kModelRelationship)
                model = std::string(target[0] == '/' ? "" : "/").append(target);
              return "";
            },
            [](Name) { return std::string(); });
  return model;
}

// One layer part (Part II) → the IR layer.

const Resource& chosen(const Model& m, const std::string& file) {
  if (m.resources.empty())
    throw ParseError(
        "a 3MF with no toolpath in it (no <tp:toolpathresource> of the 3MF Toolpath "
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
    throw ParseError(
        "a 6-axis toolpath: the toolpath IR has no tool orientation, Trellis does not "
        "read 6-axis toolpaths (§2.2)",
        {path});
  const std::set<std::string> targets = layer_targets(pkg, path, model_name);
  Toolpath tp;
  tp.source = r.source.empty() ? path : r.source;
  tp.job = r.job;
  tp.part_labels = r.part_labels;
  tp.lasers = r.lasers_declared;
  for (const Profile& p : r.profiles)
    if (p.set && parameter_set_of(tp, p.values.role, p.values.power, p.values.speed) < 0)
      tp.parameter_sets.push_back({p.name, p.values.role, p.values.power, p.values.speed});
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
    Layer layer = read_layer_part(r, m.mm, path, l.path, *bytes, z, lasers);
    if (!l.ztop && !l.z && !layer.paths.empty()) layer.z = layer.paths.front().points.front().z;
    tp.layers.push_back(std::move(layer));
  }
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
