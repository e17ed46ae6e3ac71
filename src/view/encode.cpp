// The data blocks of a viewer page: each scene's meta (JSON), its layers (base64 binary, as
// chunks per layer or packed and deflated), the design overlay and the extras; viewer/src/data.js
// reads them back.
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "page.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/gcode_writer.hpp"  // base64, shared with G-code thumbnails

namespace trellis::view_page {

namespace {

// The float attributes of a path, in order (viewer/src/data.js ATTRS): mixture[0] (-1 none),
// mixture[1] (-1 unless 3+ materials), temperature, speed, width, power, mixture[2] (-1 none),
// then the commanded mixture[0], [1], [2] the same way (machine/mixing_lag.hpp; the path's own
// when the scene keeps none).
constexpr std::size_t kAttributes = 10;

double attribute(const Path& p, const std::vector<double>& commanded, std::size_t k) {
  auto mix = [](const std::vector<double>& m, std::size_t i) {
    return i == 0 ? (m.empty() ? -1 : m[0]) : m.size() > 2 ? m[i] : -1;
  };
  switch (k) {
    case 0:
      return mix(p.mixture, 0);
    case 1:
      return mix(p.mixture, 1);
    case 2:
      return p.temperature;
    case 3:
      return p.speed;
    case 4:
      return p.width;
    case 5:
      return p.power;
    case 6:
      return mix(p.mixture, 2);
    default:
      return mix(commanded, k - 7);
  }
}

// The role byte: the PathRole, plus 0x80 when the path continues the run of the one printed
// before it (continues_run: a piece cut where the mixture, role or tool changes with no travel
// between), not a path of its own in the counts: a path is a run of extrusion between travels,
// as `trellis analyze` says.
char role_byte(const Path* prev, const Path& p) {
  return static_cast<char>(static_cast<std::uint8_t>(p.role) | (continues_run(prev, p) ? 0x80 : 0));
}

// The role bytes of a layer; `prev`: the last path with points printed before it (null: none).
// A laser build file's vectors are paths each (`trellis analyze` counts vectors).
void put_roles(std::string& b, const ViewScene& s, const Layer& layer, const Path* prev) {
  const bool runs = s.kind != "cli";
  for (const auto& p : layer.paths) {
    b += role_byte(runs ? prev : nullptr, p);
    if (!p.points.empty()) prev = &p;
  }
}

// The last path with points before layer `i` of `t`, or null.
const Path* last_before(const Toolpath& t, std::size_t i) {
  for (std::size_t l = i; l-- > 0;)
    for (auto p = t.layers[l].paths.rbegin(); p != t.layers[l].paths.rend(); ++p)
      if (!p->points.empty()) return &*p;
  return nullptr;
}

// Path `k` (print order) of scene `s`: its commanded mixture.
const std::vector<double>& commanded_of(const ViewScene& s, const Path& p, std::size_t k) {
  return k < s.commanded.size() ? s.commanded[k] : p.mixture;
}

void put_u32(std::string& b, std::uint32_t v) {
  char c[4];
  std::memcpy(c, &v, 4);
  b.append(c, 4);
}
void put_f32(std::string& b, double v) {
  const float f = static_cast<float>(v);
  char c[4];
  std::memcpy(c, &f, 4);
  b.append(c, 4);
}

// The tool byte of each path of `layer`, then its laser parameter set byte: the set's index in
// Toolpath::parameter_sets plus 1, 0 for a path of no set (parameter_set_of).
void put_tools_and_sets(std::string& b, const Toolpath& t, const Layer& layer) {
  for (const auto& p : layer.paths) b += static_cast<char>(std::clamp(p.tool, 0, 255));
  for (const auto& p : layer.paths)
    b += static_cast<char>(
        t.parameter_sets.empty() ? 0 : std::clamp(parameter_set_of(t, p) + 1, 0, 255));
}

// One layer as bytes (little-endian, 4-byte aligned sections):
//   u32 points, u32 paths; f32 xyz[points]; u32 first_point[paths];
//   f32 attributes[paths][kAttributes] (attribute()); u8 role[paths] (role_byte());
//   u8 tool[paths]; u8 set[paths] (put_tools_and_sets);
//   padding to 4 bytes; u32 vias, and when vias > 0: u32 first_via[paths + 1], f32 xyz[vias]
//   (the corners of the travel into each path, Path::via).
std::string encode_layer(const ViewScene& s, std::size_t index, std::size_t first_path) {
  const Layer& layer = s.toolpath.layers[index];
  std::size_t points = 0;
  for (const auto& p : layer.paths) points += p.points.size();
  std::string b;
  b.reserve(8 + points * 12 + layer.paths.size() * 34);
  put_u32(b, static_cast<std::uint32_t>(points));
  put_u32(b, static_cast<std::uint32_t>(layer.paths.size()));
  for (const auto& p : layer.paths)
    for (const auto& q : p.points) put_f32(b, q.x), put_f32(b, q.y), put_f32(b, q.z);
  std::uint32_t first = 0;
  for (const auto& p : layer.paths) {
    put_u32(b, first);
    first += static_cast<std::uint32_t>(p.points.size());
  }
  for (std::size_t q = 0; q < layer.paths.size(); ++q) {
    const Path& p = layer.paths[q];
    for (std::size_t k = 0; k < kAttributes; ++k)
      put_f32(b, attribute(p, commanded_of(s, p, first_path + q), k));
  }
  put_roles(b, s, layer, last_before(s.toolpath, index));
  put_tools_and_sets(b, s.toolpath, layer);
  while (b.size() % 4) b += '\0';
  std::size_t vias = 0;
  for (const auto& p : layer.paths) vias += p.via.size();
  put_u32(b, static_cast<std::uint32_t>(vias));
  if (vias > 0) {
    std::uint32_t at = 0;
    for (const auto& p : layer.paths) {
      put_u32(b, at);
      at += static_cast<std::uint32_t>(p.via.size());
    }
    put_u32(b, at);
    for (const auto& p : layer.paths)
      for (const auto& q : p.via) put_f32(b, q.x), put_f32(b, q.y), put_f32(b, q.z);
  }
  return b;
}

std::string encode_design(const ViewScene& s) {
  std::string b;
  put_u32(b, static_cast<std::uint32_t>(s.design.size()));
  for (const auto& [a, c] : s.design)
    put_f32(b, a.x), put_f32(b, a.y), put_f32(b, a.z), put_f32(b, c.x), put_f32(b, c.y),
        put_f32(b, c.z);
  for (std::size_t i = 0; i < s.design.size(); ++i)
    b += i < s.design_flag.size() ? s.design_flag[i] : '\0';
  while (b.size() % 4) b += '\0';
  return b;
}

// Per-scene extras: u32 points, f32 deviation[points] (empty: points = 0); u32 hits, then per
// hit i32 path, i32 segment, f32 xyz.
std::string encode_extras(const ViewScene& s) {
  std::string b;
  put_u32(b, static_cast<std::uint32_t>(s.deviation.size()));
  for (float d : s.deviation) put_f32(b, d);
  put_u32(b, static_cast<std::uint32_t>(s.hits.size()));
  for (const auto& h : s.hits) {
    put_u32(b, static_cast<std::uint32_t>(static_cast<std::int32_t>(h.path)));
    put_u32(b, static_cast<std::uint32_t>(static_cast<std::int32_t>(h.segment)));
    put_f32(b, h.point.x), put_f32(b, h.point.y), put_f32(b, h.point.z);
  }
  return b;
}

void put_varint(std::string& b, std::uint64_t v) {
  while (v >= 0x80) {
    b += static_cast<char>((v & 0x7f) | 0x80);
    v >>= 7;
  }
  b += static_cast<char>(v);
}
void put_zigzag(std::string& b, std::int64_t v) {
  put_varint(b, v < 0 ? (static_cast<std::uint64_t>(-(v + 1)) << 1) | 1
                      : static_cast<std::uint64_t>(v) << 1);
}

// Steps of `quantum` mm, each coordinate written as its difference from the previous point's.
class StepWriter {
 public:
  StepWriter(std::string& out, double quantum) : out_(out), quantum_(quantum) {}
  void put(const Vec3& p) {
    for (int k = 0; k < 3; ++k) {
      const double v = k == 0 ? p.x : k == 1 ? p.y : p.z;
      const auto q = static_cast<std::int64_t>(std::llround(v / quantum_));
      put_zigzag(out_, q - last_[k]);
      last_[k] = q;
    }
  }

 private:
  std::string& out_;
  double quantum_;
  std::int64_t last_[3] = {0, 0, 0};
};

// 1 µm, or coarser when the largest coordinate would not fit in 30 bits of steps.
double pack_quantum(const Toolpath& t) {
  double most = 0;
  auto see = [&](const Vec3& p, const char* what) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw GeometryError(std::string("viewer: a toolpath ") + what + " is not finite");
    most = std::max({most, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  };
  for (const auto& l : t.layers)
    for (const auto& p : l.paths) {
      for (const auto& q : p.points) see(q, "point");
      for (const auto& q : p.via) see(q, "travel corner");
    }
  return std::max(1e-3, most / double(1 << 30));
}

std::string deflate(const std::string& in) {
  uLongf size = compressBound(static_cast<uLong>(in.size()));
  std::string out(size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(out.data()), &size,
                reinterpret_cast<const Bytef*>(in.data()), static_cast<uLong>(in.size()),
                Z_BEST_COMPRESSION) != Z_OK)
    throw Error("viewer: deflating the scene data failed");
  out.resize(size);
  return out;
}

void append_scene(std::string& html, const ViewScene& s, std::size_t index, LayerData layers) {
  nlohmann::json meta;
  meta["name"] = s.name;
  meta["kind"] = s.kind;
  meta["source"] = s.toolpath.source;
  std::vector<std::string> roles;
  for (std::size_t r = 0; r < kPathRoleCount; ++r)
    roles.emplace_back(to_string(static_cast<PathRole>(r)));
  meta["roles"] = roles;
  meta["layer_z"] = nlohmann::json::array();
  for (const auto& l : s.toolpath.layers) meta["layer_z"].push_back(l.z);
  meta["print_time_s"] = s.print_time_s;
  meta["filament_mm"] = s.filament_mm;
  meta["warnings"] = s.warnings;
  meta["design_lines"] = s.design.size();
  std::size_t materials = 0;
  for (const auto& l : s.toolpath.layers)
    for (const auto& p : l.paths) materials = std::max(materials, p.mixture.size());
  meta["materials"] = materials;
  meta["mixture_read_back"] = s.mixture_read_back;
  meta["mixture_lookahead_mm"] = s.mixture_lookahead;
  meta["checked"] = s.checked;
  meta["collisions"] = s.collisions;
  meta["extra_stats"] = s.extra_stats;
  meta["parameter_sets"] = nlohmann::json::array();
  for (const auto& set : s.toolpath.parameter_sets) meta["parameter_sets"].push_back(set.name);
  if (!s.bed.shape.empty())
    meta["bed"] = {{"shape", s.bed.shape}, {"x", s.bed.x},           {"y", s.bed.y},
                   {"z", s.bed.z},         {"center", s.bed.center}, {"machine", s.bed.machine}};
  const std::string id = "tv-" + std::to_string(index);
  html += "<script type=\"application/json\" id=\"" + id + "-meta\">" + script_json(meta) +
          "</script>\n";
  if (layers == LayerData::Packed)
    html += "<script type=\"application/octet-stream\" id=\"" + id + "-pack\">" +
            base64(deflate(pack_layers(s))) + "</script>\n";
  else
    for (std::size_t i = 0, first = 0; i < s.toolpath.layers.size(); ++i) {
      html += "<script type=\"application/octet-stream\" id=\"" + id + "-l" + std::to_string(i) +
              "\">" + base64(encode_layer(s, i, first)) + "</script>\n";
      first += s.toolpath.layers[i].paths.size();
    }
  if (!s.design.empty())
    html += "<script type=\"application/octet-stream\" id=\"" + id + "-design\">" +
            base64(encode_design(s)) + "</script>\n";
  if (!s.deviation.empty() || !s.hits.empty())
    html += "<script type=\"application/octet-stream\" id=\"" + id + "-extras\">" +
            base64(encode_extras(s)) + "</script>\n";
}

}  // namespace

// Packed layers (before deflating):
//   "TVP1"; f64 quantum (mm per step); varint layers; then per layer:
//   varint points, varint paths, varint vias; varint points_of_path[paths];
//   zigzag varint dx, dy, dz [points] (steps from the previous point, through all layers, from 0);
//   f32 attribute columns: attribute 0 of every path, then attribute 1, ... (as in
//   encode_layer); u8 role[paths]; u8 tool[paths]; u8 set[paths];
//   when vias > 0: varint vias_of_path[paths], zigzag varint dx, dy, dz [vias] (steps from the
//   previous travel corner, through all layers, from 0).
std::string pack_layers(const ViewScene& s) {
  const Toolpath& t = s.toolpath;
  std::size_t first_path = 0;
  const double quantum = pack_quantum(t);
  std::string b = "TVP1";
  char q[8];
  std::memcpy(q, &quantum, 8);
  b.append(q, 8);
  put_varint(b, t.layers.size());
  StepWriter points(b, quantum), vias(b, quantum);
  const Path* last = nullptr;  // the last path with points so far
  for (const auto& layer : t.layers) {
    std::size_t np = 0, nv = 0;
    for (const auto& p : layer.paths) np += p.points.size(), nv += p.via.size();
    put_varint(b, np);
    put_varint(b, layer.paths.size());
    put_varint(b, nv);
    for (const auto& p : layer.paths) put_varint(b, p.points.size());
    for (const auto& p : layer.paths)
      for (const auto& v : p.points) points.put(v);
    for (std::size_t k = 0; k < kAttributes; ++k)
      for (std::size_t q = 0; q < layer.paths.size(); ++q) {
        const Path& p = layer.paths[q];
        put_f32(b, attribute(p, commanded_of(s, p, first_path + q), k));
      }
    first_path += layer.paths.size();
    put_roles(b, s, layer, last);
    for (const auto& p : layer.paths)
      if (!p.points.empty()) last = &p;
    put_tools_and_sets(b, t, layer);
    if (nv > 0) {
      for (const auto& p : layer.paths) put_varint(b, p.via.size());
      for (const auto& p : layer.paths)
        for (const auto& v : p.via) vias.put(v);
    }
  }
  return b;
}

std::string data_blocks(const std::vector<ViewScene>& scenes, const std::string& title,
                        LayerData layers) {
  std::string data = "<script type=\"application/json\" id=\"tv-index\">" +
                     script_json(nlohmann::json{{"title", title}, {"scenes", scenes.size()}}) +
                     "</script>\n";
  for (std::size_t i = 0; i < scenes.size(); ++i) append_scene(data, scenes[i], i, layers);
  return data;
}

// JSON as text safe inside <script>: `<`, `>` and `&` occur in JSON only inside strings, where
// \u003c, \u003e and \u0026 mean the same characters, so no content (`</script>`, `<!--`,
// `<script`) can change how the page parses. Invalid UTF-8 (a G-code comment echoed in a warning)
// becomes U+FFFD instead of failing the page.
std::string script_json(const nlohmann::json& value) {
  const std::string text = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    if (c == '<')
      out += "\\u003c";
    else if (c == '>')
      out += "\\u003e";
    else if (c == '&')
      out += "\\u0026";
    else
      out += c;
  }
  return out;
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

}  // namespace trellis::view_page
