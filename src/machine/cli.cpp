#include "trellis/machine/cli.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <map>
#include <string_view>
#include <vector>

#include "fast_number.hpp"
#include "text_out.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/version.hpp"

namespace trellis {

namespace {

static_assert(std::endian::native == std::endian::little, "binary CLI I/O assumes little endian");

constexpr double kUnits = 0.001;  // mm per CLI unit (1 µm)
constexpr int kContourId = 1, kHatchId = 2;

// Coordinates in µm with two decimals (10 nm), no trailing zeros.
// (fastnum::cli_um: the bytes of fmt::format("{}", round(mm * 1e5) / 100.0), -0 as 0.)
void put(fastnum::TextOut& out, double mm) {
  out.commit(fastnum::cli_um(out.room(fastnum::kMaxChars), mm));
}

// ",<x>,<y>" written in place.
[[gnu::always_inline]] inline void put_xy(fastnum::TextOut& out, const Vec3& q) {
  char* b = out.room(2 * fastnum::kMaxChars + 2);
  *b++ = ',';
  b = fastnum::cli_um(b, q.x);
  *b++ = ',';
  b = fastnum::cli_um(b, q.y);
  out.commit(b);
}

// A block's head, "<command><id>,<more>" (integers as fmt's "{}" prints them).
void put_head(fastnum::TextOut& out, std::string_view command, int id, std::string_view middle,
              std::size_t n) {
  char* h = out.room(command.size() + middle.size() + 48);
  std::memcpy(h, command.data(), command.size());
  h = std::to_chars(h + command.size(), h + command.size() + 24, id).ptr;
  std::memcpy(h, middle.data(), middle.size());
  h = std::to_chars(h + middle.size(), h + middle.size() + 24, n).ptr;
  out.commit(h);
}

template <class T>
void put_bin(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

// A block's id: a contour id and a hatch id per part (one pair without parts), one set of them
// per laser (laser 0's first). Lasers beyond the first are named in the id's label.
int block_id(int part, std::size_t parts, int laser, bool hatch) {
  const int base = part == 0 ? (hatch ? kHatchId : kContourId) : 2 * part - (hatch ? 0 : 1);
  return base + 2 * static_cast<int>(std::max<std::size_t>(parts, 1)) * laser;
}

// Parameter set k's id for laser `laser`: after every part's and laser's contour and hatch ids.
int set_id(std::size_t k, std::size_t sets, std::size_t parts, int lasers, int laser) {
  return 2 * static_cast<int>(std::max<std::size_t>(parts, 1)) * lasers + 1 +
         static_cast<int>(k + sets * static_cast<std::size_t>(laser));
}

// The id a path is written under: its parameter set's, else `fallback` (its block's).
int id_of(const Path& p, bool hatch, int fallback, const std::vector<CliParameterSet>& sets,
          std::size_t parts, int lasers, int laser) {
  for (std::size_t k = 0; k < sets.size(); ++k)
    if (sets[k].hatch == hatch && sets[k].power == p.power && sets[k].speed == p.speed)
      return set_id(k, sets.size(), parts, lasers, laser);
  return fallback;
}

std::string laser_suffix(int laser, int lasers) {
  return lasers > 1 ? fmt::format(" laser {}", laser + 1) : std::string();
}

// The lasers a toolpath's blocks are written for: the profile's, or more if a path says so.
int lasers_of(const Toolpath& tp, const LaserProfile& prof) {
  int n = std::max(1, prof.lasers);
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) n = std::max(n, p.tool + 1);
  return n;
}

bool is_hatch(const Path& p) {
  return (p.role == PathRole::Hatch || p.role == PathRole::Infill) && p.points.size() == 2;
}

// "//laser N: contour P W S mm/s; hatch P W S mm/s; spot D mm; jump V mm/s; delays jump J, mark
// M, polygon G, on A, off B us; skywriting on|off K us//": one laser of several that differ (read
// back as Toolpath::lasers; a line without the skywriting part, as Trellis wrote it before, is
// read as a laser that does not skywrite).
std::string laser_comment(int l, const LaserParameters& p) {
  const ScanTiming& t = p.timing;
  return fmt::format(
      "//laser {}: contour {} W {} mm/s; hatch {} W {} mm/s; spot {} mm; jump {} mm/s; delays "
      "jump {}, mark {}, polygon {}, on {}, off {} us; skywriting {} {} us//\n",
      l + 1, p.contour_power, p.contour_speed, p.hatch_power, p.hatch_speed, p.spot_diameter,
      t.jump_speed, t.jump_delay, t.mark_delay, t.polygon_delay, t.laser_on_delay,
      t.laser_off_delay, t.skywriting ? "on" : "off", t.skywriting_time);
}

// The header: every point's extent and the layer count are known only once all layers are.
std::string header(BBox3 box, std::size_t layers, const std::string& source, const std::string& job,
                   const LaserProfile& prof, const CliWriteOptions& o, int lasers,
                   const std::vector<std::string>& labels = {}) {
  if (box.empty()) box.add({0, 0, 0});
  std::string out = "$$HEADERSTART\n";
  out += o.binary ? "$$BINARY\n" : "$$ASCII\n";
  out += "$$UNITS/0.001\n$$VERSION/200\n";
  for (int l = 0; l < lasers; ++l) {
    const std::string sfx = laser_suffix(l, lasers);
    if (labels.empty()) {
      out += fmt::format("$$LABEL/{},contour{}\n$$LABEL/{},hatch{}\n", block_id(0, 0, l, false),
                         sfx, block_id(0, 0, l, true), sfx);
    } else {
      // A build plate: a contour id and a hatch id per part, labelled with the part.
      for (std::size_t k = 0; k < labels.size(); ++k)
        out +=
            fmt::format("$$LABEL/{},{} contour{}\n$$LABEL/{},{} hatch{}\n",
                        block_id(static_cast<int>(k + 1), labels.size(), l, false), labels[k], sfx,
                        block_id(static_cast<int>(k + 1), labels.size(), l, true), labels[k], sfx);
    }
  }
  const std::size_t parts = labels.size();
  for (int l = 0; l < lasers; ++l)
    for (std::size_t k = 0; k < o.sets.size(); ++k)
      out += fmt::format("$$LABEL/{},{}{}\n", set_id(k, o.sets.size(), parts, lasers, l),
                         o.sets[k].name, laser_suffix(l, lasers));
  out += fmt::format("//generated by Trellis {}//\n", TRELLIS_VERSION);
  out += fmt::format("//machine: {}//\n", prof.name);
  out += fmt::format("//id 1 contour: {} W, {} mm/s; id 2 hatch: {} W, {} mm/s; spot {} mm//\n",
                     prof.contour_power, prof.contour_speed, prof.hatch_power, prof.hatch_speed,
                     prof.spot_diameter);
  // Lasers that differ: each one's parameters, and its own contour and hatch power and speed in
  // its ids' CLI+ definitions.
  const std::vector<LaserParameters> each = laser_parameters(prof);
  const LaserParameters own = profile_laser(prof);
  const auto laser = [&](int l) -> const LaserParameters& {
    return static_cast<std::size_t>(l) < each.size() ? each[static_cast<std::size_t>(l)] : own;
  };
  for (int l = 0; lasers_differ(prof) && l < lasers; ++l) out += laser_comment(l, laser(l));
  for (int l = 0; o.plus && l < lasers; ++l) {
    const std::string sfx = laser_suffix(l, lasers);
    const std::string las = lasers > 1 ? fmt::format(" LASER={}", l + 1) : std::string();
    const LaserParameters& L = laser(l);
    if (labels.empty()) {
      out += fmt::format("// PROFILE_DEF={} NAME=\"contour{}\" POWER={} SPEED={}{} //\n",
                         block_id(0, 0, l, false), sfx, L.contour_power, L.contour_speed, las);
      out += fmt::format("// PROFILE_DEF={} NAME=\"hatch{}\" POWER={} SPEED={}{} //\n",
                         block_id(0, 0, l, true), sfx, L.hatch_power, L.hatch_speed, las);
    } else {
      for (std::size_t k = 0; k < labels.size(); ++k) {
        const int part = static_cast<int>(k + 1);
        out += fmt::format("// PROFILE_DEF={} NAME=\"{} contour{}\" POWER={} SPEED={}{} //\n",
                           block_id(part, labels.size(), l, false), labels[k], sfx, L.contour_power,
                           L.contour_speed, las);
        out += fmt::format("// PROFILE_DEF={} NAME=\"{} hatch{}\" POWER={} SPEED={}{} //\n",
                           block_id(part, labels.size(), l, true), labels[k], sfx, L.hatch_power,
                           L.hatch_speed, las);
      }
    }
  }
  for (int l = 0; o.plus && l < lasers; ++l)
    for (std::size_t k = 0; k < o.sets.size(); ++k)
      out += fmt::format("// PROFILE_DEF={} NAME=\"{}{}\" POWER={} SPEED={}{} //\n",
                         set_id(k, o.sets.size(), parts, lasers, l), o.sets[k].name,
                         laser_suffix(l, lasers), o.sets[k].power, o.sets[k].speed,
                         lasers > 1 ? fmt::format(" LASER={}", l + 1) : std::string());
  out += fmt::format("//source: {}//\n", source);
  // The job that made the file, one comment line each, for `trellis rerun`.
  for (std::size_t a = 0; a < job.size();) {
    const std::size_t b = std::min(job.find('\n', a), job.size());
    out += "//job: " + job.substr(a, b - a) + "//\n";
    a = b + 1;
  }
  out += fmt::format("$$DIMENSION/{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n", box.min.x,
                     box.min.y, box.min.z, box.max.x, box.max.y, box.max.z);
  out += fmt::format("$$LAYERS/{}\n$$HEADEREND", layers);
  return out;
}

std::string header(const Toolpath& tp, const LaserProfile& prof, const CliWriteOptions& o) {
  return header(points_box(tp), tp.layers.size(), tp.source, tp.job, prof, o, lasers_of(tp, prof),
                tp.part_labels);
}

// The geometry section: what comes before the first layer, each layer, what comes after.
const char* kAsciiStart = "\n$$GEOMETRYSTART\n";
const char* kAsciiEnd = "$$GEOMETRYEND\n";

// The layer's blocks in file order, one per part (or one when there are no parts) and laser: each
// of a block's contour paths to `contour(id, path)` as it comes, then its hatch vectors,
// `hatches(id, vectors)` per run of one id (one run without parameter sets).
template <class Contour, class Hatches>
void for_each_block(const Layer& layer, std::size_t parts, int lasers,
                    const std::vector<CliParameterSet>& sets, Contour&& contour,
                    Hatches&& hatches) {
  std::vector<std::pair<int, std::vector<const Path*>>> runs;
  for (int part = 0; part <= static_cast<int>(parts); ++part)
    for (int laser = 0; laser < lasers; ++laser) {
      const auto mine = [&](const Path& p) {
        return (p.part == part || parts == 0) && (lasers == 1 || p.tool == laser);
      };
      const int contour_id = block_id(part, parts, laser, false);
      const int hatch_id = block_id(part, parts, laser, true);
      runs.clear();
      for (const auto& p : layer.paths) {
        if (!mine(p)) continue;
        if (is_hatch(p)) {
          const int id = id_of(p, true, hatch_id, sets, parts, lasers, laser);
          if (runs.empty() || runs.back().first != id) runs.push_back({id, {}});
          runs.back().second.push_back(&p);
        } else {
          contour(id_of(p, false, contour_id, sets, parts, lasers, laser), p);
        }
      }
      for (const auto& [id, vectors] : runs) hatches(id, vectors);
    }
}

void ascii_layer(const Layer& layer, fastnum::TextOut& out, std::size_t parts, int lasers,
                 const std::vector<CliParameterSet>& sets) {
  out += "$$LAYER/";
  put(out, layer.z);
  out += '\n';
  for_each_block(
      layer, parts, lasers, sets,
      [&](int id, const Path& p) {
        put_head(out, "$$POLYLINE/", id, ",2,", p.points.size());
        for (const auto& q : p.points) put_xy(out, q);
        out += '\n';
      },
      [&](int id, const std::vector<const Path*>& vectors) {
        put_head(out, "$$HATCHES/", id, ",", vectors.size());
        for (const Path* p : vectors)
          for (const auto& q : p->points) put_xy(out, q);
        out += '\n';
      });
}

void ascii_geometry(const Toolpath& tp, std::string& out, int lasers,
                    const std::vector<CliParameterSet>& sets) {
  std::size_t points = 0;
  for (const auto& layer : tp.layers)
    for (const auto& p : layer.paths) points += p.points.size();
  fastnum::TextOut text;
  text.adopt(std::move(out));
  text.reserve(text.size() + points * 18 + tp.layers.size() * 64 + 64);  // ~",123.45,67.89"
  fastnum::advise_huge_pages(text.storage());
  text += kAsciiStart;
  for (const auto& layer : tp.layers) ascii_layer(layer, text, tp.part_labels.size(), lasers, sets);
  text += kAsciiEnd;
  out = text.take();
}

void binary_layer(const Layer& layer, std::string& out, std::size_t parts, int lasers,
                  const std::vector<CliParameterSet>& sets) {
  auto coord = [&](double mm) { put_bin(out, static_cast<float>(mm / kUnits)); };
  put_bin<std::uint16_t>(out, 127);
  coord(layer.z);
  for_each_block(
      layer, parts, lasers, sets,
      [&](int id, const Path& p) {
        put_bin<std::uint16_t>(out, 130);
        put_bin<std::int32_t>(out, id);
        put_bin<std::int32_t>(out, 2);  // open
        put_bin<std::int32_t>(out, static_cast<std::int32_t>(p.points.size()));
        for (const auto& q : p.points) coord(q.x), coord(q.y);
      },
      [&](int id, const std::vector<const Path*>& vectors) {
        put_bin<std::uint16_t>(out, 132);
        put_bin<std::int32_t>(out, id);
        put_bin<std::int32_t>(out, static_cast<std::int32_t>(vectors.size()));
        for (const Path* p : vectors)
          for (const auto& q : p->points) coord(q.x), coord(q.y);
      });
}

void binary_geometry(const Toolpath& tp, std::string& out, int lasers,
                     const std::vector<CliParameterSet>& sets) {
  for (const auto& layer : tp.layers) binary_layer(layer, out, tp.part_labels.size(), lasers, sets);
}

// What the reader knows of each id: role and CLI+ power/speed.
struct IdInfo {
  std::string label;
  double power = 0, speed = 0;
  int laser = -1;  // from the label's " laser N" or CLI+ LASER=N (0-based); -1 = not said
};

// "… laser N" at the end of a label → N - 1; -1 if the label names no laser.
int laser_of_label(std::string_view label) {
  const std::size_t k = label.rfind(" laser ");
  if (k == std::string_view::npos) return -1;
  int n = 0;
  const char* e = label.data() + label.size();
  const auto r = std::from_chars(label.data() + k + 7, e, n);
  return r.ec == std::errc() && r.ptr == e && n >= 1 ? n - 1 : -1;
}

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
    name_parameter_sets();
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
  // A count or id read as a number: a whole number an int holds, else an error at `offset`.
  long whole(std::size_t offset, double x, const char* what) const {
    if (!(std::abs(x) <= 2147483647.0) || x != std::floor(x))
      fail(offset, fmt::format("{} must be a whole number, got {}", what, x));
    return static_cast<long>(x);
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
        if (v.size() != 1 || !(v[0] > 0) || !(v[0] <= 1000))
          fail(i + 8, "$$UNITS needs one positive number up to 1000 (mm per unit)");
        units_ = v[0];
      } else if (line.starts_with("$$LABEL/")) {
        const std::size_t c = line.find(',');
        if (c == std::string_view::npos) fail(i, "$$LABEL needs id,text");
        const auto id = numbers(i + 8, i + c);
        if (id.size() != 1 || !(std::abs(id[0]) <= 1e9)) fail(i + 8, "$$LABEL needs one id number");
        ids_[static_cast<int>(whole(i + 8, id[0], "$$LABEL id"))].label =
            std::string(line.substr(c + 1));
      } else if (line.find("PROFILE_DEF=") != std::string_view::npos) {
        read_profile_def(i, line);
      } else if (line.starts_with("//laser ")) {
        read_laser(i, line);
      }
      i = eol + 1;
    }
  }

  // laser_comment's line: one of the lasers that differ, into Toolpath::lasers.
  void read_laser(std::size_t at, std::string_view line) {
    const std::string text(line);
    int n = 0, end = 0;
    LaserParameters l;
    ScanTiming& t = l.timing;
    char sky[4] = {};
    int got = std::sscanf(
        text.c_str(),
        "//laser %d: contour %lf W %lf mm/s; hatch %lf W %lf mm/s; spot %lf mm; jump %lf mm/s; "
        "delays jump %lf, mark %lf, polygon %lf, on %lf, off %lf us; skywriting %3s %lf us//%n",
        &n, &l.contour_power, &l.contour_speed, &l.hatch_power, &l.hatch_speed, &l.spot_diameter,
        &t.jump_speed, &t.jump_delay, &t.mark_delay, &t.polygon_delay, &t.laser_on_delay,
        &t.laser_off_delay, sky, &t.skywriting_time, &end);
    const std::string_view said(sky);
    bool ok = got == 14 && end == static_cast<int>(text.size()) &&
              (said == "on" || said == "off") && std::isfinite(t.skywriting_time) &&
              t.skywriting_time >= 0;
    if (got == 12) {  // written before skywriting was per laser: no skywriting part
      end = 0;
      l.timing = ScanTiming{};
      got = std::sscanf(
          text.c_str(),
          "//laser %d: contour %lf W %lf mm/s; hatch %lf W %lf mm/s; spot %lf mm; jump %lf mm/s; "
          "delays jump %lf, mark %lf, polygon %lf, on %lf, off %lf us//%n",
          &n, &l.contour_power, &l.contour_speed, &l.hatch_power, &l.hatch_speed, &l.spot_diameter,
          &t.jump_speed, &t.jump_delay, &t.mark_delay, &t.polygon_delay, &t.laser_on_delay,
          &t.laser_off_delay, &end);
      ok = got == 12 && end == static_cast<int>(text.size());
    }
    if (!ok || n < 1 || n > 1000)
      fail(at,
           "a //laser N: …// line that does not say every value of laser N (1 to 1000), "
           "skywriting on or off");
    t.skywriting = said == "on";
    t.contour_speed = l.contour_speed, t.hatch_speed = l.hatch_speed;
    if (tp_.lasers.size() < static_cast<std::size_t>(n))
      tp_.lasers.resize(static_cast<std::size_t>(n));
    tp_.lasers[static_cast<std::size_t>(n - 1)] = l;
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
    const int id = static_cast<int>(whole(at, number("PROFILE_DEF="), "PROFILE_DEF id"));
    IdInfo& info = ids_[id];
    const std::string_view name = field("NAME=");
    if (!name.empty() && info.label.empty()) info.label = std::string(name);
    if (line.find("POWER=") != std::string_view::npos) info.power = number("POWER=");
    if (line.find("SPEED=") != std::string_view::npos) info.speed = number("SPEED=");
    if (line.find("LASER=") != std::string_view::npos) {
      const double n = whole(at, number("LASER="), "PROFILE_DEF LASER");
      if (n < 1 || n > 1e6) fail(at, "PROFILE_DEF LASER= needs a laser number from 1");
      info.laser = static_cast<int>(n) - 1;
    }
  }

  // Each labelled CLI+ id with a power or speed as a named parameter set; ids of one set (the
  // same role, power and speed) for several lasers share its name without " laser N", for several
  // parts (a build plate's "g01 contour", "g02 contour") the role names it.
  void name_parameter_sets() {
    for (const auto& [id, info] : ids_) {
      if (info.label.empty() || !(info.power > 0 || info.speed > 0)) continue;
      const Path p = make_path(id, false);
      std::string name = info.label;
      if (const std::size_t k = name.rfind(" laser ");
          k != std::string::npos && laser_of_label(name) >= 0)
        name.erase(k);
      const int have = parameter_set_of(tp_, p);
      if (have < 0)
        tp_.parameter_sets.push_back({name, p.role, p.power, p.speed});
      else if (tp_.parameter_sets[static_cast<std::size_t>(have)].name != name)
        tp_.parameter_sets[static_cast<std::size_t>(have)].name = to_string(p.role);
    }
  }

  Path make_path(int id, bool hatch) {
    Path p;
    const auto it = ids_.find(id);
    const std::string label = it == ids_.end() ? "" : it->second.label;
    const bool infill = hatch || label.find("hatch") != std::string::npos ||
                        label.find("infill") != std::string::npos;
    p.role = infill ? PathRole::Hatch : PathRole::Contour;
    if (it != ids_.end()) {
      const int l = it->second.laser >= 0 ? it->second.laser : laser_of_label(it->second.label);
      if (l > 0) p.tool = l;
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
    if (!std::isfinite(z) || std::abs(z) > 1e6)
      fail(at, "layer z is not a finite number of millimetres within ±1e6 ($$UNITS)");
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
    for (const Vec3& q : p.points)
      if (!std::isfinite(q.x) || !std::isfinite(q.y) || std::abs(q.x) > 1e6 || std::abs(q.y) > 1e6)
        fail(at, "a coordinate times $$UNITS is not a finite number of millimetres within ±1e6");
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
      for (const Vec3& q : p.points)
        if (!std::isfinite(q.x) || !std::isfinite(q.y) || std::abs(q.x) > 1e6 ||
            std::abs(q.y) > 1e6)
          fail(at, "a coordinate times $$UNITS is not a finite number of millimetres within ±1e6");
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
        polyline(s, static_cast<int>(whole(s, v[0], "$$POLYLINE id")),
                 whole(s, v[2], "$$POLYLINE point count"), v.data() + 3,
                 static_cast<long>(v.size()) - 3);
      } else {
        if (v.size() < 2) fail(s, "$$HATCHES needs id,n,coordinates");
        hatches(s, static_cast<int>(whole(s, v[0], "$$HATCHES id")),
                whole(s, v[1], "$$HATCHES count"), v.data() + 2, static_cast<long>(v.size()) - 2);
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
          if (!std::all_of(xy.begin(), xy.end(), [](double x) { return std::isfinite(x); }))
            fail(at, "non-finite coordinate");
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

std::vector<CliParameterSet> cli_parameter_sets(const std::vector<ParameterSet>& named,
                                                std::size_t profile_sets) {
  std::vector<CliParameterSet> sets;
  for (std::size_t i = profile_sets; i < named.size(); ++i)
    sets.push_back(
        {named[i].name, named[i].role == PathRole::Hatch, named[i].power, named[i].speed});
  return sets;
}

std::string write_cli(const Toolpath& tp, const LaserProfile& prof, const CliWriteOptions& o) {
  check_for_laser(tp, prof);  // power, speed and build area before anything is written
  std::string out = header(tp, prof, o);
  const int lasers = lasers_of(tp, prof);
  if (o.binary)
    binary_geometry(tp, out, lasers, o.sets);
  else
    ascii_geometry(tp, out, lasers, o.sets);
  return out;
}

void write_cli_file(const std::string& path, const Toolpath& tp, const LaserProfile& prof,
                    const CliWriteOptions& o) {
  write_file_atomic(path, write_cli(tp, prof, o));
}

CliStreamWriter::CliStreamWriter(std::string path, const LaserProfile& prof,
                                 const CliWriteOptions& o, std::string source, std::string job)
    : path_(std::move(path)),
      source_(std::move(source)),
      job_(std::move(job)),
      profile_(prof),
      options_(o) {
  check_for_laser(Toolpath{}, profile_);  // the profile's own power and speed
  body_ =
      temporary_file();  // in $TMPDIR, unlinked already: gone with the process, whatever happens
  if (!options_.binary) buffer_ += kAsciiStart;
}

CliStreamWriter::~CliStreamWriter() {
  if (body_) std::fclose(body_);
}

void CliStreamWriter::flush() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), body_) != buffer_.size())
    throw IoError(std::string("cannot write a temporary file: ") + std::strerror(errno), {path_});
  buffer_.clear();
}

void CliStreamWriter::add(const Layer& layer) {
  if (finished_) throw Error("CliStreamWriter: layer added after finish()");
  Toolpath one;
  one.layers.push_back(layer);
  check_for_laser(one, profile_, layers_);
  const int lasers = std::max(1, profile_.lasers);
  for (const auto& p : layer.paths) {
    if (p.tool < 0 || p.tool >= lasers)
      throw GeometryError(fmt::format("layer {}: a path on laser {}, the machine has {} "
                                      "(laser.lasers)",
                                      layers_, p.tool + 1, lasers),
                          {path_, 0, "laser.lasers"});
    for (const auto& q : p.points) box_.add(q);
  }
  if (options_.binary)
    binary_layer(layer, buffer_, 0, lasers, options_.sets);
  else {
    fastnum::TextOut text;
    text.adopt(std::move(buffer_));
    ascii_layer(layer, text, 0, lasers, options_.sets);
    buffer_ = text.take();
  }
  ++layers_;
  if (buffer_.size() > (1u << 20)) flush();
}

void CliStreamWriter::finish() {
  if (finished_) return;
  // The whole part within the build area (each layer was checked on its own).
  Toolpath extent_only;
  if (!box_.empty()) {
    Path p;
    p.points = {box_.min, box_.max};
    extent_only.layers.push_back(Layer{});
    extent_only.layers.back().paths.push_back(std::move(p));
  }
  check_for_laser(extent_only, profile_);
  if (!options_.binary) buffer_ += kAsciiEnd;
  flush();
  if (std::fflush(body_) != 0)
    throw IoError(std::string("cannot write a temporary file: ") + std::strerror(errno), {path_});
  const std::string head =
      header(box_, layers_, source_, job_, profile_, options_, std::max(1, profile_.lasers));
  write_file_atomic_with(path_, [&](const ByteWriter& put) {
    put(head);
    std::rewind(body_);
    std::string chunk(1u << 20, '\0');
    for (;;) {
      const std::size_t n = std::fread(chunk.data(), 1, chunk.size(), body_);
      if (n > 0) put(std::string_view(chunk.data(), n));
      if (n < chunk.size()) {
        if (std::ferror(body_))
          throw IoError(std::string("cannot read a temporary file: ") + std::strerror(errno),
                        {path_});
        break;
      }
    }
  });
  finished_ = true;
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
