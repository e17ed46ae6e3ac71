// Viewer pages: inputs read into scenes, the scenes' data blocks (encode.cpp) put into the page
// template bundled from viewer/ at build time (viewer_template.inc, made by viewer/build.mjs).
#include "trellis/view/view.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "page.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/toolpath/json.hpp"

namespace trellis {

namespace {

namespace fs = std::filesystem;

const char kTemplateText[] =
#include "viewer_template.inc"
    ;
const std::string_view kTemplate(kTemplateText, sizeof kTemplateText - 1);

std::string lower_ext(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

// G-code: one pass feeding the IR builder and the counters `trellis analyze` reports; mixtures
// as the reader settles them (deposited by default), the commanded ones kept beside.
ViewScene load_gcode(const std::string& path, const GcodeReadOptions& read, Diagnostics& diag) {
  ViewScene s;
  CountingSink counter;
  Diagnostics local;
  GcodeRead r = read_gcode_file(path, read, local, &counter, true);
  counter.finish();
  s.toolpath = std::move(r.toolpath);
  s.mixture_read_back = true;
  s.mixture_lookahead = read.commanded_mixtures ? 0 : r.mixture_lookahead;
  s.commanded = std::move(r.commanded);
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

bool looks_like_check_report(const std::string& path) {
  const std::string head = read_file(path).substr(0, 4096);
  return head.find("\"collision_list\"") != std::string::npos ||
         head.find("\"struts_printed_once\"") != std::string::npos;
}

// A `trellis check` report: the collision points ringed, the counts as statistics; the struts it
// names are flagged once a design is given (set_design keeps the flags).
ViewScene load_check_report(const std::string& path) {
  ViewScene s;
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_file(path));
  } catch (const nlohmann::json::exception& e) {
    throw ParseError(path + ": not a check report: " + e.what());
  }
  auto count = [&](const char* key) -> std::size_t {
    if (!j.contains(key)) throw ParseError(path + ": check report without '" + key + "'");
    const auto& v = j[key];
    return v.is_array() ? v.size() : v.get<std::size_t>();
  };
  s.checked = true;
  s.collisions = count("collisions");
  for (const auto& h : j.value("collision_list", nlohmann::json::array())) {
    const auto& p = h.at("point");
    if (!p.is_array() || p.size() != 3)
      throw ParseError(path + ": collision without a point [x, y, z]");
    ViewScene::Hit hit;
    hit.path = h.value("path", -1LL);
    hit.segment = h.value("segment", -1LL);
    hit.point = {p[0].get<double>(), p[1].get<double>(), p[2].get<double>()};
    s.hits.push_back(hit);
    for (const char* k : {"strut", "hit_strut"}) {
      const long long e = h.value(k, -1LL);
      if (e < 0) continue;
      if (s.design_flag.size() <= static_cast<std::size_t>(e))
        s.design_flag.resize(static_cast<std::size_t>(e) + 1, 0);
      s.design_flag[static_cast<std::size_t>(e)] = 1;
    }
  }
  s.extra_stats = {
      {"checked paths", std::to_string(count("paths"))},
      {"checked segments", std::to_string(count("segments"))},
      {"struts printed once",
       std::to_string(count("struts_printed_once")) + "/" + std::to_string(count("struts"))},
      {"missing struts", std::to_string(count("missing_struts"))},
      {"repeated struts", std::to_string(count("repeated_struts"))},
      {"off-design segments", std::to_string(count("off_design_segments"))},
  };
  return s;
}

bool looks_like_toolpath_json(const std::string& path) {
  const std::string head = read_file(path).substr(0, 4096);
  return head.find("\"layers\"") != std::string::npos;
}

}  // namespace

ViewScene load_view_scene(const std::string& path, const ViewLoadOptions& options,
                          Diagnostics& diag) {
  if (!fs::exists(path)) throw IoError(path + ": no such file");
  const std::string ext = lower_ext(path);
  ViewScene s;
  if (ext == ".gcode" || ext == ".g" || ext == ".gco" || ext == ".nc" || ext == ".bgcode") {
    GcodeReadOptions read;
    if (!options.valve_on.empty()) read.valve_on = options.valve_on;
    if (!options.valve_off.empty()) read.valve_off = options.valve_off;
    s = load_gcode(path, read, diag);
    s.kind = ext == ".nc" ? "nc" : ext == ".bgcode" ? "bgcode" : "gcode";
  } else if (ext == ".cli") {
    s.toolpath = read_cli_file(path, &diag);
    s.kind = "cli";
  } else if (ext == ".3mf" && toolpath_3mf_kind(path) != Toolpath3mfKind::None) {
    s.toolpath = read_toolpath_3mf_file(path, &diag);
    s.kind = "toolpath";
  } else if (ext == ".json" && looks_like_check_report(path)) {
    s = load_check_report(path);
    s.kind = "check";
  } else if (ext == ".json" && looks_like_toolpath_json(path)) {
    s.toolpath = read_toolpath(path);
    s.kind = "toolpath";
  } else if (ext == ".json" || ext == ".csv" || ext == ".obj" || ext == ".3mf") {
    s = load_lattice(path, diag);
    s.kind = "lattice";
  } else {
    throw ParseError(path + ": cannot view a '" + ext +
                     "' file (G-code .gcode/.g/.nc/.bgcode, laser .cli, toolpath or lattice JSON, "
                     "a `trellis check` report, lattice CSV/OBJ/3MF, a 3MF toolpath)");
  }
  s.name = fs::path(path).filename().string();
  return s;
}

namespace {

// Nearest-strut distances through a uniform grid of cells about one mean strut long: each strut is
// listed in the cells its bounding box covers; a query searches shells of cells around the point
// until the nearest strut found is closer than the next shell can be.
class StrutGrid {
 public:
  explicit StrutGrid(const std::vector<std::pair<Vec3, Vec3>>& struts) : struts_(struts) {
    if (struts.empty()) return;
    lo_ = hi_ = struts[0].first;
    double total = 0;
    for (const auto& [a, b] : struts) {
      for (Vec3 p : {a, b}) {
        lo_ = {std::min(lo_.x, p.x), std::min(lo_.y, p.y), std::min(lo_.z, p.z)};
        hi_ = {std::max(hi_.x, p.x), std::max(hi_.y, p.y), std::max(hi_.z, p.z)};
      }
      total += distance(a, b);
    }
    const Vec3 size = hi_ - lo_;
    cell_ = std::max({total / static_cast<double>(struts.size()), 1e-3,
                      std::max({size.x, size.y, size.z}) / 256});
    for (int k = 0; k < 3; ++k) n_[k] = static_cast<int>(std::floor(comp(size, k) / cell_)) + 1;
    cells_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
    for (std::size_t e = 0; e < struts.size(); ++e) {
      const auto& [a, b] = struts[e];
      int c0[3], c1[3];
      for (int k = 0; k < 3; ++k) {
        c0[k] = index(std::min(comp(a, k), comp(b, k)), k);
        c1[k] = index(std::max(comp(a, k), comp(b, k)), k);
      }
      for (int x = c0[0]; x <= c1[0]; ++x)
        for (int y = c0[1]; y <= c1[1]; ++y)
          for (int z = c0[2]; z <= c1[2]; ++z) cells_[flat(x, y, z)].push_back(e);
    }
  }

  double nearest(Vec3 p) const {
    if (struts_.empty()) return 0;
    int c[3];
    for (int k = 0; k < 3; ++k) c[k] = index(comp(p, k), k);
    double best = std::numeric_limits<double>::infinity();
    const int most = std::max({n_[0], n_[1], n_[2]});
    for (int r = 0; r <= most; ++r) {
      for (int x = c[0] - r; x <= c[0] + r; ++x)
        for (int y = c[1] - r; y <= c[1] + r; ++y)
          for (int z = c[2] - r; z <= c[2] + r; ++z) {
            if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != r)
              continue;
            if (x < 0 || y < 0 || z < 0 || x >= n_[0] || y >= n_[1] || z >= n_[2]) continue;
            for (std::size_t e : cells_[flat(x, y, z)])
              best = std::min(best, distance_to_segment(p, struts_[e].first, struts_[e].second));
          }
      // Every strut not yet seen lies in cells at least r cells from p's cell.
      if (best <= r * cell_) return best;
    }
    return best;
  }

 private:
  static double comp(Vec3 v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }
  int index(double v, int k) const {
    return std::clamp(static_cast<int>(std::floor((v - comp(lo_, k)) / cell_)), 0, n_[k] - 1);
  }
  std::size_t flat(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * n_[1] + y) * n_[0] + x;
  }
  const std::vector<std::pair<Vec3, Vec3>>& struts_;
  Vec3 lo_, hi_;
  double cell_ = 1;
  int n_[3] = {1, 1, 1};
  std::vector<std::vector<std::size_t>> cells_;
};

}  // namespace

void set_design(ViewScene& s, const Graph& g) {
  std::vector<char> flags = s.design_flag;  // a check report's flags, by strut id
  s.design.clear();
  s.design_flag.clear();
  for (std::size_t e = 0; e < g.edges.size(); ++e) {
    s.design.push_back({g.nodes[g.edges[e].a], g.nodes[g.edges[e].b]});
    s.design_flag.push_back(e < flags.size() ? flags[e] : 0);
  }
  s.deviation.clear();
  if (s.design.empty()) return;
  const StrutGrid grid(s.design);
  for (const auto& l : s.toolpath.layers)
    for (const auto& p : l.paths)
      for (const auto& q : p.points) s.deviation.push_back(static_cast<float>(grid.nearest(q)));
}

void set_collisions(ViewScene& s, const CollisionCheck& c) {
  s.checked = true;
  s.collisions = c.collisions;
  s.hits.clear();
  for (const auto& h : c.hits) {
    s.hits.push_back({static_cast<long long>(h.path), static_cast<long long>(h.segment), h.point});
    for (long long e : {h.strut, h.hit_strut})
      if (e >= 0 && static_cast<std::size_t>(e) < s.design_flag.size())
        s.design_flag[static_cast<std::size_t>(e)] = 1;
  }
}

void set_build_volume(ViewScene& s, const MachineProfile& m, const std::string& name) {
  s.bed.shape = to_string(m.bed_shape);
  s.bed.x = m.bed_x;
  s.bed.y = m.bed_shape == BedShape::Circle ? m.bed_x : m.bed_y;
  s.bed.z = m.bed_z;
  s.bed.center = m.origin == BedOrigin::Center;
  s.bed.machine = name;
}

std::string mixture_label(const ViewScene& s, bool commanded) {
  if (!s.mixture_read_back) return "(as planned)";
  if (!(s.mixture_lookahead > 0)) return "(as commanded; no look-ahead recorded)";
  const std::string mm = std::to_string(static_cast<long>(std::lround(s.mixture_lookahead)));
  return commanded ? "(as commanded, " + mm + " mm ahead)"
                   : "(as deposited, " + mm + " mm look-ahead undone)";
}

ViewScene view_scene(const Toolpath& toolpath, const std::string& name) {
  ViewScene s;
  s.toolpath = toolpath;
  s.name = name;
  s.kind = "toolpath";
  return s;
}

std::string viewer_html(const std::vector<ViewScene>& scenes, const std::string& title) {
  using namespace view_page;
  const std::size_t at = kTemplate.find(kDataMarker);
  if (at == std::string_view::npos) throw Error("viewer template has no data marker");
  const std::string data = data_blocks(scenes, title, LayerData::Chunks);
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

std::string_view view_page::page_template() {
  return kTemplate;
}

}  // namespace trellis
