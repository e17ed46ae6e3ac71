// A layer part of the Toolpath Extension v1.0 (Part II; section numbers are the
// specification's) → the IR layer: segments in document order, profiles and parts resolved
// through the layer's own tables, constant modifiers applied. Part of the toolpath3mf module.
#include "toolpath_3mf_read.hpp"

namespace trellis::impl::tp3mf_read {

namespace {

class LayerReader {
 public:
  LayerReader(const Resource& r, double mm, std::set<long long>& lasers)
      : r_(r), scale_(r.unitfactor * mm), lasers_(lasers) {}

  Layer read(const std::string& file, const std::string& part, const std::string& bytes, double z) {
    layer_.z = z;
    XmlPart(file, part)
        .parse(
            bytes, [&](Name n, Attrs a) { return start(n, a); }, [&](Name n) { return end(n); });
    return std::move(layer_);
  }

 private:
  std::string start(Name n, Attrs a) {
    if (n.uri == kTrellis && n.local == "via" && in_segment_) {
      Vec3 q;
      if (!coord(a, "x", q.x) || !coord(a, "y", q.y) || !coord(a, "z", q.z))
        return "<t:via> needs integer x, y and z";
      base_.via.push_back(q);
      return "";
    }
    if (!is_tp(n.uri)) return "";
    if (n.local == "part") {
      long long id = 0;
      const char* uuid = a.get("uuid");
      if (!to_long(a.get("id"), id) || !uuid) return "a <part> without id or uuid (§1.1.1)";
      const auto it = r_.part_of_uuid.find(uuid);
      parts_[id] = it == r_.part_of_uuid.end() ? 0 : it->second;
      return "";
    }
    if (n.local == "profile") {
      long long id = 0;
      const char* uuid = a.get("uuid");
      if (!to_long(a.get("id"), id) || !uuid) return "a <profile> without id or uuid (§1.1.2)";
      for (std::size_t k = 0; k < r_.profiles.size(); ++k)
        if (r_.profiles[k].uuid == uuid) {
          profiles_[id] = k;
          return "";
        }
      return fmt::format(
          "<profile id=\"{}\"> names uuid {}, which no <tp:toolpathprofile> of the "
          "resource has (§1.1.2)",
          id, uuid);
    }
    if (n.local == "segment") return segment(a);
    if (n.local == "point" || n.local == "point3d" || n.local == "hatch" || n.local == "point6d")
      return element(n.local, a);
    if (n.local == "sub")
      return "a <sub> support point: nonlinear modifiers are not applied by Trellis (§4.2)";
    return "";
  }

  std::string end(Name n) {
    if (!is_tp(n.uri) || n.local != "segment") return "";
    in_segment_ = false;
    const std::size_t need = type_ == "loop" ? 3 : type_ == "hatch" ? 1 : 2;
    if (count_ < need)
      return fmt::format("a {} segment with {} {}; it needs at least {} (§1.3, §1.4)", type_,
                         count_, type_ == "hatch" ? "hatches" : "points", need);
    if (type_ == "loop") {
      Path& last = layer_.paths.back();
      // §1.3.2: the closing line back to the first point is implied (a repeated first point is
      // redundant); it carries the first point's factors, so it joins the first piece's values.
      const Vec3 first = layer_.paths[first_path_].points.front();
      if (distance(last.points.back(), first) > 0) {
        if (close_value_ == piece_value_) {
          last.points.push_back(first);
        } else {
          Path closing = base_;
          apply(closing, close_value_);
          closing.joined = true;
          closing.points = {last.points.back(), first};
          closing.via.clear();
          layer_.paths.push_back(std::move(closing));
        }
      }
    }
    return "";
  }

  bool coord(Attrs a, const char* key, double& v) const {
    long long n = 0;
    if (!to_long(a.get(key), n)) return false;
    v = static_cast<double>(n) * scale_;
    return true;
  }

  std::string segment(Attrs a) {
    const char* type = a.get("type");
    type_ = type ? type : "";
    long long profile = 0, part = 0;
    if (!to_long(a.get("profileid"), profile) || !to_long(a.get("partid"), part))
      return "a <segment> needs profileid and partid (§1.2)";
    const auto pr = profiles_.find(profile);
    if (pr == profiles_.end())
      return fmt::format("segment profileid {} is not declared in the layer's <profiles> (§1.1.2)",
                         profile);
    const auto pa = parts_.find(part);
    if (pa == parts_.end())
      return fmt::format("segment partid {} is not declared in the layer's <parts> (§1.1.1)", part);
    const bool planar = type_ == "loop" || type_ == "polyline" || type_ == "hatch";
    if (!planar && type_ != "polyline3d" && type_ != "polyline6d")
      return fmt::format(
          "segment type '{}' (loop, polyline, hatch, polyline3d or polyline6d; §1.2 "
          "asks a consumer to refuse the layer)",
          type_);
    if (type_ == "polyline6d")
      return "a 6-axis segment: the toolpath IR has no tool orientation, Trellis does not read "
             "6-axis toolpaths (§1.4.2)";
    if (planar != (r_.type == "planar"))
      return fmt::format("a {} segment in a toolpath of type {} (§1.3, §1.4)", type_, r_.type);
    profile_ = &r_.profiles[pr->second];
    // §4.5: segment laserindex, else the profile's, else the lasersources default.
    std::optional<long long> laser = profile_->laser_index;
    long long li = 0;
    if (const char* s = a.get("laserindex")) {
      if (!to_long(s, li) || li < 0) return fmt::format("laserindex=\"{}\"", s);
      laser = li;
    }
    if (!laser) laser = r_.default_laser;
    if (laser && r_.has_lasers && !r_.lasers.count(*laser))
      return fmt::format("laser index {} is not declared in <tp:lasersources> (§4.5)", *laser);
    if (laser) lasers_.insert(*laser);
    base_ = profile_->values;
    if (profile_->laser && laser) base_.tool = static_cast<int>(*laser);  // the laser is the tool
    if (!profile_->has_role)
      base_.role = type_ == "hatch"  ? PathRole::Hatch
                   : profile_->laser ? PathRole::Contour
                   : planar          ? PathRole::Other
                                     : PathRole::Nonplanar;
    base_.part = pa->second;
    double d = 0;
    if (to_double(a.get("filament", kTrellis), d)) base_.filament = d;
    if (const char* s = a.get("joined", kTrellis)) base_.joined = std::string(s) == "1";
    if (const char* s = a.get("inside", kTrellis)) base_.inside = std::string(s) == "1";
    in_segment_ = true;
    count_ = 0;
    first_path_ = layer_.paths.size();
    return "";
  }

  // The modifier factors on an element (§4.2, Part II §1.2.1): the values they set.
  using Values = std::map<std::string, double>;
  std::string factors(Attrs a, Values& v) const {
    for (char f : std::string("efgh")) {
      const std::string one(1, f);
      const char* s = a.get(one);
      if (!s && (a.get(one + "1") || a.get(one + "2")))
        return fmt::format("a linear factor {}1/{}2: the profile's modifiers are constant (§4.2)",
                           f, f);
      if (!s) continue;
      double x = 0;
      if (!to_double(s, x) || x < 0 || x > 1) return fmt::format("factor {}=\"{}\" (0..1)", f, s);
      const auto m = profile_->modifiers.find(f);
      if (m == profile_->modifiers.end())
        return fmt::format(
            "factor {} on a segment of profile '{}', which declares no modifier {} "
            "(§4.2)",
            f, profile_->name, f);
      v[m->second.attribute] = m->second.min + x * (m->second.max - m->second.min);
    }
    return "";
  }

  static void apply(Path& p, const Values& v) {
    for (const auto& [attribute, x] : v) {
      if (attribute == "laserpower") p.power = x;
      if (attribute == "laserspeed" || attribute == "depositionspeed") p.speed = x;
      if (attribute == "beadwidth") p.width = x;
      if (attribute == "beadheight") p.height = x;
    }
  }

  std::string element(std::string_view name, Attrs a) {
    if (!in_segment_) return fmt::format("a <{}> outside a segment", name);
    Values v;
    if (std::string bad = factors(a, v); !bad.empty()) return bad;
    if (name == "hatch") {
      if (type_ != "hatch") return fmt::format("a <hatch> in a {} segment (§1.2.1)", type_);
      Path p = base_;
      apply(p, v);
      Vec3 s{0, 0, layer_.z}, e{0, 0, layer_.z};
      if (!coord(a, "x1", s.x) || !coord(a, "y1", s.y) || !coord(a, "x2", e.x) ||
          !coord(a, "y2", e.y))
        return "a <hatch> needs integer x1, y1, x2 and y2 (§1.2.1)";
      p.points = {s, e};
      if (count_ > 0) p.via.clear(), p.joined = false, p.filament = 0, p.inside = false;
      layer_.paths.push_back(std::move(p));
      ++count_;
      return "";
    }
    const bool three = name == "point3d";
    if (type_ == "hatch" || three != (type_ == "polyline3d"))
      return fmt::format("a <{}> in a {} segment (§1.2.1)", name, type_);
    Vec3 q{0, 0, layer_.z};
    if (!coord(a, "x", q.x) || !coord(a, "y", q.y) || (three && !coord(a, "z", q.z)))
      return fmt::format("a <{}> needs integer x, y{} (§1.2.1)", name, three ? " and z" : "");
    // Each point after the first closes the line into it and carries that line's factors; a
    // change of value along the chain starts a new path joined to the previous one.
    if (count_ == 0) {
      close_value_ = v;
      piece_value_ = v;
      Path p = base_;
      apply(p, v);
      p.points = {q};
      layer_.paths.push_back(std::move(p));
    } else if (count_ == 1 || v == piece_value_) {
      if (count_ == 1 && v != piece_value_) {
        piece_value_ = v;
        apply(layer_.paths.back(), v);
      }
      layer_.paths.back().points.push_back(q);
    } else {
      Path p = base_;
      apply(p, v);
      p.joined = true;
      p.via.clear();
      p.points = {layer_.paths.back().points.back(), q};
      piece_value_ = v;
      layer_.paths.push_back(std::move(p));
    }
    ++count_;
    return "";
  }

  const Resource& r_;
  double scale_;
  std::set<long long>& lasers_;
  Layer layer_;
  std::map<long long, int> parts_;
  std::map<long long, std::size_t> profiles_;
  const Profile* profile_ = nullptr;
  Path base_;
  std::string type_;
  bool in_segment_ = false;
  std::size_t count_ = 0, first_path_ = 0;
  Values close_value_, piece_value_;
};

}  // namespace

Layer read_layer_part(const Resource& resource, double mm, const std::string& file,
                      const std::string& part, const std::string& bytes, double z,
                      std::set<long long>& lasers) {
  return LayerReader(resource, mm, lasers).read(file, part, bytes, z);
}

}  // namespace trellis::impl::tp3mf_read
