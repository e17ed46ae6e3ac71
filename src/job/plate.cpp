#include "trellis/job/plate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "routes.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

namespace fs = std::filesystem;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

double cross(Vec2 a, Vec2 b, Vec2 c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

double point_segment(Vec2 p, Vec2 a, Vec2 b) {
  const Vec2 d = b - a;
  const double l2 = d.x * d.x + d.y * d.y;
  double t = l2 > 0 ? ((p.x - a.x) * d.x + (p.y - a.y) * d.y) / l2 : 0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p.x - (a.x + t * d.x), p.y - (a.y + t * d.y));
}

bool segments_cross(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  const double d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  return ((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0));
}

bool inside_convex(Vec2 p, const std::array<Vec2, 4>& q) {
  for (std::size_t i = 0; i < 4; ++i)
    if (cross(q[i], q[(i + 1) % 4], p) < 0) return false;
  return true;
}

// Distance between two convex quadrilaterals (counter-clockwise); 0 when they overlap.
double quad_distance(const std::array<Vec2, 4>& p, const std::array<Vec2, 4>& q) {
  for (const Vec2& v : p)
    if (inside_convex(v, q)) return 0;
  for (const Vec2& v : q)
    if (inside_convex(v, p)) return 0;
  double d = HUGE_VAL;
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t j = 0; j < 4; ++j) {
      const Vec2 a = p[i], b = p[(i + 1) % 4], c = q[j], e = q[(j + 1) % 4];
      if (segments_cross(a, b, c, e)) return 0;
      d = std::min({d, point_segment(a, c, e), point_segment(b, c, e), point_segment(c, a, b),
                    point_segment(e, a, b)});
    }
  return d;
}

template <class T>
void put(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

class Reader {
 public:
  Reader(const std::string& b, const std::string& origin) : b_(b), origin_(origin) {}
  template <class T>
  T get() {
    if (pos_ + sizeof(T) > b_.size())
      throw ParseError(fmt::format("shard file ends early (byte {})", pos_), {origin_});
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::size_t count(std::size_t item_bytes) {
    const auto n = get<std::uint64_t>();
    if (item_bytes && n > (b_.size() - pos_) / item_bytes)
      throw ParseError(
          fmt::format("shard file: a count of {} at byte {} is more than the file holds", n, pos_),
          {origin_});
    return static_cast<std::size_t>(n);
  }
  bool done() const { return pos_ == b_.size(); }

 private:
  const std::string& b_;
  std::string origin_;
  std::size_t pos_ = 0;
};

constexpr char kMagic[8] = {'T', 'R', 'L', 'S',
                            'H', 'R', 'D', '3'};  // 2: flow, fan, joined; 3: via, inside

}  // namespace

std::string shard_name(const std::string& output, int k, int n) {
  return output + fmt::format(".shard-{}-of-{}", k, n);
}

Vec3 place_point(const PlatePart& part, const BBox3& box, Vec3 p) {
  const double cx = 0.5 * (box.min.x + box.max.x), cy = 0.5 * (box.min.y + box.max.y);
  const double c = std::cos(part.rotation * kDeg), s = std::sin(part.rotation * kDeg);
  const double x = p.x - cx, y = p.y - cy;
  return {part.x + c * x - s * y, part.y + s * x + c * y, p.z};
}

Transform3mf place_transform(const PlatePart& part, const BBox3& box, double dz) {
  const double cx = 0.5 * (box.min.x + box.max.x), cy = 0.5 * (box.min.y + box.max.y);
  const double c = std::cos(part.rotation * kDeg), s = std::sin(part.rotation * kDeg);
  return {c, s, 0, -s, c, 0, 0, 0, 1, part.x - c * cx + s * cy, part.y - s * cx - c * cy, dz};
}

PartFootprint place_footprint(const PlatePart& part, const BBox3& box) {
  PartFootprint f;
  f.label = part.label;
  f.line = part.line;
  const Vec3 c[4] = {{box.min.x, box.min.y, 0},
                     {box.max.x, box.min.y, 0},
                     {box.max.x, box.max.y, 0},
                     {box.min.x, box.max.y, 0}};
  for (int i = 0; i < 4; ++i) {
    const Vec3 q = place_point(part, box, c[i]);
    f.corners[static_cast<std::size_t>(i)] = {q.x, q.y};
  }
  return f;
}

void check_plate(const std::vector<PartFootprint>& parts, const BBox2& area, double clearance,
                 const std::string& origin) {
  constexpr double eps = 1e-9;
  for (const auto& p : parts)
    for (const Vec2& v : p.corners)
      if (v.x < area.min.x - eps || v.x > area.max.x + eps || v.y < area.min.y - eps ||
          v.y > area.max.y + eps)
        throw SettingError(
            fmt::format("part '{}' does not fit the build area: its corner ({:.3f}, {:.3f}) is "
                        "outside X {}..{}, Y {}..{} mm; move it (x, y) or turn it (rotation)",
                        p.label, v.x, v.y, area.min.x, area.max.x, area.min.y, area.max.y),
            {origin, p.line, "part.x"});
  for (std::size_t i = 0; i < parts.size(); ++i)
    for (std::size_t j = i + 1; j < parts.size(); ++j) {
      const double d = quad_distance(parts[i].corners, parts[j].corners);
      if (d == 0 || d < clearance - eps)
        throw SettingError(
            fmt::format("parts '{}' (line {}) and '{}' (line {}) {}: {:.3f} mm apart, the "
                        "clearance is {} mm (plate.clearance)",
                        parts[i].label, parts[i].line, parts[j].label, parts[j].line,
                        d == 0 ? "overlap" : "are too close", d, clearance),
            {origin, parts[j].line, "part.x"});
    }
}

void check_sequential(const std::vector<PartFootprint>& parts, const std::vector<double>& heights,
                      double radius, double height, const std::string& origin) {
  constexpr double eps = 1e-9;
  if (!(radius > 0) || !(height > 0))
    throw SettingError(
        "plate.sequence = parts prints each part whole before the next, which "
        "needs the machine's extruder clearance: set machine.extruder_clearance_radius "
        "and machine.extruder_clearance_height in the profile (PrusaSlicer's "
        "extruder_clearance_radius/_height), or print per layer (plate.sequence = layers)",
        {origin, 0, "plate.sequence"});
  for (std::size_t i = 0; i + 1 < parts.size(); ++i)
    if (heights[i] > height + eps)
      throw SettingError(
          fmt::format("part '{}' (line {}) is {:.3f} mm tall, above the gantry's clearance "
                      "machine.extruder_clearance_height = {} mm, but it is not printed last "
                      "('{}' is): the gantry would hit it while the later parts print. Put it "
                      "last in the job file, or print per layer (plate.sequence = layers)",
                      parts[i].label, parts[i].line, heights[i], height, parts.back().label),
          {origin, parts[i].line, "plate.sequence"});
  for (std::size_t i = 0; i < parts.size(); ++i)
    for (std::size_t j = i + 1; j < parts.size(); ++j) {
      const double d = quad_distance(parts[i].corners, parts[j].corners);
      if (d < radius - eps)
        throw SettingError(
            fmt::format("parts '{}' (line {}) and '{}' (line {}) are {:.3f} mm apart: printed "
                        "one after the other (plate.sequence = parts) they must be at least "
                        "machine.extruder_clearance_radius = {} mm apart, or the printhead hits "
                        "the finished one; move them apart or print per layer "
                        "(plate.sequence = layers)",
                        parts[i].label, parts[i].line, parts[j].label, parts[j].line, d, radius),
            {origin, parts[j].line, "part.x"});
    }
}

std::pair<int, int> parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  int k = 0, n = 0;
  try {
    std::size_t u1 = 0, u2 = 0;
    if (slash == std::string::npos) throw std::invalid_argument(text);
    k = std::stoi(text.substr(0, slash), &u1);
    n = std::stoi(text.substr(slash + 1), &u2);
    if (u1 != slash || u2 != text.size() - slash - 1) throw std::invalid_argument(text);
  } catch (const std::logic_error&) {
    throw SettingError("expected K/N (shard K of N, e.g. 2/5), got '" + text + "'",
                       {"", 0, "--shard"});
  }
  if (n < 1 || n > 100000 || k < 1 || k > n)
    throw SettingError(fmt::format("shard {} of {} is out of range: K/N needs 1 <= K <= N", k, n),
                       {"", 0, "--shard"});
  return {k, n};
}

std::pair<std::size_t, std::size_t> shard_range(const std::vector<double>& work, int k, int n) {
  const std::size_t L = work.size();
  std::vector<double> prefix(L + 1, 0.0);
  double total = 0;
  for (double w : work) total += std::max(0.0, w);
  for (std::size_t i = 0; i < L; ++i)
    prefix[i + 1] = prefix[i] + (total > 0 ? std::max(0.0, work[i]) : 1.0);
  const double all = prefix[L];
  // Boundary j: the first layer whose work before it reaches j/n of the total.
  auto boundary = [&](int j) -> std::size_t {
    if (j <= 0) return 0;
    if (j >= n) return L;
    const double target = all * j / n;
    return static_cast<std::size_t>(std::lower_bound(prefix.begin(), prefix.end(), target) -
                                    prefix.begin());
  };
  return {boundary(k - 1), boundary(k)};
}

std::string shard_bytes(const std::vector<Layer>& layers) {
  std::string out(kMagic, sizeof kMagic);
  put<std::uint64_t>(out, layers.size());
  for (const Layer& l : layers) {
    put(out, l.z);
    put<std::uint64_t>(out, l.paths.size());
    for (const Path& p : l.paths) {
      put<std::int32_t>(out, static_cast<std::int32_t>(p.role));
      put<std::int32_t>(out, p.tool);
      put<std::int32_t>(out, p.part);
      put<std::int32_t>(out, p.joined ? 1 : 0);
      put<std::int32_t>(out, p.inside ? 1 : 0);
      for (double v :
           {p.width, p.height, p.speed, p.power, p.filament, p.temperature, p.flow, p.fan})
        put(out, v);
      put<std::uint64_t>(out, p.mixture.size());
      for (double v : p.mixture) put(out, v);
      put<std::uint64_t>(out, p.via.size());
      for (const Vec3& q : p.via) put(out, q.x), put(out, q.y), put(out, q.z);
      put<std::uint64_t>(out, p.points.size());
      for (const Vec3& q : p.points) put(out, q.x), put(out, q.y), put(out, q.z);
    }
  }
  return out;
}

std::vector<Layer> layers_from_shard_bytes(const std::string& bytes, const std::string& origin) {
  if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    throw ParseError("not a Trellis shard file", {origin});
  Reader r(bytes, origin);
  for (std::size_t i = 0; i < sizeof kMagic; ++i) r.get<char>();
  std::vector<Layer> layers(r.count(16));
  for (Layer& l : layers) {
    l.z = r.get<double>();
    l.paths.resize(r.count(20 + 8 * 8 + 24));
    for (Path& p : l.paths) {
      const auto role = r.get<std::int32_t>();
      if (role < 0 || role > static_cast<std::int32_t>(kPathRoleCount) - 1)
        throw ParseError("shard file: unknown path role", {origin});
      p.role = static_cast<PathRole>(role);
      p.tool = r.get<std::int32_t>();
      p.part = r.get<std::int32_t>();
      p.joined = r.get<std::int32_t>() != 0;
      p.inside = r.get<std::int32_t>() != 0;
      for (double* v :
           {&p.width, &p.height, &p.speed, &p.power, &p.filament, &p.temperature, &p.flow, &p.fan})
        *v = r.get<double>();
      p.mixture.resize(r.count(8));
      for (double& v : p.mixture) v = r.get<double>();
      p.via.resize(r.count(24));
      for (Vec3& q : p.via) q.x = r.get<double>(), q.y = r.get<double>(), q.z = r.get<double>();
      p.points.resize(r.count(24));
      for (Vec3& q : p.points) q.x = r.get<double>(), q.y = r.get<double>(), q.z = r.get<double>();
    }
  }
  if (!r.done()) throw ParseError("shard file: bytes after the last layer", {origin});
  return layers;
}

std::string write_shard(const Job& job, const std::vector<Layer>& layers, std::size_t first,
                        std::size_t total, const std::string& source,
                        const std::vector<std::string>& part_labels,
                        const std::string& graded_json) {
  if (job.output.empty())
    throw SettingError("a shard needs the job's main output (its name names the shard files)",
                       {"", 0, "--shard"});
  const std::string data = shard_name(job.output, job.shard, job.shards);
  const std::string manifest = data + ".json";
  const std::string bytes = shard_bytes(layers);
  nlohmann::ordered_json j;
  j["format"] = "trellis.shard";
  j["version"] = graded_json.empty() ? 2 : 3;
  j["route"] = job.route;
  j["output"] = fs::path(job.output).filename().string();
  j["shard"] = job.shard;
  j["shards"] = job.shards;
  j["first_layer"] = first;
  j["layers"] = layers.size();
  j["total_layers"] = total;
  j["data"] = fs::path(data).filename().string();
  j["data_bytes"] = bytes.size();
  j["source"] = source;
  j["part_labels"] = part_labels;
  if (!graded_json.empty()) j["graded"] = nlohmann::ordered_json::parse(graded_json);
  j["job"] = routes::embedded_job(job, manifest);
  write_file_atomic(data, bytes);
  write_file_atomic(manifest, j.dump(2) + "\n");
  return manifest;
}

JobResult merge_shards(const std::vector<std::string>& manifests, const std::string& output,
                       Diagnostics& diag, bool follow_symlinks) {
  if (manifests.empty())
    throw SettingError("merge needs the shards' manifests (.json)", {"", 0, "manifests"});
  if (output.empty()) throw SettingError("merge needs -o OUTPUT", {"", 0, "-o"});
  struct Shard {
    std::string path;
    nlohmann::json j;
  };
  std::map<int, Shard> by_index;
  nlohmann::json first;
  std::string first_path;
  RunFiles files(follow_symlinks);
  files.output("the merged output (-o)", output);
  for (const auto& path : manifests) {
    files.input("the shard manifest", path);
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(read_file(path));
    } catch (const nlohmann::json::exception& e) {
      throw ParseError(std::string("not a shard manifest (JSON): ") + e.what(), {path});
    }
    if (!j.is_object() || j.value("format", "") != "trellis.shard")
      throw ParseError("not a shard manifest (format trellis.shard)", {path});
    for (const char* k : {"route", "output", "source", "job", "data"})
      if (!j.contains(k) || !j[k].is_string())
        throw ParseError(std::string("manifest without '") + k + "'", {path});
    for (const char* k : {"shard", "shards", "first_layer", "layers", "total_layers", "data_bytes"})
      if (!j.contains(k) || !j[k].is_number_unsigned())
        throw ParseError(std::string("manifest without '") + k + "'", {path});
    if (first.is_null()) {
      first = j;
      first_path = path;
    } else {
      // (A graded shard's outline planes are its own.)
      auto common = [](const nlohmann::json& m, const char* k) {
        nlohmann::json v = m.value(k, nlohmann::json());
        if (v.is_object()) v.erase("outline_z");
        return v;
      };
      for (const char* k :
           {"job", "route", "shards", "total_layers", "output", "source", "part_labels", "graded"})
        if (common(j, k) != common(first, k))
          throw SettingError(
              fmt::format("{} is a shard of another job than {} (their '{}' differ): "
                          "merge the shards of one run",
                          path, first_path, k),
              {path, 0, k});
    }
    const int k = j["shard"].get<int>();
    if (k < 1 || k > j["shards"].get<int>())
      throw SettingError(fmt::format("shard {} of {} is out of range", k, j["shards"].get<int>()),
                         {path, 0, "shard"});
    if (by_index.count(k))
      throw SettingError(
          fmt::format("shard {} is given twice: {} and {}", k, by_index[k].path, path),
          {path, 0, "shard"});
    by_index[k] = {path, j};
  }
  const int n = first["shards"].get<int>();
  std::string missing;
  for (int k = 1; k <= n; ++k)
    if (!by_index.count(k)) missing += (missing.empty() ? "" : ", ") + std::to_string(k);
  if (!missing.empty())
    throw SettingError(
        fmt::format("shards {} of {} are missing (give every shard's manifest)", missing, n),
        {first_path, 0, "shards"});
  Toolpath tp;
  std::size_t next = 0;
  std::vector<double> outline_z;  // graded shards of a design with process fields
  for (auto& [k, s] : by_index) {
    if (s.j["first_layer"].get<std::size_t>() != next)
      throw SettingError(fmt::format("shard {} starts at layer {} but the shards before it end at "
                                     "layer {}",
                                     k, s.j["first_layer"].get<std::size_t>(), next),
                         {s.path, 0, "first_layer"});
    const std::string data =
        (fs::path(s.path).parent_path() / s.j["data"].get<std::string>()).string();
    files.input("the shard", data);
    const std::string bytes = read_file(data);
    if (bytes.size() != s.j["data_bytes"].get<std::size_t>())
      throw ParseError(fmt::format("{} bytes, its manifest says {}", bytes.size(),
                                   s.j["data_bytes"].get<std::size_t>()),
                       {data});
    std::vector<Layer> layers = layers_from_shard_bytes(bytes, data);
    if (layers.size() != s.j["layers"].get<std::size_t>())
      throw ParseError("layer count differs from its manifest", {data});
    next += layers.size();
    for (auto& l : layers) tp.layers.push_back(std::move(l));
    if (s.j.contains("graded") && s.j["graded"].is_object() &&
        s.j["graded"].contains("outline_z")) {
      const auto& zs = s.j["graded"]["outline_z"];
      if (!zs.is_array() || zs.size() != layers.size())
        throw ParseError("graded shard manifest: outline_z is not one plane per layer", {s.path});
      for (const auto& z : zs) {
        if (!z.is_number())
          throw ParseError("graded shard manifest: outline_z holds a non-number", {s.path});
        outline_z.push_back(z.get<double>());
      }
    }
  }
  if (next != first["total_layers"].get<std::size_t>())
    throw SettingError(fmt::format("the shards hold {} layers, the job has {}", next,
                                   first["total_layers"].get<std::size_t>()),
                       {first_path, 0, "total_layers"});
  tp.source = first["source"].get<std::string>();
  if (first.contains("part_labels"))
    tp.part_labels = first["part_labels"].get<std::vector<std::string>>();
  const std::string base = fs::path(first_path).parent_path().string();
  Job job = job_from_toml(first["job"].get<std::string>(), first_path + " (job)",
                          base.empty() ? "." : base, true);
  job.output = output;
  files.input("the input of the job", job.input);
  const Config c = job.settings.config();
  JobResult out;
  OutputBatch batch;
  const RouteSpec& route = route_spec(job.route, {first_path, 0, "route"});
  files.check();
  {
    // The merged output is the route's main output (a plan's G-code): named for its format.
    Job named = job;
    named.output.clear();
    named.*route.main_output = output;
    check_output_names(named, c);
  }
  const fs::path dir = fs::path(output).parent_path();
  if (!dir.empty()) create_output_directories(dir.string());
  require_shards(route, {first_path, 0, "route"});
  const ShardLayers layers{first.contains("graded") ? first["graded"].dump() : std::string(),
                           outline_z, next};
  route.merge(job, c, tp, layers, out, diag);
  batch.commit();
  out.summary = fmt::format("{} shards, {} layers", n, next);
  return out;
}

}  // namespace trellis
