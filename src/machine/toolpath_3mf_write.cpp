// The toolpath IR as a 3MF package with the Toolpath Extension v1.0 (section numbers below are
// the specification's, 3MFConsortium/spec_toolpath). Part of the toolpath3mf module (libzip).
#include <fmt/format.h>
#include <zip.h>

#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "toolpath_3mf_module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/version.hpp"

namespace trellis::impl {

namespace {

using namespace tp3mf;

// Integer toolpath units (Part II: coordinates are integers times unitfactor).
long long units(double mm, std::size_t layer, std::size_t path) {
  const double u = std::round(mm / kUnitFactor);
  if (!std::isfinite(u) || std::fabs(u) > std::numeric_limits<std::int32_t>::max())
    throw GeometryError(
        fmt::format("3MF toolpath: layer {} path {}: coordinate {} mm is beyond "
                    "what 32-bit toolpath units of {} mm hold",
                    layer, path, mm, kUnitFactor));
  return static_cast<long long>(u);
}

// The values one <tp:toolpathprofile> stands for (§4.1): every path with the same ones shares it.
struct ProfileKey {
  PathRole role;
  double power, speed, width, height;
  int tool;
  double temperature, flow, fan;
  std::vector<double> mixture;
  bool laser;
  auto tie() const {
    return std::tie(role, power, speed, width, height, tool, temperature, flow, fan, mixture,
                    laser);
  }
  bool operator<(const ProfileKey& o) const { return tie() < o.tie(); }
};

ProfileKey key_of(const Path& p, bool laser) {
  return {p.role,
          p.power,
          p.speed,
          p.width,
          p.height,
          p.tool,
          p.temperature,
          p.flow,
          p.fan,
          p.mixture,
          laser || p.power > 0};
}

void check_finite(const Path& p, std::size_t layer, std::size_t index) {
  for (double v : {p.power, p.speed, p.width, p.height, p.temperature, p.flow, p.fan, p.filament})
    if (!std::isfinite(v))
      throw GeometryError(
          fmt::format("3MF toolpath: layer {} path {}: a value is not finite", layer, index));
  if (p.points.size() < 2)
    throw GeometryError(fmt::format("3MF toolpath: layer {} path {}: {} point(s), a path needs 2",
                                    layer, index, p.points.size()));
}

// §4.1: standard attributes where the extension has them, ours (namespace t) for the rest.
// `set`: the laser parameter set's name (Toolpath::parameter_sets), the profile's name then and
// our t:set (read back as the set); empty: named by its role and number.
// `laser`: the laser's spot and scanner (its own when the lasers differ, else the profile's).
std::string profile_xml(const ProfileKey& k, std::size_t index, const LaserParameters* laser,
                        const std::string& set) {
  std::string out = fmt::format(
      "<tp:toolpathprofile uuid=\"{}\" name=\"{}\"", uuid_of(fmt::format("profile {}", index)),
      set.empty() ? fmt::format("{} {}", to_string(k.role), index + 1) : esc(set));
  if (!set.empty()) out += fmt::format(" t:set=\"{}\"", esc(set));
  if (k.laser) {
    out += fmt::format(" laserpower=\"{}\"", num(std::max(0.0, k.power)));
    if (k.speed > 0) out += fmt::format(" laserspeed=\"{}\"", num(k.speed));
    if (laser && laser->timing.jump_speed > 0)
      out += fmt::format(" jumpspeed=\"{}\"", num(laser->timing.jump_speed));
    if (laser && laser->spot_diameter > 0)
      out += fmt::format(" spotradius=\"{}\"", num(laser->spot_diameter / 2));
    out += fmt::format(" laserindex=\"{}\"", std::max(0, k.tool));  // §4.5: Path::tool
  } else {
    if (k.speed > 0) out += fmt::format(" depositionspeed=\"{}\"", num(k.speed));
    if (k.width > 0) out += fmt::format(" beadwidth=\"{}\"", num(k.width));
    if (k.height > 0) out += fmt::format(" beadheight=\"{}\"", num(k.height));
  }
  out += fmt::format(" t:role=\"{}\"", to_string(k.role));
  if (k.laser && k.power < 0) out += fmt::format(" t:power=\"{}\"", num(k.power));
  if (k.laser && k.width != 0) out += fmt::format(" t:width=\"{}\"", num(k.width));
  if (k.laser && k.height != 0) out += fmt::format(" t:height=\"{}\"", num(k.height));
  if (!k.laser && k.speed < 0) out += fmt::format(" t:speed=\"{}\"", num(k.speed));
  if (!k.laser && k.width < 0) out += fmt::format(" t:width=\"{}\"", num(k.width));
  if (!k.laser && k.height < 0) out += fmt::format(" t:height=\"{}\"", num(k.height));
  if (k.tool != 0 && !k.laser) out += fmt::format(" t:tool=\"{}\"", k.tool);
  if (k.temperature != 0) out += fmt::format(" t:temperature=\"{}\"", num(k.temperature));
  if (k.flow != 0) out += fmt::format(" t:flow=\"{}\"", num(k.flow));
  if (k.fan != -1) out += fmt::format(" t:fan=\"{}\"", num(k.fan));
  if (!k.mixture.empty()) {
    out += " t:mixture=\"";
    for (std::size_t i = 0; i < k.mixture.size(); ++i) {
      if (i) out += ' ';
      out += num(k.mixture[i]);
    }
    out += '"';
  }
  return out + "/>\n";
}

// §4.4, our metadata: one laser of several that differ, all its values (the profiles carry its
// power, speed, spot and jump speed as the standard has them; its delays have no attribute there).
std::string laser_xml(std::size_t index, const LaserParameters& l) {
  const ScanTiming& t = l.timing;
  return fmt::format(
      "<t:laser index=\"{}\" contourpower=\"{}\" contourspeed=\"{}\" hatchpower=\"{}\" "
      "hatchspeed=\"{}\" spotdiameter=\"{}\" jumpspeed=\"{}\" jumpdelay=\"{}\" markdelay=\"{}\" "
      "polygondelay=\"{}\" laserondelay=\"{}\" laseroffdelay=\"{}\" skywriting=\"{}\" "
      "skywritingtime=\"{}\"/>",
      index, num(l.contour_power), num(l.contour_speed), num(l.hatch_power), num(l.hatch_speed),
      num(l.spot_diameter), num(t.jump_speed), num(t.jump_delay), num(t.mark_delay),
      num(t.polygon_delay), num(t.laser_on_delay), num(t.laser_off_delay),
      t.skywriting ? "true" : "false", num(t.skywriting_time));
}

// A path that needs a segment of its own: per-path values beyond its profile.
bool has_extras(const Path& p) {
  return p.filament != 0 || p.joined || p.inside || !p.via.empty();
}

// A laser hatch vector (§1.3.3): exposed on its own, with a jump between.
bool is_hatch(const Path& p, bool laser) {
  return (laser || p.power > 0) && p.points.size() == 2 &&
         (p.role == PathRole::Hatch || p.role == PathRole::Infill);
}

struct Writer {
  const Toolpath& tp;
  const Toolpath3mfOptions& o;
  bool laser;
  bool planar = true;
  std::map<ProfileKey, std::size_t> profiles;
  std::vector<const ProfileKey*> profile_order;
  std::vector<std::string> part_uuids;  // index Path::part
  std::set<int> used_parts;             // the parts the paths name
  std::vector<LaserParameters> lasers;  // lasers that differ, by index (machine/laser.hpp)
  LaserParameters own;                  // the profile's laser

  // The laser a profile's paths are scanned by (§4.1 laserindex), for its spot and jump speed.
  const LaserParameters* laser_of(const ProfileKey& k) const {
    if (!o.laser) return nullptr;
    const auto i = static_cast<std::size_t>(std::max(0, k.tool));
    return i < lasers.size() ? &lasers[i] : &own;
  }

  std::string set_name(const ProfileKey& k) const {
    const int i = k.laser ? parameter_set_of(tp, k.role, k.power, k.speed) : -1;
    return i < 0 ? "" : tp.parameter_sets[static_cast<std::size_t>(i)].name;
  }

  void collect() {
    long long last_top = 0;
    for (std::size_t i = 0; i < tp.layers.size(); ++i) {
      const Layer& L = tp.layers[i];
      const long long top = units(L.z, i, 0);
      if (top < last_top || top < 0) planar = false;  // §4.3: ztop never decreases, from 0
      last_top = top;
      for (std::size_t j = 0; j < L.paths.size(); ++j) {
        const Path& p = L.paths[j];
        check_finite(p, i, j);
        if (p.part < 0 || p.part > static_cast<int>(tp.part_labels.size()))
          throw GeometryError(fmt::format("3MF toolpath: layer {} path {}: part {} of {}", i, j,
                                          p.part, tp.part_labels.size()));
        used_parts.insert(p.part);
        for (const Vec3& q : p.points) {
          const long long x = units(q.x, i, j), y = units(q.y, i, j), z = units(q.z, i, j);
          (void)x, (void)y;
          if (z != top) planar = false;
        }
        for (const Vec3& q : p.via) units(q.x, i, j), units(q.y, i, j), units(q.z, i, j);
        const auto [it, fresh] = profiles.emplace(key_of(p, laser), profiles.size());
        if (fresh) profile_order.push_back(&it->first);
      }
    }
    // Parts (Part II §1.1.1): the build item's UUID where there is one.
    part_uuids.push_back(uuid_of("build item"));
    for (const auto& label : tp.part_labels) part_uuids.push_back(uuid_of("part " + label));
  }

  void point(std::string& out, const Vec3& q, std::size_t i, std::size_t j) const {
    if (planar)
      fmt::format_to(std::back_inserter(out), "<point x=\"{}\" y=\"{}\"/>", units(q.x, i, j),
                     units(q.y, i, j));
    else
      fmt::format_to(std::back_inserter(out), "<point3d x=\"{}\" y=\"{}\" z=\"{}\"/>",
                     units(q.x, i, j), units(q.y, i, j), units(q.z, i, j));
  }

  void segment_head(std::string& out, const char* type, std::size_t profile, const Path& p) const {
    fmt::format_to(std::back_inserter(out), "<segment type=\"{}\" profileid=\"{}\" partid=\"{}\"",
                   type, profile + 1, p.part + 1);
    if (p.filament != 0) out += fmt::format(" t:filament=\"{}\"", num(p.filament));
    if (p.joined) out += " t:joined=\"1\"";
    if (p.inside) out += " t:inside=\"1\"";
    out += '>';
  }

  void vias(std::string& out, const Path& p, std::size_t i, std::size_t j) const {
    for (const Vec3& q : p.via)
      fmt::format_to(std::back_inserter(out), "<t:via x=\"{}\" y=\"{}\" z=\"{}\"/>",
                     units(q.x, i, j), units(q.y, i, j), units(q.z, i, j));
  }

  // Part II, Chapter 1: one layer part.
  std::string layer_xml(std::size_t i) const {
    const Layer& L = tp.layers[i];
    std::set<int> parts;
    std::set<std::size_t> used;
    std::vector<std::size_t> profile_of(L.paths.size());
    for (std::size_t j = 0; j < L.paths.size(); ++j) {
      parts.insert(L.paths[j].part);
      profile_of[j] = profiles.at(key_of(L.paths[j], laser));
      used.insert(profile_of[j]);
    }
    std::string out = fmt::format(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<layer xmlns=\"{}\" xmlns:t=\"{}\">\n",
        kNamespace, kTrellis);
    out += "<parts>";
    for (int part : parts)
      out += fmt::format("<part id=\"{}\" uuid=\"{}\"/>", part + 1, part_uuids[part]);
    out += "</parts>\n<profiles>";
    for (std::size_t k : used)
      out += fmt::format("<profile id=\"{}\" uuid=\"{}\"/>", k + 1,
                         uuid_of(fmt::format("profile {}", k)));
    out += "</profiles>\n<segments>\n";
    // Execution order is document order (Part II): segments follow the paths one by one, except
    // that a run of plain hatch vectors of one profile and part is one hatch segment (§1.3.3).
    for (std::size_t j = 0; j < L.paths.size();) {
      const Path& p = L.paths[j];
      if (is_hatch(p, laser)) {
        segment_head(out, "hatch", profile_of[j], p);
        vias(out, p, i, j);
        std::size_t k = j;
        do {
          const Path& h = L.paths[k];
          fmt::format_to(std::back_inserter(out),
                         "<hatch x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\"/>",
                         units(h.points[0].x, i, k), units(h.points[0].y, i, k),
                         units(h.points[1].x, i, k), units(h.points[1].y, i, k));
          ++k;
        } while (!has_extras(p) && k < L.paths.size() && is_hatch(L.paths[k], laser) &&
                 !has_extras(L.paths[k]) && profile_of[k] == profile_of[j] &&
                 L.paths[k].part == p.part);
        out += "</segment>\n";
        j = k;
        continue;
      }
      // §1.3.2: a closed polyline is a loop, its first vertex not repeated; §1.4.1: 3-axis paths
      // are open polylines only.
      const Vec3& a = p.points.front();
      const Vec3& b = p.points.back();
      const bool loop = planar && p.points.size() >= 4 && units(a.x, i, j) == units(b.x, i, j) &&
                        units(a.y, i, j) == units(b.y, i, j);
      segment_head(out, loop ? "loop" : planar ? "polyline" : "polyline3d", profile_of[j], p);
      vias(out, p, i, j);
      const std::size_t n = loop ? p.points.size() - 1 : p.points.size();
      for (std::size_t k = 0; k < n; ++k) point(out, p.points[k], i, j);
      out += "</segment>\n";
      ++j;
    }
    out += "</segments>\n</layer>\n";
    return out;
  }

  static std::string layer_path(std::size_t i) {
    return fmt::format("/Toolpath/Layers/layer{:05}.xml", i + 1);
  }

  // Part I, Chapter 4: the model part with the toolpath resource (and the mesh, if any).
  std::string model_xml() const {
    // Beam Lattice Chapter 1: a producer using it marks "b" required.
    const Geometry3mf geometry = geometry_xml(tp, o, part_uuids, used_parts);
    std::string out = fmt::format(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<model unit=\"millimeter\" xml:lang=\"en-US\" xmlns=\"{}\" xmlns:p=\"{}\" xmlns:tp=\"{}\" "
        "xmlns:t=\"{}\"{} requiredextensions=\"p tp{}\">\n"
        "<metadata name=\"Application\">Trellis {}</metadata>\n<resources>\n",
        kCore, kProduction, kNamespace, kTrellis,
        geometry.beams ? fmt::format(" xmlns:b=\"{}\"", kBeamLattice) : "",
        geometry.beams ? " b" : "", TRELLIS_VERSION);
    out += fmt::format(
        "<tp:toolpathresource id=\"1\" uuid=\"{}\" unitfactor=\"{}\" "
        "toolpathtype=\"{}\">\n",
        uuid_of("toolpath"), num(kUnitFactor), planar ? "planar" : "3axis");
    if (laser && o.laser) {
      // §4.5: a laser source per laser (Path::tool), its field the profile's or the build
      // plate; SHOULD come first.
      const LaserProfile& l = *o.laser;
      int lasers = std::max(1, l.lasers);
      for (const auto& L : tp.layers)
        for (const auto& p : L.paths) lasers = std::max(lasers, p.tool + 1);
      const std::string name = l.name.empty() ? "laser" : l.name;
      out += "<tp:lasersources default=\"0\">";
      for (int i = 0; i < lasers; ++i) {
        out += fmt::format("<tp:lasersource index=\"{}\" name=\"{}\"", i,
                           esc(lasers > 1 ? fmt::format("{} laser {}", name, i + 1) : name));
        const std::size_t f = 4 * static_cast<std::size_t>(i);
        if (f + 4 <= l.fields.size())
          out += fmt::format(" minx=\"{}\" maxx=\"{}\" miny=\"{}\" maxy=\"{}\"",
                             units(l.fields[f], 0, 0), units(l.fields[f + 2], 0, 0),
                             units(l.fields[f + 1], 0, 0), units(l.fields[f + 3], 0, 0));
        else if (l.build_x > 0 && l.build_y > 0)
          out += fmt::format(" minx=\"0\" maxx=\"{}\" miny=\"0\" maxy=\"{}\"",
                             units(l.build_x, 0, 0), units(l.build_y, 0, 0));
        out += "/>";
      }
      out += "</tp:lasersources>\n";
    }
    out += "<tp:toolpathprofiles>\n";
    for (std::size_t k = 0; k < profile_order.size(); ++k)
      out += profile_xml(*profile_order[k], k, laser_of(*profile_order[k]),
                         set_name(*profile_order[k]));
    out += "</tp:toolpathprofiles>\n<tp:toolpathlayers>\n";
    for (std::size_t i = 0; i < tp.layers.size(); ++i) {
      // §4.3: ztop only for planar toolpaths; the nominal height of 3-axis layers is ours.
      if (planar)
        out += fmt::format("<tp:toolpathlayer ztop=\"{}\" path=\"{}\"/>\n",
                           units(tp.layers[i].z, i, 0), layer_path(i));
      else
        out += fmt::format("<tp:toolpathlayer path=\"{}\" t:z=\"{}\"/>\n", layer_path(i),
                           num(tp.layers[i].z));
    }
    out += "</tp:toolpathlayers>\n";
    // §4.4: metadata in our namespace — what made the file, the job, the plate's part labels.
    out += fmt::format("<tp:toolpathdata><t:trellis source=\"{}\">", esc(tp.source));
    if (!tp.job.empty()) {
      out += "<t:job>";
      escape_to(out, tp.job, true);
      out += "</t:job>";
    }
    for (std::size_t k = 0; k < tp.part_labels.size(); ++k)
      out += fmt::format("<t:part id=\"{}\" uuid=\"{}\" label=\"{}\"/>", k + 2, part_uuids[k + 1],
                         esc(tp.part_labels[k]));
    for (std::size_t i = 0; i < lasers.size(); ++i) out += laser_xml(i, lasers[i]);
    out += "</t:trellis></tp:toolpathdata>\n</tp:toolpathresource>\n";
    out += geometry.objects;
    out += fmt::format("</resources>\n<build p:UUID=\"{}\" tp:toolpathid=\"1\">", uuid_of("build"));
    out += geometry.items;
    out += "</build>\n</model>\n";
    return out;
  }

  std::string model_rels() const {
    std::string out =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<Relationships "
        "xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\n";
    // §3.2: one relationship per layer part, from the model part.
    for (std::size_t i = 0; i < tp.layers.size(); ++i)
      out += fmt::format("<Relationship Id=\"layer{}\" Type=\"{}\" Target=\"{}\"/>\n", i + 1,
                         kLayerRelationship, layer_path(i));
    return out + "</Relationships>\n";
  }
};

const char* kContentTypes =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">\n"
    "<Default Extension=\"rels\" "
    "ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>\n"
    "<Default Extension=\"model\" "
    "ContentType=\"application/vnd.ms-package.3dmanufacturing-3dmodel+xml\"/>\n"
    "<Default Extension=\"xml\" ContentType=\"application/xml\"/>\n"
    "</Types>\n";

const char* kRootRels =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\n"
    "<Relationship Id=\"rel0\" Target=\"/3D/3dmodel.model\" "
    "Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel\"/>\n"
    "</Relationships>\n";

// An OPC package (a ZIP) made in memory, its entries deflated and dated 1980 so that the same
// parts make the same bytes.
class Package {
 public:
  Package() {
    zip_error_init(&error_);
    source_ = zip_source_buffer_create(nullptr, 0, 0, &error_);
    if (!source_) fail("cannot make a ZIP buffer");
    zip_source_keep(source_);
    zip_ = zip_open_from_source(source_, ZIP_TRUNCATE, &error_);
    if (!zip_) fail("cannot open a ZIP buffer");
  }
  ~Package() {
    if (zip_) zip_discard(zip_);
    if (source_) zip_source_free(source_);
    zip_error_fini(&error_);
  }
  void add(const std::string& name, std::string data) {
    parts_.push_back(std::move(data));
    const std::string& d = parts_.back();
    zip_source_t* s = zip_source_buffer(zip_, d.data(), d.size(), 0);
    if (!s) fail("cannot add " + name);
    const zip_int64_t i = zip_file_add(zip_, name.c_str(), s, ZIP_FL_ENC_UTF_8);
    if (i < 0) {
      zip_source_free(s);
      fail("cannot add " + name);
    }
    zip_set_file_compression(zip_, static_cast<zip_uint64_t>(i), ZIP_CM_DEFLATE, 6);
    zip_file_set_mtime(zip_, static_cast<zip_uint64_t>(i), 315619200, 0);  // 1980-01-02
  }
  std::string bytes() {
    if (zip_close(zip_) != 0) fail("cannot write the ZIP");
    zip_ = nullptr;
    std::string out;
    if (zip_source_open(source_) != 0) fail("cannot read the ZIP back");
    zip_source_seek(source_, 0, SEEK_END);
    const zip_int64_t n = zip_source_tell(source_);
    zip_source_seek(source_, 0, SEEK_SET);
    out.resize(static_cast<std::size_t>(std::max<zip_int64_t>(n, 0)));
    if (n > 0 && zip_source_read(source_, out.data(), static_cast<zip_uint64_t>(n)) != n)
      fail("cannot read the ZIP back");
    zip_source_close(source_);
    return out;
  }

 private:
  [[noreturn]] void fail(const std::string& what) {
    throw IoError("3MF toolpath: " + what + " (libzip: " + zip_error_strerror(&error_) + ")");
  }
  zip_error_t error_;
  zip_source_t* source_ = nullptr;
  zip_t* zip_ = nullptr;
  std::deque<std::string> parts_;  // alive until the ZIP is closed
};

}  // namespace

std::string write_toolpath_3mf(const Toolpath& toolpath, const Toolpath3mfOptions& options) {
  Writer w{toolpath, options, options.laser != nullptr};
  w.lasers = declared_lasers(options.laser, toolpath);
  if (options.laser) w.own = profile_laser(*options.laser);
  w.collect();
  Package pkg;
  pkg.add("[Content_Types].xml", kContentTypes);
  pkg.add("_rels/.rels", kRootRels);
  pkg.add("3D/3dmodel.model", w.model_xml());
  pkg.add("3D/_rels/3dmodel.model.rels", w.model_rels());
  for (std::size_t i = 0; i < toolpath.layers.size(); ++i)
    pkg.add(Writer::layer_path(i).substr(1), w.layer_xml(i));
  return pkg.bytes();
}

}  // namespace trellis::impl
