// Viewer pages: inputs read into scenes, scenes encoded as base64 binary chunks into the page
// template bundled from viewer/ at build time (viewer_template.inc, made by viewer/build.mjs).
#include "trellis/view/view.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis {

namespace {

namespace fs = std::filesystem;

const char kTemplateText[] =
#include "viewer_template.inc"
    ;
const std::string_view kTemplate(kTemplateText, sizeof kTemplateText - 1);
constexpr std::string_view kDataMarker = "<!--TRELLIS_DATA-->";
constexpr std::string_view kPathRoles[] = {"strut",  "contour", "handle", "perimeter",
                                           "infill", "other",   "skin"};

std::string lower_ext(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

// G-code: one pass feeding the IR builder and the counters `trellis analyze` reports.
ViewScene load_gcode(const std::string& path, const GcodeReadOptions& read, Diagnostics& diag) {
  ViewScene s;
  CountingSink counter;
  auto builder = make_toolpath_builder(s.toolpath);
  TeeSink both(counter, *builder);  // the builder also gets ;WIDTH:/;HEIGHT:
  Diagnostics local;
  scan_gcode_file(path, both, read, local);
  counter.finish();
  s.print_time_s = counter.counts.print_time_s;
  s.filament_mm = counter.counts.filament;
  for (const auto& m : local.messages()) s.warnings.push_back(m.kind + ": " + m.text);
  diag.merge(local);
  return s;
}

ViewScene load_lattice(const std::string& path, Diagnostics& diag) {
  ViewScene s;
  const Graph g = read_lattice(path, {}, diag);
  for (const auto& e : g.edges) {
    s.design.push_back({g.nodes[e.a], g.nodes[e.b]});
    s.design_flag.push_back(0);
  }
  return s;
}

bool looks_like_toolpath_json(const std::string& path) {
  const std::string head = read_file(path).substr(0, 4096);
  return head.find("\"layers\"") != std::string::npos;
}

// --- encoding -------------------------------------------------------------------------------

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

std::string base64(std::string_view in) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= in.size(); i += 3) {
    const std::uint32_t v =
        (std::uint8_t(in[i]) << 16) | (std::uint8_t(in[i + 1]) << 8) | std::uint8_t(in[i + 2]);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < in.size()) {
    std::uint32_t v = std::uint8_t(in[i]) << 16;
    if (i + 1 < in.size()) v |= std::uint8_t(in[i + 1]) << 8;
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < in.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// One layer as bytes (little-endian, 4-byte aligned sections):
//   u32 points, u32 paths; f32 xyz[points]; u32 first_point[paths];
//   f32 attributes[paths][6] = mixture[0] (-1 none), mixture[1] (-1 none), temperature, speed,
//   width, power; u8 role[paths]; u8 tool[paths]; padding to 4 bytes.
std::string encode_layer(const Layer& layer) {
  std::size_t points = 0;
  for (const auto& p : layer.paths) points += p.points.size();
  std::string b;
  b.reserve(8 + points * 12 + layer.paths.size() * 30);
  put_u32(b, static_cast<std::uint32_t>(points));
  put_u32(b, static_cast<std::uint32_t>(layer.paths.size()));
  for (const auto& p : layer.paths)
    for (const auto& q : p.points) put_f32(b, q.x), put_f32(b, q.y), put_f32(b, q.z);
  std::uint32_t first = 0;
  for (const auto& p : layer.paths) {
    put_u32(b, first);
    first += static_cast<std::uint32_t>(p.points.size());
  }
  for (const auto& p : layer.paths) {
    put_f32(b, p.mixture.size() > 0 ? p.mixture[0] : -1);
    put_f32(b, p.mixture.size() > 2 ? p.mixture[1] : -1);
    put_f32(b, p.temperature);
    put_f32(b, p.speed);
    put_f32(b, p.width);
    put_f32(b, p.power);
  }
  for (const auto& p : layer.paths) b += static_cast<char>(static_cast<std::uint8_t>(p.role));
  for (const auto& p : layer.paths) b += static_cast<char>(std::clamp(p.tool, 0, 255));
  while (b.size() % 4) b += '\0';
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

// JSON text safe inside <script>: no "</" sequence.
std::string script_safe(std::string text) {
  for (std::size_t at = 0; (at = text.find("</", at)) != std::string::npos; at += 3)
    text.replace(at, 2, "<\\/");
  return text;
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

void append_scene(std::string& html, const ViewScene& s, std::size_t index) {
  nlohmann::json meta;
  meta["name"] = s.name;
  meta["kind"] = s.kind;
  meta["source"] = s.toolpath.source;
  meta["roles"] = std::vector<std::string>(std::begin(kPathRoles), std::end(kPathRoles));
  meta["layer_z"] = nlohmann::json::array();
  for (const auto& l : s.toolpath.layers) meta["layer_z"].push_back(l.z);
  meta["print_time_s"] = s.print_time_s;
  meta["filament_mm"] = s.filament_mm;
  meta["warnings"] = s.warnings;
  meta["design_lines"] = s.design.size();
  const std::string id = "tv-" + std::to_string(index);
  html += "<script type=\"application/json\" id=\"" + id + "-meta\">" + script_safe(meta.dump()) +
          "</script>\n";
  for (std::size_t i = 0; i < s.toolpath.layers.size(); ++i)
    html += "<script type=\"application/octet-stream\" id=\"" + id + "-l" + std::to_string(i) +
            "\">" + base64(encode_layer(s.toolpath.layers[i])) + "</script>\n";
  if (!s.design.empty())
    html += "<script type=\"application/octet-stream\" id=\"" + id + "-design\">" +
            base64(encode_design(s)) + "</script>\n";
}

}  // namespace

ViewScene load_view_scene(const std::string& path, const ViewLoadOptions& options,
                          Diagnostics& diag) {
  if (!fs::exists(path)) throw IoError(path + ": no such file");
  const std::string ext = lower_ext(path);
  ViewScene s;
  if (ext == ".gcode" || ext == ".g" || ext == ".gco" || ext == ".nc") {
    GcodeReadOptions read;
    if (!options.machine.empty()) {
      const MachineProfile profile = load_profile(options.machine);
      if (profile.parsed_flavor() != Flavor::Marlin) {
        read.valve_on = profile.valve_on;
        read.valve_off = profile.valve_off;
      }
    }
    if (!options.valve_on.empty()) read.valve_on = options.valve_on;
    if (!options.valve_off.empty()) read.valve_off = options.valve_off;
    s = load_gcode(path, read, diag);
    s.kind = ext == ".nc" ? "nc" : "gcode";
  } else if (ext == ".cli") {
    s.toolpath = read_cli_file(path, &diag);
    s.kind = "cli";
  } else if (ext == ".json" && looks_like_toolpath_json(path)) {
    s.toolpath = read_toolpath(path);
    s.kind = "toolpath";
  } else if (ext == ".json" || ext == ".csv" || ext == ".obj" || ext == ".3mf") {
    s = load_lattice(path, diag);
    s.kind = "lattice";
  } else {
    throw ParseError(path + ": cannot view a '" + ext +
                     "' file (G-code .gcode/.g/.nc, laser .cli, toolpath or lattice JSON, "
                     "lattice CSV/OBJ/3MF)");
  }
  s.name = fs::path(path).filename().string();
  return s;
}

ViewScene view_scene(const Toolpath& toolpath, const std::string& name) {
  ViewScene s;
  s.toolpath = toolpath;
  s.name = name;
  s.kind = "toolpath";
  return s;
}

std::string viewer_html(const std::vector<ViewScene>& scenes, const std::string& title) {
  const std::size_t at = kTemplate.find(kDataMarker);
  if (at == std::string_view::npos) throw Error("viewer template has no data marker");
  std::string data =
      "<script type=\"application/json\" id=\"tv-index\">" +
      script_safe(nlohmann::json{{"title", title}, {"scenes", scenes.size()}}.dump()) +
      "</script>\n";
  for (std::size_t i = 0; i < scenes.size(); ++i) append_scene(data, scenes[i], i);
  std::string html;
  html.reserve(kTemplate.size() + data.size() + title.size() + 64);
  std::string head(kTemplate.substr(0, at));
  const auto t = head.find("<title>");
  if (t != std::string::npos) head.insert(t + 7, html_escape(title));
  html += head;
  html += data;
  html += kTemplate.substr(at + kDataMarker.size());
  return html;
}

std::size_t viewer_template_size() {
  return kTemplate.size();
}

}  // namespace trellis
