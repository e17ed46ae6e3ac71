#include "trellis/slice/fgm.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "trellis/core/error.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/geom/regions.hpp"

namespace trellis {

int Palette::color_of(double f) const {
  return std::clamp(static_cast<int>(std::floor(f * colors)), 0, colors - 1);
}

namespace {

// The first material's fraction on one layer's grid, evaluated once per node (every band-edge
// contour samples the same nodes); points off the grid (root refinement) are evaluated directly.
class FractionGrid {
 public:
  FractionGrid(Evaluator& ev, double z, Vec2 lo, Vec2 hi, double res)
      : ev_(ev), z_(z), lo_(lo), res_(res) {
    nx_ = static_cast<std::size_t>(std::ceil((hi.x - lo.x) / res)) + 1;
    ny_ = static_cast<std::size_t>(std::ceil((hi.y - lo.y) / res)) + 1;
    values_.resize(nx_ * ny_);
    for (std::size_t j = 0; j < ny_; ++j)
      for (std::size_t i = 0; i < nx_; ++i)
        values_[j * nx_ + i] = eval({lo.x + static_cast<double>(i) * res, lo.y + static_cast<double>(j) * res});
  }
  double at(Vec2 p) {
    std::size_t i, j;
    if (node(p, i, j)) return values_[j * nx_ + i];
    return eval(p);
  }
  // Range of the node values in [a, b] (grid nodes only: what marching squares sees).
  Interval range(Vec2 a, Vec2 b) const {
    const auto i0 = static_cast<std::size_t>(std::max(0.0, std::floor((a.x - lo_.x) / res_ - 1e-9)));
    const auto j0 = static_cast<std::size_t>(std::max(0.0, std::floor((a.y - lo_.y) / res_ - 1e-9)));
    const auto i1 = std::min(nx_ - 1, static_cast<std::size_t>(std::max(0.0, std::ceil((b.x - lo_.x) / res_ + 1e-9))));
    const auto j1 = std::min(ny_ - 1, static_cast<std::size_t>(std::max(0.0, std::ceil((b.y - lo_.y) / res_ + 1e-9))));
    Interval r{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (std::size_t j = j0; j <= j1; ++j)
      for (std::size_t i = i0; i <= i1; ++i) {
        const double v = values_[j * nx_ + i];
        r.lo = std::min(r.lo, v);
        r.hi = std::max(r.hi, v);
      }
    return r;
  }

 private:
  bool node(Vec2 p, std::size_t& i, std::size_t& j) const {
    const double fx = (p.x - lo_.x) / res_, fy = (p.y - lo_.y) / res_;
    const double ix = std::floor(fx + 0.5), iy = std::floor(fy + 0.5);
    if (std::abs(fx - ix) > 1e-9 || std::abs(fy - iy) > 1e-9 || ix < 0 || iy < 0) return false;
    i = static_cast<std::size_t>(ix);
    j = static_cast<std::size_t>(iy);
    return i < nx_ && j < ny_;
  }
  double eval(Vec2 p) {
    const auto f = ev_.fractions({p.x, p.y, z_});
    return f.empty() ? 0.0 : f[0];
  }
  Evaluator& ev_;
  double z_;
  Vec2 lo_;
  double res_;
  std::size_t nx_ = 0, ny_ = 0;
  std::vector<double> values_;
};

// max(f - level, distance outside the box): its zero set closes along the box. Blocks whose
// nodes are all on one side of the level are skipped by the contouring.
class BelowLevel : public PlaneFunction {
 public:
  BelowLevel(FractionGrid& grid, double level, Vec2 lo, Vec2 hi)
      : grid_(grid), level_(level), lo_(lo), hi_(hi) {}
  void sample(const Vec2* p, double* out, std::size_t n) override {
    for (std::size_t i = 0; i < n; ++i) {
      const double box = std::max({lo_.x - p[i].x, p[i].x - hi_.x, lo_.y - p[i].y, p[i].y - hi_.y});
      out[i] = std::max(grid_.at(p[i]) - level_, box);
    }
  }
  Interval bound(Vec2 a, Vec2 b) override {
    // The box term's range over the rectangle, and the nodes' fraction range.
    const double box_lo = std::max({lo_.x - b.x, a.x - hi_.x, lo_.y - b.y, a.y - hi_.y});
    const double box_hi = std::max({lo_.x - a.x, b.x - hi_.x, lo_.y - a.y, b.y - hi_.y});
    const Interval f = grid_.range(a, b);
    return {std::max(f.lo - level_, box_lo), std::max(f.hi - level_, box_hi)};
  }

 private:
  FractionGrid& grid_;
  double level_;
  Vec2 lo_, hi_;
};

BBox3 bbox_of(const Regions& r) {
  BBox3 b;
  for (const auto& p : r)
    for (const Vec2 q : p.outer) b.add({q.x, q.y, 0});
  return b;
}

}  // namespace

std::vector<Regions> level_slabs(const Field& field, Evaluator& ev, double z,
                                 const Regions& outline, const std::vector<double>& levels,
                                 double resolution) {
  if (field.materials().size() < 2)
    throw GeometryError("gradient slicing needs a design with two materials (an fgrade node)");
  std::vector<Regions> slabs(levels.size() + 1);
  const BBox3 b = bbox_of(outline);
  if (b.empty()) return slabs;
  const Vec2 lo{b.min.x - resolution, b.min.y - resolution};
  const Vec2 hi{b.max.x + resolution, b.max.y + resolution};
  const Vec2 glo{lo.x - 2 * resolution, lo.y - 2 * resolution};
  const Vec2 ghi{hi.x + 2 * resolution, hi.y + 2 * resolution};
  FractionGrid grid(ev, z, glo, ghi, resolution);
  MarchOptions mo;
  mo.resolution = resolution;
  Regions previous;  // the outline where f <= the previous level
  for (std::size_t k = 0; k <= levels.size(); ++k) {
    Regions below;
    if (k < levels.size()) {
      BelowLevel f(grid, levels[k], lo, hi);
      const ContourSet cs = march_squares(f, glo, ghi, 0.0, mo);
      below = intersection(outline, nest_oriented_rings(cs.lines.loops));
    } else {
      below = outline;
    }
    slabs[k] = k == 0 ? below : difference(below, previous);
    previous = std::move(below);
  }
  return slabs;
}

std::vector<ColorFace> color_faces(const Field& field, Evaluator& ev, double z,
                                   const Regions& outline, const Palette& palette,
                                   double resolution) {
  if (palette.colors < 1 || palette.colors > 1000)
    throw SettingError("the palette needs 1 to 1000 colours");
  std::vector<double> levels;
  for (int k = 1; k < palette.colors; ++k) levels.push_back(k * palette.band());
  auto slabs = level_slabs(field, ev, z, outline, levels, resolution);
  std::vector<ColorFace> faces;
  for (std::size_t k = 0; k < slabs.size(); ++k)
    if (!slabs[k].empty()) faces.push_back({static_cast<int>(k), std::move(slabs[k])});
  return faces;
}

Toolpath plan_fgm_strategy2(const Field& field, const std::vector<LayerOutline>& layers,
                            const FgmOptions& o, FgmStats* stats) {
  if (!(o.bead_width > 0) || !(o.resolution > 0))
    throw SettingError("bead width and resolution must be positive");
  // Layers are independent: planned in parallel (oneTBB), one evaluator per thread, each
  // layer's paths paired with their colours.
  struct Planned {
    Layer layer;
    std::vector<int> colors;
    std::size_t faces = 0;
  };
  std::vector<Planned> planned(layers.size());
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::parallel_for(std::size_t{0}, layers.size(), [&](std::size_t li) {
    Evaluator& ev = evaluators.local();
    const LayerOutline& lo = layers[li];
    Planned& out = planned[li];
    Layer& layer = out.layer;
    // As the planar slicer: the nozzle at the top of layer i, counted from the bed.
    layer.z = static_cast<double>(li + 1) * o.layer_height;
    // Material iso-lines on their own grid (half a bead at the finest: a face narrower than
    // that cannot be printed); crossings are refined on the field.
    auto faces = color_faces(field, ev, lo.z, lo.regions, o.palette,
                             std::max(o.material_resolution, o.bead_width / 2));
    out.faces = faces.size();
    // Palette order, reversed every other layer so a layer starts where the last one ended.
    if (li % 2 == 1) std::reverse(faces.begin(), faces.end());
    const double angle = o.angle_deg + (li % 2 ? 90.0 : 0.0);
    Vec2 cursor{0, 0};
    for (const auto& face : faces) {
      const double m = o.palette.mid(face.color);
      // One ring half a bead inside the face (its bead reaches the face's edge, not beyond),
      // then concentric rings, or 100 % rectilinear lines inside the ring.
      Regions inner = offset(face.region, -o.bead_width / 2);
      std::vector<std::vector<Vec2>> lines;
      auto add_rings = [&](const Regions& r) {
        for (auto ring : rings_of(r)) {
          if (ring.size() < 2) continue;
          ring.push_back(ring.front());
          lines.push_back(std::move(ring));
        }
      };
      if (o.concentric) {
        for (Regions r = inner; !r.empty(); r = offset(r, -o.bead_width)) add_rings(r);
      } else {
        add_rings(inner);
        for (auto& run : fill_lines(offset(face.region, -o.bead_width), angle, o.bead_width,
                                    o.bead_width, 0.05, true, cursor))
          lines.push_back(std::move(run));
      }
      for (auto& line : lines) {
        if (line.size() < 2) continue;
        Path p;
        p.role = PathRole::Infill;
        p.mixture = {m, 1 - m};
        p.width = o.bead_width;
        p.height = o.layer_height;
        for (const Vec2 q : line) p.points.push_back({q.x, q.y, layer.z});
        if (p.length() <= 0) continue;
        layer.paths.push_back(std::move(p));
        out.colors.push_back(face.color);
      }
    }
  });
  Toolpath tp;
  FgmStats st;
  st.shortest_path = std::numeric_limits<double>::infinity();
  int last_color = -1;
  for (auto& pl : planned) {
    st.faces += pl.faces;
    for (std::size_t i = 0; i < pl.layer.paths.size(); ++i) {
      st.shortest_path = std::min(st.shortest_path, pl.layer.paths[i].length());
      if (pl.colors[i] != last_color && last_color >= 0) ++st.colour_changes;
      last_color = pl.colors[i];
      ++st.paths;
    }
    if (!pl.layer.paths.empty()) tp.layers.push_back(std::move(pl.layer));
  }
  if (st.paths == 0) st.shortest_path = 0;
  if (stats) *stats = st;
  return tp;
}

void measure_gradient_error(const Field& field, const Toolpath& tp,
                            const std::vector<LayerOutline>& layers, double h, FgmStats& st) {
  struct Acc {
    double sum = 0, max = 0;
    std::size_t n = 0;
  };
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::enumerable_thread_specific<Acc> acc;
  tbb::parallel_for(std::size_t{0}, tp.layers.size(), [&](std::size_t li) {
    const Layer& l = tp.layers[li];
    const auto idx = static_cast<std::size_t>(std::llround(l.z / h)) - 1;
    if (idx >= layers.size()) return;
    Evaluator& ev = evaluators.local();
    Acc& a = acc.local();
    for (const auto& p : l.paths) {
      if (p.mixture.empty() || p.role == PathRole::Other) continue;
      for (const auto& q : p.points) {
        const auto f = ev.fractions({q.x, q.y, layers[idx].z});
        if (f.empty()) continue;
        const double e = std::abs(std::clamp(f[0], 0.0, 1.0) - p.mixture[0]);
        a.sum += e;
        a.max = std::max(a.max, e);
        ++a.n;
      }
    }
  });
  double sum = 0;
  st.error_max = 0;
  st.error_samples = 0;
  for (const auto& a : acc) {
    sum += a.sum;
    st.error_max = std::max(st.error_max, a.max);
    st.error_samples += a.n;
  }
  st.error_mean = st.error_samples ? sum / static_cast<double>(st.error_samples) : 0;
}

double purge_length(double volume, double h, double w) {
  const double area = h * (w - h) + 3.14159265358979323846 * h * h / 4;
  return area > 0 ? volume / area : 0;
}

namespace {

// A square zig-zag of about `length` mm centred at c (lines `spacing` apart; the square grows
// with the length needed).
std::vector<Vec2> purge_block(Vec2 c, double side, double spacing, double length) {
  std::vector<Vec2> pts;
  const int lines = std::max(2, static_cast<int>(std::ceil(length / side)));
  const double span = std::min(side, spacing * (lines - 1));
  for (int i = 0; i < lines; ++i) {
    const double y = c.y - span / 2 + (lines > 1 ? span * i / (lines - 1) : 0);
    const double x0 = c.x - side / 2, x1 = c.x + side / 2;
    if (i % 2 == 0) {
      pts.push_back({x0, y});
      pts.push_back({x1, y});
    } else {
      pts.push_back({x1, y});
      pts.push_back({x0, y});
    }
  }
  return pts;
}

}  // namespace

Toolpath plan_fgm_strategy1(const Field& field, const std::vector<LayerOutline>& layers,
                            const Toolpath& planar, const FgmOptions& o, const PurgeOptions& purge,
                            FgmStats* stats) {
  if (!(o.bead_width > 0) || !(o.layer_height > 0))
    throw SettingError("bead width and layer height must be positive");
  if (!(o.zipper >= 0) || o.zipper >= o.palette.band())
    throw SettingError("the zipper overlap must be in [0, one colour band) of the gradient");
  struct Piece {
    Path path;
    int color;
  };
  std::vector<std::vector<Piece>> per(planar.layers.size());
  std::vector<std::size_t> faces_per(planar.layers.size(), 0);
  tbb::enumerable_thread_specific<Evaluator> evaluators([&] { return Evaluator(field); });
  tbb::parallel_for(std::size_t{0}, planar.layers.size(), [&](std::size_t li) {
    Evaluator& ev = evaluators.local();
    const Layer& pl = planar.layers[li];
    // The outline this layer was planned from: nozzle z = (i + 1) h.
    const auto idx = static_cast<std::size_t>(std::llround(pl.z / o.layer_height)) - 1;
    if (idx >= layers.size()) return;
    // Zones: a colour's face, or with zippering the overlap band around each colour boundary
    // (|f - k/N| < β/2), where pieces alternate between the two neighbouring colours.
    struct Zone {
      Regions region;
      int a, b;           // colours (a == b: a plain face)
      std::size_t count;  // pieces so far (for alternating)
    };
    std::vector<Zone> zones;
    const double res = std::max(o.material_resolution, o.bead_width / 2);
    const double beta = o.zipper;
    if (beta > 0) {
      std::vector<double> levels;
      for (int k = 1; k < o.palette.colors; ++k) {
        levels.push_back(k * o.palette.band() - beta / 2);
        levels.push_back(k * o.palette.band() + beta / 2);
      }
      auto slabs = level_slabs(field, ev, layers[idx].z, layers[idx].regions, levels, res);
      for (std::size_t k = 0; k < slabs.size(); ++k) {
        const int c = static_cast<int>(k / 2);  // even slabs: colour c; odd: overlap c | c+1
        if (!slabs[k].empty())
          zones.push_back({std::move(slabs[k]), c, k % 2 ? c + 1 : c, 0});
      }
    } else {
      for (auto& f : color_faces(field, ev, layers[idx].z, layers[idx].regions, o.palette, res))
        zones.push_back({std::move(f.region), f.color, f.color, 0});
    }
    faces_per[li] = zones.size();
    // Paths of one role share their attributes: each role's paths are cut by a zone in one
    // clipping call (piece order within a role follows Clipper's, not the planar order).
    std::vector<std::pair<PathRole, std::vector<std::size_t>>> roles;
    for (std::size_t k = 0; k < pl.paths.size(); ++k) {
      auto it = std::find_if(roles.begin(), roles.end(),
                             [&](const auto& r) { return r.first == pl.paths[k].role; });
      if (it == roles.end()) {
        roles.push_back({pl.paths[k].role, {}});
        it = roles.end() - 1;
      }
      it->second.push_back(k);
    }
    for (const auto& [role, ids] : roles) {
      std::vector<std::vector<Vec2>> lines;
      for (std::size_t k : ids) {
        std::vector<Vec2> line;
        for (const auto& q : pl.paths[k].points) line.push_back(q.xy());
        lines.push_back(std::move(line));
      }
      const Path& proto = pl.paths[ids.front()];  // role, width, height, speed
      for (auto& zone : zones)
        for (auto& piece : clip_polylines(lines, zone.region)) {
          if (piece.size() < 2) continue;
          Path p;
          p.role = proto.role;
          p.width = proto.width;
          p.height = proto.height;
          p.speed = proto.speed;
          p.tool = proto.tool;
          for (const Vec2 q : piece) p.points.push_back({q.x, q.y, pl.z});
          if (p.length() <= 1e-9) continue;
          const int color = zone.count++ % 2 ? zone.b : zone.a;
          const double m = o.palette.mid(color);
          p.mixture = {m, 1 - m};
          per[li].push_back({std::move(p), color});
        }
    }
    // Colour by colour in palette order (reversed every other layer), the planar order within.
    std::stable_sort(per[li].begin(), per[li].end(), [&](const Piece& a, const Piece& b) {
      return li % 2 ? a.color > b.color : a.color < b.color;
    });
  });
  Toolpath tp;
  FgmStats st;
  st.shortest_path = std::numeric_limits<double>::infinity();
  const double L = purge_length(purge.melt_volume, o.layer_height, o.bead_width);
  int last = -1;
  for (std::size_t li = 0; li < per.size(); ++li) {
    st.faces += faces_per[li];
    Layer layer;
    layer.z = planar.layers[li].z;
    for (auto& piece : per[li]) {
      if (last >= 0 && piece.color != last) {
        ++st.colour_changes;
        const double change = std::abs(o.palette.mid(piece.color) - o.palette.mid(last));
        if (purge.melt_volume > 0 && change > purge.threshold) {
          Path tower;
          tower.role = PathRole::Other;
          tower.mixture = piece.path.mixture;
          tower.width = o.bead_width;
          tower.height = o.layer_height;
          for (const Vec2 q : purge_block({purge.x, purge.y}, purge.side, o.bead_width, L))
            tower.points.push_back({q.x, q.y, layer.z});
          st.purge_length += tower.length();
          ++st.purges;
          layer.paths.push_back(std::move(tower));
        }
      }
      last = piece.color;
      st.shortest_path = std::min(st.shortest_path, piece.path.length());
      ++st.paths;
      layer.paths.push_back(std::move(piece.path));
    }
    if (!layer.paths.empty()) tp.layers.push_back(std::move(layer));
  }
  st.purge_volume = st.purge_length * (o.layer_height * (o.bead_width - o.layer_height) +
                                       3.14159265358979323846 * o.layer_height * o.layer_height / 4);
  if (st.paths == 0) st.shortest_path = 0;
  if (stats) *stats = st;
  return tp;
}

}  // namespace trellis
