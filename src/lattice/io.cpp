#include "trellis/lattice/io.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "../core/json_document.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/text.hpp"

namespace trellis {

using nlohmann::json;

namespace {

// Splits on commas (or, if there is no comma, on whitespace).
std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> out;
  const bool commas = line.find(',') != std::string_view::npos;
  std::size_t start = 0;
  if (commas) {
    while (true) {
      const auto pos = line.find(',', start);
      out.push_back(
          trim(line.substr(start, pos == std::string_view::npos ? line.npos : pos - start)));
      if (pos == std::string_view::npos) break;
      start = pos + 1;
    }
  } else {
    while (start < line.size()) {
      while (start < line.size() && (line[start] == ' ' || line[start] == '\t')) ++start;
      std::size_t end = start;
      while (end < line.size() && line[end] != ' ' && line[end] != '\t') ++end;
      if (end > start) out.push_back(line.substr(start, end - start));
      start = end;
    }
  }
  return out;
}

bool parse_double(std::string_view s, double& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && p == s.data() + s.size() && std::isfinite(v);
}

bool parse_long(std::string_view s, long& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && p == s.data() + s.size();
}

bool is_name(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!(std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == ' ' ||
          std::isdigit(static_cast<unsigned char>(c)) || c == '"'))
      return false;
  return std::isalpha(static_cast<unsigned char>(s.front())) || s.front() == '"';
}

// Calls fn(line_number, fields) for each non-empty, non-comment line; skips one header line of
// names at the top.
template <class Fn>
void for_each_record(const std::string& text, Fn fn) {
  std::size_t pos = 0;
  long line_no = 0;
  bool first = true;
  while (pos <= text.size()) {
    auto end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    ++line_no;
    const std::string_view line = trim(std::string_view(text).substr(pos, end - pos));
    pos = end + 1;
    if (line.empty() || line.front() == '#') {
      if (end == text.size()) break;
      continue;
    }
    const auto fields = split_fields(line);
    if (first && std::all_of(fields.begin(), fields.end(), is_name)) {
      first = false;
      continue;
    }
    first = false;
    fn(line_no, fields);
    if (end == text.size()) break;
  }
}

double field_double(std::string_view f, const std::string& origin, long line, int column) {
  double v;
  if (!parse_double(f, v))
    throw ParseError("column " + std::to_string(column) + ": '" + std::string(f.substr(0, 40)) +
                         "' is not a finite number",
                     {origin, line});
  if (std::abs(v) > kMaxCoordinate)
    throw ParseError("column " + std::to_string(column) + ": coordinate beyond ±1e6 mm",
                     {origin, line});
  return v;
}

NodeId node_index(long v, std::size_t count, const std::string& origin, long line,
                  const std::string& element) {
  if (v < 0 || static_cast<std::size_t>(v) >= count)
    throw ParseError("node index " + std::to_string(v) + " out of range (" +
                         (count ? "0.." + std::to_string(count - 1) : std::string("no nodes")) +
                         ")",
                     {origin, line, element});
  return static_cast<NodeId>(v);
}

int field_material(std::string_view f, const std::string& origin, long line, int column) {
  long v;
  if (!parse_long(f, v) || v < 0 || v > 255)
    throw ParseError("column " + std::to_string(column) + ": material '" +
                         std::string(f.substr(0, 40)) + "' is not an integer 0..255",
                     {origin, line});
  return static_cast<int>(v);
}

void require_edges(const LatticeInput& in, const std::string& origin) {
  if (in.graph.edges.empty()) throw ParseError("no edges found", {origin});
}

}  // namespace

LatticeInput parse_segments_csv(const std::string& text, const std::string& origin) {
  LatticeInput in;
  bool header_material = false;  // a header line whose last name is "material"
  {
    std::size_t pos = 0;
    while (pos < text.size()) {
      auto end = text.find('\n', pos);
      if (end == std::string::npos) end = text.size();
      const std::string_view line = trim(std::string_view(text).substr(pos, end - pos));
      pos = end + 1;
      if (line.empty() || line.front() == '#') continue;
      const auto f = split_fields(line);
      header_material = std::all_of(f.begin(), f.end(), is_name) && !f.empty() &&
                        (f.back() == "material" || f.back() == "\"material\"");
      break;
    }
  }
  std::size_t columns = 0;  // of the first row: every row has as many
  for_each_record(text, [&](long line, const std::vector<std::string_view>& f) {
    if (columns == 0) columns = f.size();
    if (f.size() != columns)
      throw ParseError("expected " + std::to_string(columns) + " fields like the first row, got " +
                           std::to_string(f.size()) + " field(s)",
                       {origin, line});
    // 3D + material has 7 fields; 2D + material (5) only under a header naming the column,
    // so that a 3D line missing a number stays an error.
    const bool with_material = f.size() == 7 || (f.size() == 5 && header_material);
    if (f.size() != 6 && f.size() != 4 && !with_material)
      throw ParseError(
          "expected x1,y1,z1,x2,y2,z2[,material] (or x1,y1,x2,y2 for 2D, with a "
          "header x1,y1,x2,y2,material for a material column), got " +
              std::to_string(f.size()) + " field(s)",
          {origin, line});
    const bool three_d = f.size() >= 6;
    const std::size_t coords = three_d ? 6 : 4;
    double v[6];
    for (std::size_t i = 0; i < coords; ++i) v[i] = field_double(f[i], origin, line, i + 1);
    const int material =
        with_material ? field_material(f[coords], origin, line, static_cast<int>(coords) + 1) : 0;
    const Vec3 p = three_d ? Vec3{v[0], v[1], v[2]} : Vec3{v[0], v[1], 0};
    const Vec3 q = three_d ? Vec3{v[3], v[4], v[5]} : Vec3{v[2], v[3], 0};
    const auto n = static_cast<NodeId>(in.graph.nodes.size());
    in.graph.nodes.push_back(p);
    in.graph.nodes.push_back(q);
    in.graph.edges.push_back({n, n + 1, material});
    in.edge_where.push_back(origin + ":" + std::to_string(line));
  });
  require_edges(in, origin);
  return in;
}

LatticeInput parse_aero_pair(const std::string& vtext, const std::string& vorigin,
                             const std::string& etext, const std::string& eorigin) {
  LatticeInput in;
  std::size_t columns = 0;  // of the first row: every row has as many (no short row read as z = 0)
  for_each_record(vtext, [&](long line, const std::vector<std::string_view>& f) {
    if (f.size() != 3 && f.size() != 2)
      throw ParseError("expected x,y,z, got " + std::to_string(f.size()) + " field(s)",
                       {vorigin, line});
    if (columns == 0) columns = f.size();
    if (f.size() != columns)
      throw ParseError("expected " + std::to_string(columns) + " fields like the first row, got " +
                           std::to_string(f.size()) + " field(s)",
                       {vorigin, line});
    const double x = field_double(f[0], vorigin, line, 1), y = field_double(f[1], vorigin, line, 2);
    const double z = f.size() == 3 ? field_double(f[2], vorigin, line, 3) : 0.0;
    in.graph.nodes.push_back({x, y, z});
  });
  if (in.graph.nodes.empty()) throw ParseError("no vertices found", {vorigin});
  for_each_record(etext, [&](long line, const std::vector<std::string_view>& f) {
    if (f.size() != 2 && f.size() != 3)
      throw ParseError("expected i,j[,material], got " + std::to_string(f.size()) + " field(s)",
                       {eorigin, line});
    long v[2];
    for (int i = 0; i < 2; ++i)
      if (!parse_long(f[i], v[i]))
        throw ParseError("column " + std::to_string(i + 1) + ": '" +
                             std::string(f[i].substr(0, 40)) + "' is not an integer node index",
                         {eorigin, line});
    const auto n = in.graph.nodes.size();
    in.graph.edges.push_back({node_index(v[0], n, eorigin, line, ""),
                              node_index(v[1], n, eorigin, line, ""),
                              f.size() == 3 ? field_material(f[2], eorigin, line, 3) : 0});
    in.edge_where.push_back(eorigin + ":" + std::to_string(line));
  });
  require_edges(in, eorigin);
  return in;
}

LatticeInput parse_obj_lines(const std::string& text, const std::string& origin) {
  LatticeInput in;
  struct LineRecord {
    long line;
    std::vector<long> idx;
    int material;
  };
  std::vector<LineRecord> lines;
  // `usemtl NAME` sets the material of the lines after it: NAME an integer 0..255 is that
  // material, any other name the next free number in order of appearance.
  std::vector<std::string> names;
  int material = 0;
  std::size_t pos = 0;
  long line_no = 0;
  while (pos < text.size()) {
    auto end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    ++line_no;
    const std::string_view line = trim(std::string_view(text).substr(pos, end - pos));
    pos = end + 1;
    if (line.size() < 2 || line.front() == '#') continue;
    const auto f = split_fields(line);
    if (f.empty()) continue;
    if (f[0] == "usemtl") {
      if (f.size() != 2) throw ParseError("'usemtl' needs one name", {origin, line_no});
      long v;
      if (parse_long(f[1], v)) {
        material = field_material(f[1], origin, line_no, 2);
      } else {
        auto it = std::find(names.begin(), names.end(), std::string(f[1]));
        if (it == names.end()) it = names.insert(names.end(), std::string(f[1]));
        material = static_cast<int>(it - names.begin());
        if (material > 255) throw ParseError("more than 256 materials", {origin, line_no});
      }
    } else if (f[0] == "v") {
      if (f.size() < 4 || f.size() > 5) throw ParseError("'v' needs x y z", {origin, line_no});
      in.graph.nodes.push_back({field_double(f[1], origin, line_no, 2),
                                field_double(f[2], origin, line_no, 3),
                                field_double(f[3], origin, line_no, 4)});
    } else if (f[0] == "l") {
      if (f.size() < 3)
        throw ParseError("'l' needs at least two vertex indices", {origin, line_no});
      std::vector<long> idx;
      for (std::size_t i = 1; i < f.size(); ++i) {
        long v;
        const auto slash = f[i].find('/');
        if (!parse_long(f[i].substr(0, slash), v) || v == 0)
          throw ParseError("'" + std::string(f[i].substr(0, 40)) + "' is not a vertex index",
                           {origin, line_no});
        // Negative indices are relative to the vertices read so far.
        if (v < 0) v = static_cast<long>(in.graph.nodes.size()) + v + 1;
        idx.push_back(v - 1);
      }
      lines.push_back({line_no, std::move(idx), material});
    }
  }
  for (const auto& [line, idx, mat] : lines)
    for (std::size_t i = 1; i < idx.size(); ++i) {
      const auto n = in.graph.nodes.size();
      in.graph.edges.push_back({node_index(idx[i - 1], n, origin, line, ""),
                                node_index(idx[i], n, origin, line, ""), mat});
      in.edge_where.push_back(origin + ":" + std::to_string(line));
    }
  require_edges(in, origin);
  return in;
}

static LatticeInput lattice_from_document(const json& doc, const std::string& origin) {
  if (!doc.is_object())
    throw ParseError("expected a JSON object with 'nodes' and 'edges'", {origin});
  for (auto it = doc.begin(); it != doc.end(); ++it)
    if (it.key() != "nodes" && it.key() != "edges" && it.key() != "material" &&
        it.key() != "directed" && it.key() != "name" && it.key() != "units" && it.key() != "meta" &&
        it.key() != "job" && it.key() != "generator")
      throw ParseError(
          "unknown key '" + it.key() +
              "' (expected nodes, edges, material, directed, name, units, meta, job, generator)",
          {origin});
  if (auto u = doc.find("units"); u != doc.end() && *u != "mm")
    throw ParseError("only \"units\": \"mm\" is supported", {origin, 0, "units"});
  const auto nodes = doc.find("nodes");
  const auto edges = doc.find("edges");
  if (nodes == doc.end() || !nodes->is_array()) throw ParseError("missing 'nodes' array", {origin});
  if (edges == doc.end() || !edges->is_array()) throw ParseError("missing 'edges' array", {origin});
  LatticeInput in;
  auto num = [&](const json& v, const std::string& el) {
    if (!v.is_number()) throw ParseError("expected a number", {origin, 0, el});
    const double d = v.get<double>();
    if (!std::isfinite(d) || std::abs(d) > kMaxCoordinate)
      throw ParseError("coordinate is not finite or beyond ±1e6 mm", {origin, 0, el});
    return d;
  };
  for (std::size_t i = 0; i < nodes->size(); ++i) {
    const std::string el = "nodes[" + std::to_string(i) + "]";
    const json& p = (*nodes)[i];
    if (!p.is_array() || (p.size() != 3 && p.size() != 2))
      throw ParseError("expected [x, y, z] or [x, y]", {origin, 0, el});
    if (p.size() != (*nodes)[0].size())
      throw ParseError("has " + std::to_string(p.size()) + " coordinates, nodes[0] has " +
                           std::to_string((*nodes)[0].size()) + ": every node has as many",
                       {origin, 0, el});
    in.graph.nodes.push_back({num(p[0], el), num(p[1], el), p.size() == 3 ? num(p[2], el) : 0.0});
  }
  auto index = [&](const json& v, const std::string& el) {
    if (!v.is_number_integer()) throw ParseError("expected an integer node index", {origin, 0, el});
    return node_index(v.get<long>(), in.graph.nodes.size(), origin, 0, el);
  };
  for (std::size_t i = 0; i < edges->size(); ++i) {
    const std::string el = "edges[" + std::to_string(i) + "]";
    const json& e = (*edges)[i];
    Edge edge;
    const json* ends = &e;
    if (e.is_object()) {
      auto it = e.find("ends");
      if (it == e.end()) throw ParseError("edge object needs \"ends\": [i, j]", {origin, 0, el});
      ends = &*it;
      if (auto m = e.find("material"); m != e.end()) {
        if (!m->is_number_integer() || m->get<long>() < 0 || m->get<long>() > 255)
          throw ParseError("material must be an integer 0..255", {origin, 0, el + ".material"});
        edge.material = m->get<int>();
      }
      if (auto r = e.find("radius"); r != e.end()) {
        if (!r->is_number() || !(r->get<double>() > 0) || !std::isfinite(r->get<double>()))
          throw ParseError("radius must be a positive number (mm)", {origin, 0, el + ".radius"});
        edge.radius = r->get<double>();
      }
      if (auto d = e.find("directed"); d != e.end()) {
        if (!d->is_boolean()) throw ParseError("directed must be true or false", {origin, 0, el});
        edge.directed = d->get<bool>();
      }
    }
    if (!ends->is_array() || ends->size() != 2)
      throw ParseError("expected [i, j]", {origin, 0, el});
    edge.a = index((*ends)[0], el);
    edge.b = index((*ends)[1], el);
    in.graph.edges.push_back(edge);
    in.edge_where.push_back(origin + ": " + el);
  }
  auto per_edge = [&](const char* key, auto apply) {
    auto it = doc.find(key);
    if (it == doc.end()) return;
    if (!it->is_array() || it->size() != in.graph.edges.size())
      throw ParseError(std::string("'") + key + "' must be an array with one value per edge",
                       {origin, 0, key});
    for (std::size_t i = 0; i < it->size(); ++i)
      apply(in.graph.edges[i], (*it)[i], std::string(key) + "[" + std::to_string(i) + "]");
  };
  per_edge("material", [&](Edge& e, const json& v, const std::string& el) {
    if (!v.is_number_integer() || v.get<long>() < 0 || v.get<long>() > 255)
      throw ParseError("material must be an integer 0..255", {origin, 0, el});
    e.material = v.get<int>();
  });
  per_edge("directed", [&](Edge& e, const json& v, const std::string& el) {
    if (!v.is_boolean()) throw ParseError("directed must be true or false", {origin, 0, el});
    e.directed = v.get<bool>();
  });
  require_edges(in, origin);
  return in;
}

LatticeInput parse_lattice_json(const std::string& text, const std::string& origin) {
  return read_json_document(text, origin,
                            [&](const json& doc) { return lattice_from_document(doc, origin); });
}

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

Graph read_lattice(const std::string& path, const CleanOptions& options, Diagnostics& diag) {
  const std::string name = lower(path);
  LatticeInput in;
  if (ends_with(name, ".json")) {
    in = parse_lattice_json(read_file(path), path);
  } else if (ends_with(name, "_vertices.csv") || ends_with(name, "_edges.csv")) {
    const bool is_v = ends_with(name, "_vertices.csv");
    const std::string stem = path.substr(0, path.size() - (is_v ? 13 : 10));
    const std::string vpath = is_v ? path : stem + "_vertices.csv";
    const std::string epath = is_v ? stem + "_edges.csv" : path;
    if (!std::filesystem::exists(is_v ? epath : vpath))
      throw IoError("the other file of the AERO pair is missing: " + (is_v ? epath : vpath),
                    {path});
    in = parse_aero_pair(read_file(vpath), vpath, read_file(epath), epath);
  } else if (ends_with(name, ".csv") || ends_with(name, ".txt")) {
    in = parse_segments_csv(read_file(path), path);
    if (!options.merge_nodes) {  // no node ids: ends at the same point (1 pm) are one node
      CleanOptions o = options;
      o.merge_nodes = true;
      o.merge_tolerance = 1e-9;
      Graph g = clean_graph(in.graph, o, diag, in.edge_where);
      if (g.edges.empty()) throw GeometryError("no edges left after cleaning", {path});
      return g;
    }
  } else if (ends_with(name, ".obj")) {
    in = parse_obj_lines(read_file(path), path);
  } else if (ends_with(name, ".3mf")) {
    in = read_beam_lattice_3mf(path, diag);
  } else {
    throw ParseError(
        "unknown lattice format (expected .json, .csv, NAME_vertices.csv/"
        "NAME_edges.csv, .obj or .3mf)",
        {path});
  }
  Graph g = clean_graph(in.graph, options, diag, in.edge_where);
  if (g.edges.empty()) throw GeometryError("no edges left after cleaning", {path});
  return g;
}

std::string lattice_to_json(const Graph& g) {
  // Shortest round-trip form of each coordinate, so a written lattice reads back exactly.
  auto num = [](std::string& out, double v) {
    char buf[32];
    auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, p);
  };
  std::string out = "{\"units\": \"mm\",\n \"nodes\": [";
  for (std::size_t i = 0; i < g.nodes.size(); ++i) {
    out += i ? ",\n  [" : "\n  [";
    num(out, g.nodes[i].x);
    out += ", ";
    num(out, g.nodes[i].y);
    out += ", ";
    num(out, g.nodes[i].z);
    out += "]";
  }
  out += "],\n \"edges\": [";
  bool extra = false;
  for (const auto& e : g.edges) extra |= e.material != 0 || e.directed || e.radius > 0;
  for (std::size_t i = 0; i < g.edges.size(); ++i) {
    const auto& e = g.edges[i];
    out += i ? (extra ? ",\n  " : ", ") : "\n  ";
    if (!extra) {
      out += "[" + std::to_string(e.a) + ", " + std::to_string(e.b) + "]";
      continue;
    }
    out += "{\"ends\": [" + std::to_string(e.a) + ", " + std::to_string(e.b) +
           "], \"material\": " + std::to_string(e.material);
    if (e.directed) out += ", \"directed\": true";
    if (e.radius > 0) {
      out += ", \"radius\": ";
      num(out, e.radius);
    }
    out += "}";
  }
  out += "]}\n";
  return out;
}

void write_lattice(const std::string& path, const Graph& g, double beam_radius) {
  if (ends_with(lower(path), ".3mf")) return write_beam_lattice_3mf(path, g, beam_radius);
  // The other lattice formats are read, not written: a .obj or .csv holding JSON is refused.
  if (!ends_with(lower(path), ".json") && !is_stream_output(path))
    throw SettingError("'" + path +
                           "': a lattice is written as .json (lattice JSON) or .3mf "
                           "(3MF beam lattice)",
                       {"", 0, "lattice"});
  write_file_atomic(path, lattice_to_json(g));
}

}  // namespace trellis
