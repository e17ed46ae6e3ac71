#include "trellis/machine/cli.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string_view>
#include <vector>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

namespace {

static_assert(std::endian::native == std::endian::little, "binary CLI I/O assumes little endian");

constexpr double kUnits = 0.001;  // mm per CLI unit (1 µm)
constexpr int kContourId = 1, kHatchId = 2;

// Coordinates in µm with two decimals (10 nm), no trailing zeros.
void put(std::string& out, double mm) {
  double v = std::round(mm * 1e5) / 100.0;
  if (v == 0) v = 0;
  out += fmt::format("{}", v);
}

void put_xy(std::string& out, const Vec3& q) {
  out += ',';
  put(out, q.x);
  out += ',';
  put(out, q.y);
}

template <class T>
void put_bin(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

bool is_hatch(const Path& p) {
  return p.role == PathRole::Infill && p.points.size() == 2;
}

std::string header(const Toolpath& tp, const LaserProfile& prof, const CliWriteOptions& o) {
  BBox3 box;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths)
      for (const auto& q : p.points) box.add(q);
  if (box.empty()) box.add({0, 0, 0});
  std::string out = "$$HEADERSTART\n";
  out += o.binary ? "$$BINARY\n" : "$$ASCII\n";
  out += "$$UNITS/0.001\n$$VERSION/200\n";
  out += "$$LABEL/1,contour\n$$LABEL/2,hatch\n";
  out += fmt::format("//machine: {}//\n", prof.name);
  out += fmt::format("//id 1 contour: {} W, {} mm/s; id 2 hatch: {} W, {} mm/s; spot {} mm//\n",
                     prof.contour_power, prof.contour_speed, prof.hatch_power, prof.hatch_speed,
                     prof.spot_diameter);
  if (o.plus) {
    out += fmt::format("// PROFILE_DEF={} NAME=\"contour\" POWER={} SPEED={} //\n", kContourId,
                       prof.contour_power, prof.contour_speed);
    out += fmt::format("// PROFILE_DEF={} NAME=\"hatch\" POWER={} SPEED={} //\n", kHatchId,
                       prof.hatch_power, prof.hatch_speed);
  }
  out += fmt::format("//source: {}//\n", tp.source);
  // The job that made the file, one comment line each, for `trellis rerun`.
  for (std::size_t a = 0; a < tp.job.size();) {
    const std::size_t b = std::min(tp.job.find('\n', a), tp.job.size());
    out += "//job: " + tp.job.substr(a, b - a) + "//\n";
    a = b + 1;
  }
  out += fmt::format("$$DIMENSION/{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n", box.min.x,
                     box.min.y, box.min.z, box.max.x, box.max.y, box.max.z);
  out += fmt::format("$$LAYERS/{}\n$$HEADEREND", tp.layers.size());
  return out;
}

void ascii_geometry(const Toolpath& tp, std::string& out) {
  out += "\n$$GEOMETRYSTART\n";
  for (const auto& layer : tp.layers) {
    out += "$$LAYER/";
    put(out, layer.z);
    out += '\n';
    std::size_t hatches = 0;
    for (const auto& p : layer.paths) {
      if (is_hatch(p)) {
        ++hatches;
        continue;
      }
      out += fmt::format("$$POLYLINE/{},2,{}", kContourId, p.points.size());
      for (const auto& q : p.points) put_xy(out, q);
      out += '\n';
    }
    if (hatches) {
      out += fmt::format("$$HATCHES/{},{}", kHatchId, hatches);
      for (const auto& p : layer.paths)
        if (is_hatch(p))
          for (const auto& q : p.points) put_xy(out, q);
      out += '\n';
    }
  }
  out += "$$GEOMETRYEND\n";
}

void binary_geometry(const Toolpath& tp, std::string& out) {
  auto coord = [&](double mm) { put_bin(out, static_cast<float>(mm / kUnits)); };
  for (const auto& layer : tp.layers) {
    put_bin<std::uint16_t>(out, 127);
    coord(layer.z);
    std::int32_t hatches = 0;
    for (const auto& p : layer.paths) {
      if (is_hatch(p)) {
        ++hatches;
        continue;
      }
      put_bin<std::uint16_t>(out, 130);
      put_bin<std::int32_t>(out, kContourId);
      put_bin<std::int32_t>(out, 2);  // open
      put_bin<std::int32_t>(out, static_cast<std::int32_t>(p.points.size()));
      for (const auto& q : p.points) coord(q.x), coord(q.y);
    }
    if (hatches) {
      put_bin<std::uint16_t>(out, 132);
      put_bin<std::int32_t>(out, kHatchId);
      put_bin<std::int32_t>(out, hatches);
      for (const auto& p : layer.paths)
        if (is_hatch(p))
          for (const auto& q : p.points) coord(q.x), coord(q.y);
    }
  }
}

// What the reader knows of each id: role and CLI+ power/speed.
struct IdInfo {
  std::string label;
  double power = 0, speed = 0;
};

class Reader {
 public:
  Reader(const std::string& bytes, const std::string& origin, Diagnostics* diag)
      : b_(bytes), origin_(origin), diag_(diag) {}

  Toolpath run() {
    const std::size_t start = b_.find("$$HEADERSTART");
    if (start == std::string::npos) fail(0, "not a CLI file: no $$HEADERSTART");
    const std::size_t end = b_.find("$$HEADEREND", start);
    if (end == std::string::npos) fail(start, "the header has no $$HEADEREND");
    read_header(start, end);
    std::size_t pos = end + 11;
    tp_.source = "cli: " + origin_;
    if (binary_)
      read_binary(pos);
    else
      read_ascii(pos);
    return std::move(tp_);
  }

 private:
  [[noreturn]] void fail(std::size_t offset, const std::string& msg) const {
    throw ParseError(msg, Where{origin_, binary_ && offset > header_end_ ? 0 : line_of(offset),
                                fmt::format("offset {}", offset)});
  }
  long line_of(std::size_t offset) const {
    long n = 1;
    for (std::size_t i = 0; i < offset && i < b_.size(); ++i) n += b_[i] == '\n';
    return n;
  }
  void warn(std::size_t offset, const std::string& msg) {
    if (diag_)
      diag_->warn("cli.unknown_command", fmt::format("{}: offset {}: {}", origin_, offset, msg));
  }

  // Numbers after "$$CMD/" up to the end of the line, comma separated.
  std::vector<double> numbers(std::size_t from, std::size_t to) {
    std::vector<double> v;
    std::size_t i = from;
    while (i < to) {
      while (i < to && (b_[i] == ' ' || b_[i] == '\t' || b_[i] == '\r')) ++i;
      std::size_t j = i;
      while (j < to && b_[j] != ',') ++j;
      std::size_t k = j;
      while (k > i && (b_[k - 1] == ' ' || b_[k - 1] == '\t' || b_[k - 1] == '\r')) --k;
      double x = 0;
      const char* first = b_.data() + i;
      if (*first == '+') ++first;
      const auto r = std::from_chars(first, b_.data() + k, x);
      if (i == k || r.ec != std::errc() || r.ptr != b_.data() + k || !std::isfinite(x))
        fail(i, fmt::format("expected a number, got '{}'",
                            b_.substr(i, std::min<std::size_t>(k - i, 20))));
      v.push_back(x);
      i = j + 1;
    }
    return v;
  }

  void read_header(std::size_t start, std::size_t end) {
    header_end_ = end;
    std::size_t i = start;
    while (i < end) {
      std::size_t eol = b_.find('\n', i);
      if (eol == std::string::npos || eol > end) eol = end;
      std::string_view line(b_.data() + i, eol - i);
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
      if (line.starts_with("$$BINARY"))
        binary_ = true;
      else if (line.starts_with("$$ASCII"))
        binary_ = false;
      else if (line.starts_with("$$ALIGN"))
        align_ = true;
      else if (line.starts_with("$$UNITS/")) {
        const auto v = numbers(i + 8, i + line.size());
        if (v.size() != 1 || !(v[0] > 0)) fail(i + 8, "$$UNITS needs one positive number");
        units_ = v[0];
      } else if (line.starts_with("$$LABEL/")) {
        const std::size_t c = line.find(',');
        if (c == std::string_view::npos) fail(i, "$$LABEL needs id,text");
        const auto id = numbers(i + 8, i + c);
        if (id.size() != 1 || !(std::abs(id[0]) <= 1e9)) fail(i + 8, "$$LABEL needs one id number");
        ids_[static_cast<int>(id[0])].label = std::string(line.substr(c + 1));
      } else if (line.find("PROFILE_DEF=") != std::string_view::npos) {
        read_profile_def(i, line);
      }
      i = eol + 1;
    }
  }

  // // PROFILE_DEF=<id> NAME="<name>" POWER=<W> SPEED=<mm/s> //
  void read_profile_def(std::size_t at, std::string_view line) {
    auto field = [&](std::string_view key) -> std::string_view {
      const std::size_t k = line.find(key);
      if (k == std::string_view::npos) return {};
      std::size_t s = k + key.size(), e = s;
      if (s < line.size() && line[s] == '"') {
        e = line.find('"', s + 1);
        if (e == std::string_view::npos) fail(at + s, "unterminated NAME in PROFILE_DEF");
        return line.substr(s + 1, e - s - 1);
      }
      while (e < line.size() && line[e] != ' ') ++e;
      return line.substr(s, e - s);
    };
    auto number = [&](std::string_view key) {
      const std::string_view t = field(key);
      double x = 0;
      const auto r = std::from_chars(t.data(), t.data() + t.size(), x);
      if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(x))
        fail(at, fmt::format("PROFILE_DEF needs a number after {}", key));
      return x;
    };
    const int id = static_cast<int>(number("PROFILE_DEF="));
    IdInfo& info = ids_[id];
    const std::string_view name = field("NAME=");
    if (!name.empty() && info.label.empty()) info.label = std::string(name);
    if (line.find("POWER=") != std::string_view::npos) info.power = number("POWER=");
    if (line.find("SPEED=") != std::string_view::npos) info.speed = number("SPEED=");
  }

  Path make_path(int id, bool hatch) {
    Path p;
    const auto it = ids_.find(id);
    const std::string label = it == ids_.end() ? "" : it->second.label;
    const bool infill = hatch || label.find("hatch") != std::string::npos ||
                        label.find("infill") != std::string::npos;
    p.role = infill ? PathRole::Infill : PathRole::Contour;
    if (it != ids_.end()) {
      if (it->second.power > 0) p.power = it->second.power;
      if (it->second.speed > 0) p.speed = it->second.speed;
    }
    return p;
  }
  Layer& layer(std::size_t at) {
    if (tp_.layers.empty()) fail(at, "geometry before the first $$LAYER");
    return tp_.layers.back();
  }
  void start_layer(std::size_t at, double z) {
    if (!tp_.layers.empty() && z < tp_.layers.back().z)
      fail(at, fmt::format("layer z = {} mm below the previous layer's {} mm (CLI layers ascend)",
                           z, tp_.layers.back().z));
    Layer l;
    l.z = z;
    tp_.layers.push_back(std::move(l));
  }
  void polyline(std::size_t at, int id, long n, const double* xy, long count) {
    if (n < 1 || count != 2 * n)
      fail(at, fmt::format("$$POLYLINE says {} points but has {} coordinates", n, count));
    Path p = make_path(id, false);
    const double z = layer(at).z;
    for (long k = 0; k < n; ++k)
      p.points.push_back({xy[2 * k] * units_, xy[2 * k + 1] * units_, z});
    layer(at).paths.push_back(std::move(p));
  }
  void hatches(std::size_t at, int id, long n, const double* xy, long count) {
    if (n < 0 || count != 4 * n)
      fail(at, fmt::format("$$HATCHES says {} hatches but has {} coordinates", n, count));
    Layer& l = layer(at);
    for (long k = 0; k < n; ++k) {
      Path p = make_path(id, true);
      p.points = {{xy[4 * k] * units_, xy[4 * k + 1] * units_, l.z},
                  {xy[4 * k + 2] * units_, xy[4 * k + 3] * units_, l.z}};
      l.paths.push_back(std::move(p));
    }
  }

  void read_ascii(std::size_t pos) {
    const std::size_t gs = b_.find("$$GEOMETRYSTART", pos);
    if (gs == std::string::npos) fail(pos, "no $$GEOMETRYSTART after the header");
    std::size_t i = gs + 15;
    bool ended = false;
    while (i < b_.size()) {
      std::size_t eol = b_.find('\n', i);
      if (eol == std::string::npos) eol = b_.size();
      std::size_t s = i;
      while (s < eol && (b_[s] == ' ' || b_[s] == '\t' || b_[s] == '\r')) ++s;
      std::size_t e = eol;
      const std::size_t comment = std::string_view(b_.data() + s, e - s).find("//");
      if (comment != std::string_view::npos) e = s + comment;
      while (e > s && (b_[e - 1] == ' ' || b_[e - 1] == '\r' || b_[e - 1] == '\t')) --e;
      const std::string_view line(b_.data() + s, e - s);
      i = eol + 1;
      if (line.empty()) continue;
      if (line == "$$GEOMETRYEND") {
        ended = true;
        break;
      }
      const std::size_t slash = line.find('/');
      const std::string_view cmd = line.substr(0, slash);
      if (!cmd.starts_with("$$"))
        fail(s, fmt::format("expected a $$COMMAND, got '{}'", line.substr(0, 20)));
      if (cmd != "$$LAYER" && cmd != "$$POLYLINE" && cmd != "$$HATCHES") {
        warn(s, fmt::format("skipped {}", cmd));
        continue;
      }
      if (slash == std::string_view::npos) fail(s, fmt::format("{} without parameters", cmd));
      const std::vector<double> v = numbers(s + slash + 1, e);
      if (cmd == "$$LAYER") {
        if (v.size() != 1) fail(s, "$$LAYER needs one z");
        start_layer(s, v[0] * units_);
      } else if (cmd == "$$POLYLINE") {
        if (v.size() < 3) fail(s, "$$POLYLINE needs id,dir,n,points");
        polyline(s, static_cast<int>(v[0]), static_cast<long>(v[2]), v.data() + 3,
                 static_cast<long>(v.size()) - 3);
      } else {
        if (v.size() < 2) fail(s, "$$HATCHES needs id,n,coordinates");
        hatches(s, static_cast<int>(v[0]), static_cast<long>(v[1]), v.data() + 2,
                static_cast<long>(v.size()) - 2);
      }
    }
    if (!ended) fail(b_.size(), "no $$GEOMETRYEND");
  }

  template <class T>
  T get(std::size_t& pos, std::size_t cmd_at) {
    if (pos + sizeof(T) > b_.size())
      fail(cmd_at, "binary command cut short by the end of the file");
    T v;
    std::memcpy(&v, b_.data() + pos, sizeof(T));
    pos += sizeof(T);
    return v;
  }
  void read_binary(std::size_t pos) {
    if (align_) fail(pos, "$$ALIGN (4-byte aligned binary) is not supported");
    while (pos < b_.size() && (b_[pos] == '\r' || b_[pos] == '\n')) ++pos;
    std::vector<double> xy;
    while (pos < b_.size()) {
      const std::size_t at = pos;
      const auto cmd = get<std::uint16_t>(pos, at);
      auto count = [&](std::int64_t n, std::size_t per, std::size_t bytes) {
        if (n < 0 || static_cast<std::uint64_t>(n) * per * bytes > b_.size() - pos)
          fail(at, fmt::format("command {} says {} items, more than the file holds", cmd, n));
        return static_cast<long>(n);
      };
      switch (cmd) {
        case 127:
          start_layer(at, get<float>(pos, at) * units_);
          break;
        case 128:
          start_layer(at, get<std::uint16_t>(pos, at) * units_);
          break;
        case 129:
        case 130: {
          const bool lng = cmd == 130;
          const int id = lng ? get<std::int32_t>(pos, at) : get<std::uint16_t>(pos, at);
          if (lng)
            get<std::int32_t>(pos, at);
          else
            get<std::uint16_t>(pos, at);  // dir
          const long n =
              count(lng ? get<std::int32_t>(pos, at) : get<std::uint16_t>(pos, at), 2, lng ? 4 : 2);
          xy.resize(2 * static_cast<std::size_t>(n));
          for (auto& x : xy) x = lng ? get<float>(pos, at) : get<std::uint16_t>(pos, at);
          polyline(at, id, n, xy.data(), static_cast<long>(xy.size()));
          break;
        }
        case 131:
        case 132: {
          const bool lng = cmd == 132;
          const int id = lng ? get<std::int32_t>(pos, at) : get<std::uint16_t>(pos, at);
          const long n =
              count(lng ? get<std::int32_t>(pos, at) : get<std::uint16_t>(pos, at), 4, lng ? 4 : 2);
          xy.resize(4 * static_cast<std::size_t>(n));
          for (auto& x : xy) x = lng ? get<float>(pos, at) : get<std::uint16_t>(pos, at);
          if (!std::all_of(xy.begin(), xy.end(), [](double x) { return std::isfinite(x); }))
            fail(at, "non-finite coordinate");
          hatches(at, id, n, xy.data(), static_cast<long>(xy.size()));
          break;
        }
        default:
          fail(at, fmt::format("unknown binary CLI command {}", cmd));
      }
    }
  }

  const std::string& b_;
  std::string origin_;
  Diagnostics* diag_;
  bool binary_ = false, align_ = false;
  double units_ = 1;
  std::size_t header_end_ = 0;
  std::map<int, IdInfo> ids_;
  Toolpath tp_;
};

}  // namespace

std::string write_cli(const Toolpath& tp, const LaserProfile& prof, const CliWriteOptions& o) {
  std::string out = header(tp, prof, o);
  if (o.binary)
    binary_geometry(tp, out);
  else
    ascii_geometry(tp, out);
  return out;
}

void write_cli_file(const std::string& path, const Toolpath& tp, const LaserProfile& prof,
                    const CliWriteOptions& o) {
  write_file_atomic(path, write_cli(tp, prof, o));
}

std::string write_cli(const Toolpath& tp, const LaserProfile& prof) {
  return write_cli(tp, prof, CliWriteOptions{});
}

void write_cli_file(const std::string& path, const Toolpath& tp, const LaserProfile& prof) {
  write_file_atomic(path, write_cli(tp, prof));
}

Toolpath read_cli(const std::string& bytes, const std::string& origin, Diagnostics* diag) {
  return Reader(bytes, origin, diag).run();
}

Toolpath read_cli_file(const std::string& path, Diagnostics* diag) {
  return read_cli(read_file(path), path, diag);
}

}  // namespace trellis
