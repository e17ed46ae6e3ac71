#include "trellis/toolpath/json.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "../core/json_document.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/toolpath/check.hpp"
#include "trellis/version.hpp"

namespace trellis {

using nlohmann::json;

std::string toolpath_to_json(const Toolpath& tp) {
  json layers = json::array();
  for (const auto& layer : tp.layers) {
    json paths = json::array();
    for (const auto& p : layer.paths) {
      json pts = json::array();
      for (const auto& q : p.points) pts.push_back({q.x, q.y, q.z});
      json jp = {{"role", to_string(p.role)}, {"tool", p.tool},   {"width", p.width},
                 {"height", p.height},        {"speed", p.speed}, {"points", std::move(pts)}};
      if (!p.mixture.empty()) jp["mixture"] = p.mixture;
      if (p.power != 0) jp["power"] = p.power;
      if (p.filament != 0) jp["filament"] = p.filament;
      if (p.temperature != 0) jp["temperature"] = p.temperature;
      if (p.flow != 0) jp["flow"] = p.flow;
      if (p.fan >= 0) jp["fan"] = p.fan;
      if (p.joined) jp["joined"] = true;
      if (!p.via.empty()) {
        json via = json::array();
        for (const auto& q : p.via) via.push_back({q.x, q.y, q.z});
        jp["via"] = std::move(via);
      }
      if (p.inside) jp["inside"] = true;
      paths.push_back(std::move(jp));
    }
    layers.push_back({{"z", layer.z}, {"paths", std::move(paths)}});
  }
  json doc = {{"format", "trellis.toolpath"},
              {"version", 1},
              {"units", "mm"},
              {"source", tp.source},
              {"generator", std::string("Trellis ") + TRELLIS_VERSION}};
  if (!tp.job.empty()) doc["job"] = tp.job;
  if (!tp.parameter_sets.empty()) {
    json sets = json::array();
    for (const ParameterSet& s : tp.parameter_sets)
      sets.push_back(
          {{"name", s.name}, {"role", to_string(s.role)}, {"power", s.power}, {"speed", s.speed}});
    doc["parameter_sets"] = std::move(sets);
  }
  if (!tp.lasers.empty()) {
    json lasers = json::array();
    for (const LaserParameters& l : tp.lasers) {
      const ScanTiming& t = l.timing;
      lasers.push_back({{"contour_power", l.contour_power},
                        {"contour_speed", l.contour_speed},
                        {"hatch_power", l.hatch_power},
                        {"hatch_speed", l.hatch_speed},
                        {"spot_diameter", l.spot_diameter},
                        {"jump_speed", t.jump_speed},
                        {"jump_delay", t.jump_delay},
                        {"mark_delay", t.mark_delay},
                        {"polygon_delay", t.polygon_delay},
                        {"laser_on_delay", t.laser_on_delay},
                        {"laser_off_delay", t.laser_off_delay},
                        {"skywriting", t.skywriting},
                        {"skywriting_time", t.skywriting_time}});
    }
    doc["lasers"] = std::move(lasers);
  }
  doc["layers"] = std::move(layers);
  return doc.dump(1) + "\n";
}

namespace {

double number(const json& j, const std::string& origin, const std::string& element) {
  if (!j.is_number()) throw ParseError("expected a number", {origin, 0, element});
  const double v = j.get<double>();
  // Beyond ±1e6 (1 km, or 1000 km/s) nothing is printable, and writers could overflow.
  if (!std::isfinite(v) || std::abs(v) > 1e6)
    throw ParseError("number is not finite or beyond ±1e6", {origin, 0, element});
  return v;
}

double optional_number(const json& obj, const char* key, const std::string& origin,
                       const std::string& element) {
  auto it = obj.find(key);
  return it == obj.end() ? 0.0 : number(*it, origin, element + "." + key);
}

Path parse_path(const json& jp, const std::string& origin, const std::string& el) {
  if (!jp.is_object()) throw ParseError("expected an object", {origin, 0, el});
  Path p;
  if (auto it = jp.find("role"); it != jp.end()) {
    if (!it->is_string()) throw ParseError("role must be a string", {origin, 0, el + ".role"});
    try {
      p.role = path_role_from_string(it->get<std::string>());
    } catch (const Error& e) {
      throw ParseError(e.message(), {origin, 0, el + ".role"});
    }
  }
  p.tool = static_cast<int>(optional_number(jp, "tool", origin, el));
  p.width = optional_number(jp, "width", origin, el);
  p.height = optional_number(jp, "height", origin, el);
  p.speed = optional_number(jp, "speed", origin, el);
  p.power = optional_number(jp, "power", origin, el);
  p.filament = optional_number(jp, "filament", origin, el);
  p.temperature = optional_number(jp, "temperature", origin, el);
  p.flow = optional_number(jp, "flow", origin, el);
  if (auto it = jp.find("fan"); it != jp.end()) {
    p.fan = number(*it, origin, el + ".fan");
    if (p.fan < 0 || p.fan > 100)
      throw ParseError("fan must be 0..100 %", {origin, 0, el + ".fan"});
  }
  if (auto it = jp.find("joined"); it != jp.end()) {
    if (!it->is_boolean())
      throw ParseError("joined must be true or false", {origin, 0, el + ".joined"});
    p.joined = it->get<bool>();
  }
  if (auto it = jp.find("inside"); it != jp.end()) {
    if (!it->is_boolean())
      throw ParseError("inside must be true or false", {origin, 0, el + ".inside"});
    p.inside = it->get<bool>();
  }
  if (auto it = jp.find("via"); it != jp.end()) {
    if (!it->is_array())
      throw ParseError("via must be an array of [x, y, z]", {origin, 0, el + ".via"});
    for (std::size_t i = 0; i < it->size(); ++i) {
      const std::string ve = el + ".via[" + std::to_string(i) + "]";
      const json& q = (*it)[i];
      if (!q.is_array() || q.size() != 3) throw ParseError("expected [x, y, z]", {origin, 0, ve});
      p.via.push_back(
          {number(q[0], origin, ve), number(q[1], origin, ve), number(q[2], origin, ve)});
    }
  }
  if (auto it = jp.find("mixture"); it != jp.end()) {
    if (!it->is_array()) throw ParseError("mixture must be an array", {origin, 0, el});
    for (std::size_t i = 0; i < it->size(); ++i)
      p.mixture.push_back(number((*it)[i], origin, el + ".mixture[" + std::to_string(i) + "]"));
  }
  auto pts = jp.find("points");
  if (pts == jp.end() || !pts->is_array() || pts->size() < 2)
    throw ParseError("a path needs 'points' with at least 2 points", {origin, 0, el});
  for (std::size_t i = 0; i < pts->size(); ++i) {
    const std::string pe = el + ".points[" + std::to_string(i) + "]";
    const json& q = (*pts)[i];
    if (!q.is_array() || q.size() != 3) throw ParseError("expected [x, y, z]", {origin, 0, pe});
    p.points.push_back(
        {number(q[0], origin, pe), number(q[1], origin, pe), number(q[2], origin, pe)});
  }
  if (const auto problem = path_problem(p)) {
    const bool indexed = problem->attribute == "points" || problem->attribute == "via" ||
                         problem->attribute == "mixture";
    throw ParseError(problem->attribute + " " + problem->message,
                     {origin, 0,
                      el + "." + problem->attribute +
                          (indexed ? "[" + std::to_string(problem->index) + "]" : "")});
  }
  return p;
}

std::vector<ParameterSet> parse_parameter_sets(const json& js, const std::string& origin) {
  if (!js.is_array())
    throw ParseError("parameter_sets must be an array", {origin, 0, "parameter_sets"});
  std::vector<ParameterSet> sets;
  for (std::size_t i = 0; i < js.size(); ++i) {
    const std::string el = "parameter_sets[" + std::to_string(i) + "]";
    const json& j = js[i];
    const auto name = j.is_object() ? j.find("name") : j.end();
    const auto role = j.is_object() ? j.find("role") : j.end();
    if (name == j.end() || !name->is_string() || role == j.end() || !role->is_string())
      throw ParseError("a parameter set needs a \"name\" and a \"role\" (strings)",
                       {origin, 0, el});
    ParameterSet s;
    s.name = *name;
    try {
      s.role = path_role_from_string(*role);
    } catch (const ParseError& e) {
      throw ParseError(e.message(), {origin, 0, el + ".role"});
    }
    s.power = optional_number(j, "power", origin, el);
    s.speed = optional_number(j, "speed", origin, el);
    sets.push_back(std::move(s));
  }
  return sets;
}

// "lasers": one object per laser, laser 1 first, every value given (Toolpath::lasers).
std::vector<LaserParameters> parse_lasers(const json& js, const std::string& origin) {
  if (!js.is_array())
    throw ParseError("lasers must be an array of objects, one per laser", {origin, 0, "lasers"});
  std::vector<LaserParameters> lasers;
  for (std::size_t i = 0; i < js.size(); ++i) {
    const std::string el = "lasers[" + std::to_string(i) + "]";
    const json& j = js[i];
    if (!j.is_object()) throw ParseError("expected an object", {origin, 0, el});
    LaserParameters l;
    ScanTiming& t = l.timing;
    const std::pair<const char*, double*> values[] = {
        {"contour_power", &l.contour_power},     {"contour_speed", &l.contour_speed},
        {"hatch_power", &l.hatch_power},         {"hatch_speed", &l.hatch_speed},
        {"spot_diameter", &l.spot_diameter},     {"jump_speed", &t.jump_speed},
        {"jump_delay", &t.jump_delay},           {"mark_delay", &t.mark_delay},
        {"polygon_delay", &t.polygon_delay},     {"laser_on_delay", &t.laser_on_delay},
        {"laser_off_delay", &t.laser_off_delay}, {"skywriting_time", &t.skywriting_time}};
    for (const auto& [key, into] : values) {
      const auto it = j.find(key);
      if (it == j.end()) throw ParseError(std::string("missing ") + key, {origin, 0, el});
      *into = number(*it, origin, el + "." + key);
      if (*into < 0) throw ParseError("must be 0 or more", {origin, 0, el + "." + key});
    }
    const auto sky = j.find("skywriting");
    if (sky == j.end() || !sky->is_boolean())
      throw ParseError("skywriting must be true or false", {origin, 0, el + ".skywriting"});
    t.skywriting = sky->get<bool>();
    t.contour_speed = l.contour_speed, t.hatch_speed = l.hatch_speed;
    for (const auto& [key, value] : j.items()) {
      bool known = key == "skywriting";
      for (const auto& v : values) known |= key == v.first;
      if (!known) throw ParseError("unknown laser value", {origin, 0, el + "." + key});
    }
    lasers.push_back(l);
  }
  return lasers;
}

}  // namespace

static Toolpath toolpath_from_document(const json& doc, const std::string& origin) {
  const auto format = doc.is_object() ? doc.find("format") : doc.end();
  if (!doc.is_object() || format == doc.end() || *format != "trellis.toolpath")
    throw ParseError("not a Trellis toolpath (missing \"format\": \"trellis.toolpath\")", {origin});
  const auto version = doc.find("version");
  if (version == doc.end() || *version != 1)
    throw ParseError("unsupported toolpath version (this build reads version 1)", {origin});
  if (auto units = doc.find("units"); units != doc.end() && *units != "mm")
    throw ParseError("units " + units->dump() +
                         ": a Trellis toolpath is in millimetres (\"mm\"); "
                         "convert the coordinates, widths and heights",
                     {origin, 0, "units"});
  Toolpath tp;
  if (auto it = doc.find("source"); it != doc.end() && it->is_string()) tp.source = *it;
  if (auto it = doc.find("parameter_sets"); it != doc.end())
    tp.parameter_sets = parse_parameter_sets(*it, origin);
  if (auto it = doc.find("lasers"); it != doc.end()) tp.lasers = parse_lasers(*it, origin);
  auto layers = doc.find("layers");
  if (layers == doc.end() || !layers->is_array())
    throw ParseError("missing 'layers' array", {origin});
  for (std::size_t li = 0; li < layers->size(); ++li) {
    const std::string el = "layers[" + std::to_string(li) + "]";
    const json& jl = (*layers)[li];
    if (!jl.is_object()) throw ParseError("expected an object", {origin, 0, el});
    Layer layer;
    layer.z = optional_number(jl, "z", origin, el);
    auto paths = jl.find("paths");
    if (paths == jl.end() || !paths->is_array())
      throw ParseError("missing 'paths' array", {origin, 0, el});
    for (std::size_t pi = 0; pi < paths->size(); ++pi)
      layer.paths.push_back(
          parse_path((*paths)[pi], origin, el + ".paths[" + std::to_string(pi) + "]"));
    tp.layers.push_back(std::move(layer));
  }
  return tp;
}

Toolpath toolpath_from_json(const std::string& text, const std::string& origin) {
  return read_json_document(text, origin,
                            [&](const json& doc) { return toolpath_from_document(doc, origin); });
}

Toolpath read_toolpath(const std::string& path) {
  return toolpath_from_json(read_file(path), path);
}

void write_toolpath(const std::string& path, const Toolpath& toolpath) {
  write_file_atomic(path, toolpath_to_json(toolpath));
}

}  // namespace trellis
