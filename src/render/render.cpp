// PNG pictures with cairo, built as the run-time module trellis_cairo (see src/core/module.hpp):
// cairo and the ~20 libraries it loads are paid for only by programs that draw.
#include "trellis/render/render.hpp"

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <tuple>

#include "render_module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/render/palette.hpp"

namespace trellis {

namespace {

using Surface = std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)>;
using Context = std::unique_ptr<cairo_t, decltype(&cairo_destroy)>;

cairo_status_t append_png(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

void save_png(cairo_surface_t* surface, const std::string& path) {
  std::string png;
  if (cairo_surface_write_to_png_stream(surface, append_png, &png) != CAIRO_STATUS_SUCCESS)
    throw IoError("cannot encode PNG", {path});
  write_file_atomic(path, png);
}

// Every colour comes from the shared palette (render/palette.hpp), as in the viewer.
void set_rgb(cairo_t* cr, const Rgb& c) {
  cairo_set_source_rgb(cr, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0);
}

// Ranged values (print order, height): the viewer's continuous map.
void order_colour(cairo_t* cr, double t) {
  set_rgb(cr, continuous_rgb(t));
}

// A colour bar of `colour(t)` for t in 0..1: `length` pixels wide, `height` high, centred on
// ymid; returns its width. Its columns sit on whole pixels, so each pixel is one colour of the
// map (a column at a fractional x would blend two with the background).
template <class Colour>
double draw_bar(cairo_t* c, double x, double ymid, double height, double length, Colour colour) {
  const double x0 = std::round(x), y0 = std::round(ymid - height / 2), h = std::round(height);
  const int n = static_cast<int>(length);
  for (int i = 0; i < n; ++i) {
    set_rgb(c, colour(n > 1 ? static_cast<double>(i) / (n - 1) : 0.0));
    cairo_rectangle(c, x0 + i, y0, 1, h);
    cairo_fill(c);
  }
  return length;
}
double draw_order_bar(cairo_t* c, double x, double ymid, double height, double length) {
  return draw_bar(c, x, ymid, height, length, continuous_rgb);
}

void role_colour(cairo_t* cr, PathRole role) {
  set_rgb(cr, role_rgb(role));
}

void tool_colour(cairo_t* cr, int tool) {
  set_rgb(cr, tool_rgb(tool));
}

// A length of 1, 2 or 5 × 10^k mm, at most `max_mm`.
double nice_length(double max_mm) {
  const double p = std::pow(10.0, std::floor(std::log10(max_mm)));
  for (double k : {5.0, 2.0, 1.0})
    if (k * p <= max_mm) return k * p;
  return p;
}

void text(cairo_t* cr, double x, double y, double size, const std::string& s, bool bold = false) {
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
  cairo_move_to(cr, x, y);
  cairo_show_text(cr, s.c_str());
}

double text_width(cairo_t* cr, double size, const std::string& s) {
  cairo_set_font_size(cr, size);
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  return e.x_advance;
}

// The laser parameter sets a layer's paths are coloured by (colour_by_set): the toolpath's
// named sets, then one for each further role, power and speed in the layer, named by them;
// of[i] is path i's set.
struct LayerSets {
  std::vector<ParameterSet> sets;
  std::vector<int> of;
};

LayerSets layer_sets(const Toolpath& tp, const Layer& layer) {
  Toolpath named;
  named.parameter_sets = tp.parameter_sets;
  LayerSets r;
  for (const Path& p : layer.paths) {
    int i = parameter_set_of(named, p);
    if (i < 0) {
      char name[96];
      std::snprintf(name, sizeof name, "%s %g W %g mm/s", to_string(p.role), p.power, p.speed);
      named.parameter_sets.push_back({name, p.role, p.power, p.speed});
      i = static_cast<int>(named.parameter_sets.size()) - 1;
    }
    r.of.push_back(i);
  }
  r.sets = std::move(named.parameter_sets);
  return r;
}

struct LegendItem {
  std::string label;
  double r, g, b;
  bool marker =
      false;  // drawn as the path-start marker (a white disc in a dark ring), not a swatch
};

// Where a path starts: a white disc in a dark ring, which no palette colour (role, tool, set,
// value) can hide; where it ends: a small dark dot.
void start_marker(cairo_t* c, double x, double y, double r) {
  cairo_new_path(c);  // text leaves a current point: the disc must not be joined to it
  cairo_arc(c, x, y, r, 0, 2 * M_PI);
  cairo_set_source_rgb(c, 1.0, 1.0, 1.0);
  cairo_fill_preserve(c);
  cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
  cairo_set_line_width(c, 0.35 * r);
  cairo_stroke(c);
}

// The band below a picture: `items` as colour swatches (and, with `order_bar`, a colour bar from
// `bar_lo` to `bar_hi` first, print order by default) on the left, a scale bar of a round number
// of mm on the right.
void legend_band(cairo_t* c, int W, double y0, int band, const std::vector<LegendItem>& items,
                 bool order_bar, double px_per_mm, const std::string& bar_lo = "first",
                 const std::string& bar_hi = "last (print order)") {
  const double fs = band * 0.3 * 0.85, pad = band * 0.2, ymid = y0 + band * 0.5, sw = band * 0.3;
  double x = pad;
  auto label = [&](const std::string& t) {
    cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
    text(c, x, ymid + fs * 0.35, fs, t);
    x += text_width(c, fs, t) + sw;
  };
  if (order_bar) {
    label(bar_lo);
    x -= sw * 0.5;
    x += draw_order_bar(c, x, ymid, sw, 3 * band) + sw * 0.5;
    label(bar_hi);
  }
  for (const auto& it : items) {
    if (it.marker) {
      start_marker(c, x + sw * 0.8, ymid, sw * 0.4);
    } else {
      cairo_set_source_rgb(c, it.r, it.g, it.b);
      cairo_rectangle(c, x, ymid - sw / 2, sw * 1.6, sw);
      cairo_fill(c);
    }
    x += sw * 2;
    label(it.label);
  }
  const double len = nice_length(0.25 * W / px_per_mm);
  const double bar_px = len * px_per_mm, bx = W - pad - bar_px;
  cairo_set_source_rgb(c, 0, 0, 0);
  cairo_rectangle(c, bx, ymid + sw * 0.2, bar_px, std::max(2.0, band * 0.08));
  cairo_fill(c);
  char lab[64];
  std::snprintf(lab, sizeof lab, "%g mm", len);
  text(c, bx + bar_px / 2 - text_width(c, fs, lab) / 2, ymid - sw * 0.2, fs, lab);
}

// The two axes of a plot (left edge x0 from top y0 down to the baseline y1, then right to x1),
// and the font its labels use.
void plot_axes(cairo_t* c, double x0, double y0, double x1, double y1) {
  cairo_set_source_rgb(c, 0, 0, 0);
  cairo_set_line_width(c, 1);
  cairo_move_to(c, x0, y0);
  cairo_line_to(c, x0, y1);
  cairo_line_to(c, x1, y1);
  cairo_stroke(c);
  cairo_select_font_face(c, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(c, 13);
}

}  // namespace

namespace impl {

void render_layer_png(const Toolpath& tp, std::size_t index, const std::string& path,
                      const RenderOptions& opt) {
  if (index >= tp.layers.size())
    throw SettingError("layer " + std::to_string(index) + " does not exist (the toolpath has " +
                       std::to_string(tp.layers.size()) + ")");
  const Layer& layer = tp.layers[index];
  BBox3 box;
  for (const auto& p : layer.paths)
    for (const auto& q : p.points) box.add(q);
  if (box.empty()) box.add({0, 0, 0});
  const double w = box.max.x - box.min.x + 2 * opt.margin_mm;
  const double h = box.max.y - box.min.y + 2 * opt.margin_mm;
  const double scale = opt.size_px / std::max({w, h, 1e-6});
  const int Wd = std::max(16, static_cast<int>(std::ceil(w * scale)));
  const int Hd = std::max(16, static_cast<int>(std::ceil(h * scale)));
  // A title band above the layer and a legend band below it (kLegendBand in render.hpp).
  const int band = layer_band_px(opt.size_px);
  const int W = std::max(Wd, 8 * band);
  const int H = Hd + 2 * band;
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_set_source_rgb(cr.get(), 1, 1, 1);
  cairo_paint(cr.get());
  const std::size_t n = layer.paths.size();
  enum class Mode { Order, Role, Mixture2, Mixture3, Tool, Set } mode = Mode::Order;
  bool mixed2 = false, mixed3 = false;
  for (const auto& p : layer.paths) (p.mixture.size() >= 3 ? mixed3 : mixed2) |= !p.mixture.empty();
  const LayerSets sets = opt.colour_by_set ? layer_sets(tp, layer) : LayerSets{};
  if (opt.colour_by_set)
    mode = Mode::Set;
  else if (opt.colour_by_tool)
    mode = Mode::Tool;
  else if (opt.colour_by_mixture && mixed3)
    mode = Mode::Mixture3;
  else if (opt.colour_by_mixture && mixed2)
    mode = Mode::Mixture2;
  else if (opt.colour_by_role || opt.colour_by_mixture)
    mode = Mode::Role;
  cairo_save(cr.get());
  // Millimetres, y up, the layer centred in the middle band.
  cairo_translate(cr.get(), (W - Wd) / 2.0, band + Hd);
  cairo_scale(cr.get(), scale, -scale);
  cairo_translate(cr.get(), -box.min.x + opt.margin_mm, -box.min.y + opt.margin_mm);
  cairo_set_line_cap(cr.get(), CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr.get(), CAIRO_LINE_JOIN_ROUND);
  if (opt.travel && n > 1) {
    cairo_set_source_rgba(cr.get(), 0.4, 0.4, 0.4, 0.8);
    cairo_set_line_width(cr.get(), 1.0 / scale);
    const double dash[] = {4.0 / scale, 3.0 / scale};
    cairo_set_dash(cr.get(), dash, 2, 0);
    for (std::size_t i = 1; i < n; ++i) {
      const Vec3 a = layer.paths[i - 1].points.back(), b = layer.paths[i].points.front();
      cairo_move_to(cr.get(), a.x, a.y);
      for (const Vec3& v : layer.paths[i].via) cairo_line_to(cr.get(), v.x, v.y);
      cairo_line_to(cr.get(), b.x, b.y);
    }
    cairo_stroke(cr.get());
    cairo_set_dash(cr.get(), nullptr, 0, 0);
  }
  double bead_min = 1e300;
  for (std::size_t i = 0; i < n; ++i) {
    const Path& p = layer.paths[i];
    const double bead = opt.bead_width > 0 ? opt.bead_width : (p.width > 0 ? p.width : 0.2);
    bead_min = std::min(bead_min, bead);
    cairo_set_line_width(cr.get(), std::max(bead, 1.5 / scale));
    if (mode == Mode::Set) {
      tool_colour(cr.get(), sets.of[i]);
    } else if (mode == Mode::Tool) {
      tool_colour(cr.get(), p.tool);
    } else if (mode == Mode::Mixture3 && p.mixture.size() >= 3) {
      // Three materials: the blend of their colours at the corners of the mixture triangle.
      set_rgb(cr.get(), mixture3_rgb(p.mixture[0], p.mixture[1], p.mixture[2]));
    } else if ((mode == Mode::Mixture2 || mode == Mode::Mixture3) && !p.mixture.empty()) {
      set_rgb(cr.get(), mixture_rgb(p.mixture[0]));
    } else if (mode == Mode::Mixture2 || mode == Mode::Mixture3) {
      set_rgb(cr.get(), palette().no_value);
    } else if (mode != Mode::Order) {
      role_colour(cr.get(), p.role);
    } else {
      order_colour(cr.get(), n > 1 ? static_cast<double>(i) / (n - 1) : 0.0);
    }
    cairo_move_to(cr.get(), p.points[0].x, p.points[0].y);
    for (std::size_t k = 1; k < p.points.size(); ++k)
      cairo_line_to(cr.get(), p.points[k].x, p.points[k].y);
    cairo_stroke(cr.get());
  }
  if (opt.starts && n > 0) {
    // Sized to the part: at most 3.5 px, and no wider than the bead, so small parts stay visible.
    const double r = std::max(1.0 / scale, std::min(3.5 / scale, 0.5 * bead_min));
    for (const auto& p : layer.paths) {
      // A laser hatch is thousands of short vectors whose starts line every island edge: marked,
      // they would hide the hatch itself; contours and every deposited path are marked.
      if (p.role == PathRole::Hatch) continue;
      start_marker(cr.get(), p.points.front().x, p.points.front().y, r);
      cairo_set_source_rgb(cr.get(), 0.1, 0.1, 0.1);
      cairo_arc(cr.get(), p.points.back().x, p.points.back().y, 0.6 * r, 0, 2 * M_PI);
      cairo_fill(cr.get());
    }
  }
  cairo_restore(cr.get());

  // Title: the file, the layer and its Z, and what colour means.
  cairo_t* c = cr.get();
  const double fs = band * 0.3, pad = band * 0.2;
  cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
  const std::string name = !opt.title.empty()   ? opt.title
                           : !tp.source.empty() ? tp.source
                                                : "toolpath";
  text(c, pad, pad + fs, fs, name, true);
  char line[256];
  const std::string meaning = mode == Mode::Order  ? "colour: print order"
                              : mode == Mode::Role ? "colour: feature type"
                              : mode == Mode::Set  ? "colour: laser parameter set"
                              : mode == Mode::Tool
                                  ? (opt.tools_are_lasers ? "colour: laser" : "colour: tool")
                                  : "colour: mixture " + opt.mixture_label;
  std::snprintf(line, sizeof line, "layer %zu of %zu, z = %.3f mm, %zu paths; %s", index + 1,
                tp.layers.size(), layer.z, n, meaning.c_str());
  // Smaller type when the line would run past the picture's edge (a long mixture label).
  const double line_fs = fs * 0.85 * std::min(1.0, (W - 2 * pad) / text_width(c, fs * 0.85, line));
  text(c, pad, pad + 2.3 * fs, line_fs, line);
  // Legend band: what colour means (left), scale bar in mm (right).
  const double y0 = band + Hd, ymid = y0 + band * 0.5, sw = band * 0.3;
  double x = pad;
  // A swatch of `rgb` and its label.
  auto swatch = [&](const Rgb& rgb, const std::string& label) {
    set_rgb(c, rgb);
    cairo_rectangle(c, x, ymid - sw / 2, sw * 1.6, sw);
    cairo_fill(c);
    x += sw * 2;
    cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
    text(c, x, ymid + fs * 0.3, fs * 0.85, label);
    x += text_width(c, fs * 0.85, label) + sw;
  };
  if (mode == Mode::Role) {
    bool used[kPathRoleCount] = {};
    for (const auto& p : layer.paths) used[static_cast<std::size_t>(p.role)] = true;
    for (std::size_t r = 0; r < kPathRoleCount; ++r)
      if (used[r]) swatch(role_rgb(static_cast<PathRole>(r)), to_string(static_cast<PathRole>(r)));
  } else if (mode == Mode::Set) {
    std::vector<int> used = sets.of;
    std::sort(used.begin(), used.end());
    used.erase(std::unique(used.begin(), used.end()), used.end());
    for (int k : used) swatch(tool_rgb(k), sets.sets[static_cast<std::size_t>(k)].name);
  } else if (mode == Mode::Tool) {
    std::vector<int> tools;
    for (const auto& p : layer.paths) tools.push_back(p.tool);
    std::sort(tools.begin(), tools.end());
    tools.erase(std::unique(tools.begin(), tools.end()), tools.end());
    for (int t : tools)
      swatch(tool_rgb(t),
             opt.tools_are_lasers ? "laser " + std::to_string(t + 1) : "tool " + std::to_string(t));
  } else if (mode == Mode::Mixture3) {
    const char* names[] = {"material 1", "material 2", "material 3"};
    for (int k = 0; k < 3; ++k) swatch(palette().mixture3[k], names[k]);
  } else {
    // A colour bar: print order first .. last, or the fraction of material 1.
    const std::string lo = mode == Mode::Order ? "first" : "0",
                      hi = mode == Mode::Order ? "last" : "1";
    const std::string what = mode == Mode::Order ? "" : " material 1";
    cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
    text(c, x, ymid + fs * 0.3, fs * 0.85, lo);
    x += text_width(c, fs * 0.85, lo) + sw * 0.5;
    x += (mode == Mode::Order ? draw_order_bar(c, x, ymid, sw, 4 * band)
                              : draw_bar(c, x, ymid, sw, 4 * band, mixture_rgb)) +
         sw * 0.5;
    cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
    text(c, x, ymid + fs * 0.3, fs * 0.85, hi + what);
    x += text_width(c, fs * 0.85, hi + what) + sw;
  }
  if (opt.starts && std::any_of(layer.paths.begin(), layer.paths.end(),
                                [](const Path& p) { return p.role != PathRole::Hatch; })) {
    start_marker(c, x + sw * 0.5, ymid, sw * 0.4);
    x += sw * 1.2;
    cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
    text(c, x, ymid + fs * 0.3, fs * 0.85, "path start");
  }
  const double len = nice_length(0.25 * W / scale);
  const double bar_px = len * scale, bx = W - pad - bar_px;
  cairo_set_source_rgb(c, 0, 0, 0);
  cairo_rectangle(c, bx, ymid + sw * 0.2, bar_px, std::max(2.0, band * 0.08));
  cairo_fill(c);
  char lab[64];
  std::snprintf(lab, sizeof lab, "%g mm", len);
  text(c, bx + bar_px / 2 - text_width(c, fs * 0.85, lab) / 2, ymid - sw * 0.2, fs * 0.85, lab);
  cairo_surface_flush(surface.get());
  save_png(surface.get(), path);
}

void render_3d_png(const Toolpath& tp, const std::string& path, const View3dOptions& opt) {
  std::vector<const Path*> paths;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths)
      if (p.points.size() >= 2) paths.push_back(&p);
  const double az = opt.azimuth_deg * M_PI / 180, el = opt.elevation_deg * M_PI / 180;
  // Screen axes: u to the right, v up; the eye looks along -(cos el cos az, cos el sin az, sin el).
  auto project = [&](Vec3 p) {
    const double u = -p.x * std::sin(az) + p.y * std::cos(az);
    const double v = -(p.x * std::cos(az) + p.y * std::sin(az)) * std::sin(el) + p.z * std::cos(el);
    return std::pair<double, double>{u, v};
  };
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  auto extend = [&](Vec3 p) {
    const auto [u, v] = project(p);
    u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
  };
  for (const Path* p : paths)
    for (const auto& q : p->points) extend(q);
  for (const auto& m : opt.marks) extend(m);
  if (u0 > u1) u0 = v0 = 0, u1 = v1 = 1;
  const double margin = 0.04 * std::max(u1 - u0, v1 - v0) + 1e-6;
  const double w = u1 - u0 + 2 * margin, h = v1 - v0 + 2 * margin;
  const double title_px = opt.title.empty() ? 0 : 28;
  const int band = layer_band_px(opt.size_px);
  const double scale = opt.size_px / std::max(w, h);
  const int W = std::max({16, static_cast<int>(std::ceil(w * scale)), 10 * band});
  const int Hd = std::max(16, static_cast<int>(std::ceil(h * scale + title_px)));
  const int H = Hd + band;
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_set_source_rgb(cr.get(), 1, 1, 1);
  cairo_paint(cr.get());
  if (!opt.title.empty()) {
    cairo_set_source_rgb(cr.get(), 0.1, 0.1, 0.1);
    cairo_select_font_face(cr.get(), "sans-serif", CAIRO_FONT_SLANT_NORMAL,
                           CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr.get(), 16);
    cairo_move_to(cr.get(), 8, 20);
    cairo_show_text(cr.get(), opt.title.c_str());
  }
  auto to_px = [&](Vec3 p) {
    const auto [u, v] = project(p);
    return std::pair<double, double>{(u - u0 + margin) * scale, Hd - (v - v0 + margin) * scale};
  };
  cairo_set_line_cap(cr.get(), CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr.get(), CAIRO_LINE_JOIN_ROUND);
  const std::size_t n = paths.size();
  const std::size_t shown = opt.upto > 0 ? std::min(opt.upto, n) : n;
  auto stroke_path = [&](const Path& p) {
    auto [x, y] = to_px(p.points[0]);
    cairo_move_to(cr.get(), x, y);
    for (std::size_t k = 1; k < p.points.size(); ++k) {
      std::tie(x, y) = to_px(p.points[k]);
      cairo_line_to(cr.get(), x, y);
    }
    cairo_stroke(cr.get());
  };
  // Paths not yet printed (when showing a frame) in light grey.
  cairo_set_line_width(cr.get(), 1.2);
  cairo_set_source_rgb(cr.get(), 0.85, 0.85, 0.85);
  for (std::size_t i = shown; i < n; ++i) stroke_path(*paths[i]);
  if (opt.travel && shown > 1) {
    cairo_set_source_rgba(cr.get(), 0.45, 0.45, 0.45, 0.7);
    cairo_set_line_width(cr.get(), 0.8);
    const double dash[] = {4.0, 3.0};
    cairo_set_dash(cr.get(), dash, 2, 0);
    for (std::size_t i = 1; i < shown; ++i) {
      const auto [ax, ay] = to_px(paths[i - 1]->points.back());
      const auto [bx, by] = to_px(paths[i]->points.front());
      cairo_move_to(cr.get(), ax, ay);
      for (const Vec3& v : paths[i]->via) {
        const auto [vx, vy] = to_px(v);
        cairo_line_to(cr.get(), vx, vy);
      }
      cairo_line_to(cr.get(), bx, by);
    }
    cairo_stroke(cr.get());
    cairo_set_dash(cr.get(), nullptr, 0, 0);
  }
  cairo_set_line_width(cr.get(), 2.0);
  double z0 = 1e300, z1 = -1e300;
  std::vector<int> tools;
  for (const Path* p : paths) {
    for (const auto& q : p->points) z0 = std::min(z0, q.z), z1 = std::max(z1, q.z);
    if (std::find(tools.begin(), tools.end(), p->tool) == tools.end()) tools.push_back(p->tool);
  }
  std::sort(tools.begin(), tools.end());
  using Colour = View3dOptions::Colour;
  for (std::size_t i = 0; i < shown; ++i) {
    if (opt.colour == Colour::Height) {
      // Each segment in the colour of its mid height.
      const Path& p = *paths[i];
      for (std::size_t k = 1; k < p.points.size(); ++k) {
        const double z = 0.5 * (p.points[k - 1].z + p.points[k].z);
        order_colour(cr.get(), z1 > z0 ? (z - z0) / (z1 - z0) : 0.5);
        const auto [ax, ay] = to_px(p.points[k - 1]);
        const auto [bx, by] = to_px(p.points[k]);
        cairo_move_to(cr.get(), ax, ay);
        cairo_line_to(cr.get(), bx, by);
        cairo_stroke(cr.get());
      }
      continue;
    }
    if (opt.colour == Colour::Tool)
      tool_colour(cr.get(), paths[i]->tool);
    else
      order_colour(cr.get(), n > 1 ? static_cast<double>(i) / (n - 1) : 0.0);
    stroke_path(*paths[i]);
  }
  for (std::size_t i = 0; i < shown; ++i) {
    const auto [x, y] = to_px(paths[i]->points.front());
    start_marker(cr.get(), x, y, 3.0);
  }
  cairo_set_source_rgb(cr.get(), 0.9, 0.0, 0.0);
  cairo_set_line_width(cr.get(), 2.0);
  for (const auto& m : opt.marks) {
    const auto [x, y] = to_px(m);
    cairo_arc(cr.get(), x, y, 7.0, 0, 2 * M_PI);
    cairo_stroke(cr.get());
  }
  // Axes: X red, Y green, Z blue, from the lower left corner of the drawing.
  {
    const double L = band * 0.8, ox = band * 0.6, oy = Hd - band * 0.4;
    const Vec3 axes[] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const char* names[] = {"X", "Y", "Z"};
    for (int k = 0; k < 3; ++k) {
      const auto [u, v] = project(axes[k]);
      cairo_set_source_rgb(cr.get(), k == 0 ? 0.85 : 0.1, k == 1 ? 0.6 : 0.1, k == 2 ? 0.85 : 0.1);
      cairo_set_line_width(cr.get(), 2.0);
      cairo_move_to(cr.get(), ox, oy);
      cairo_line_to(cr.get(), ox + u * L, oy - v * L);
      cairo_stroke(cr.get());
      text(cr.get(), ox + u * L * 1.2 - 4, oy - v * L * 1.2 + 4, band * 0.25, names[k]);
    }
  }
  std::vector<LegendItem> items;
  if (opt.colour == Colour::Tool)
    for (int t : tools) {
      const Rgb c = tool_rgb(t);
      items.push_back({"tool " + std::to_string(t), c[0] / 255.0, c[1] / 255.0, c[2] / 255.0});
    }
  items.push_back({"path start", 1.0, 1.0, 1.0, true});
  if (opt.upto > 0) items.push_back({"not yet printed", 0.85, 0.85, 0.85});
  if (!opt.marks.empty()) items.push_back({"collision (ring)", 0.9, 0.0, 0.0});
  if (opt.colour == Colour::Height && z0 <= z1) {
    char lo[64], hi[64];
    std::snprintf(lo, sizeof lo, "z %.2f", z0);
    std::snprintf(hi, sizeof hi, "%.2f mm (height)", z1);
    legend_band(cr.get(), W, Hd, band, items, true, scale, lo, hi);
  } else {
    legend_band(cr.get(), W, Hd, band, items, opt.colour == Colour::Order, scale);
  }
  cairo_surface_flush(surface.get());
  save_png(surface.get(), path);
}

void render_overlay_png(const std::vector<Segment2>& design, const Layer& printed,
                        const std::vector<Segment2>& red, const std::vector<Segment2>& blue,
                        double bead, const std::string& path, int size_px) {
  BBox3 box;
  for (const auto& s : design) box.add({s.a.x, s.a.y, 0}), box.add({s.b.x, s.b.y, 0});
  for (const auto& p : printed.paths)
    for (const auto& q : p.points) box.add({q.x, q.y, 0});
  if (box.empty()) box.add({0, 0, 0});
  const double margin = 1.0;
  const double w = box.max.x - box.min.x + 2 * margin, h = box.max.y - box.min.y + 2 * margin;
  const double scale = size_px / std::max({w, h, 1e-6});
  const int band = layer_band_px(size_px);
  const int Wd = std::max(16, static_cast<int>(std::ceil(w * scale)));
  const int Hd = std::max(16, static_cast<int>(std::ceil(h * scale)));
  const int W = std::max(Wd, 12 * band), H = Hd + 2 * band;
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_t* c = cr.get();
  cairo_set_source_rgb(c, 1, 1, 1);
  cairo_paint(c);
  {
    // Title: the picture's name (FILE_layer_NNNN) and the printed layer's Z.
    std::string name = path.substr(path.find_last_of('/') + 1);
    if (name.size() > 4) name.resize(name.size() - 4);
    char line[128];
    std::snprintf(line, sizeof line, "printed layer at z = %.3f mm against the design", printed.z);
    cairo_set_source_rgb(c, 0.1, 0.1, 0.1);
    text(c, band * 0.2, band * 0.5, band * 0.3, name, true);
    text(c, band * 0.2, band * 0.89, band * 0.255, line);
    legend_band(c, W, band + Hd, band,
                {{"design", 0.85, 0.85, 0.85},
                 {"printed", 0.15, 0.15, 0.15},
                 {"deposited twice", 0.9, 0.1, 0.1},
                 {"missing strut", 0.1, 0.3, 0.95}},
                false, scale);
  }
  cairo_translate(c, (W - Wd) / 2.0, band + Hd);
  cairo_scale(c, scale, -scale);
  cairo_translate(c, -box.min.x + margin, -box.min.y + margin);
  cairo_set_line_cap(c, CAIRO_LINE_CAP_ROUND);
  auto stroke = [&](const std::vector<Segment2>& segs, double width) {
    cairo_set_line_width(c, width);
    for (const auto& s : segs) {
      cairo_move_to(c, s.a.x, s.a.y);
      cairo_line_to(c, s.b.x, s.b.y);
    }
    cairo_stroke(c);
  };
  cairo_set_source_rgb(c, 0.85, 0.85, 0.85);
  stroke(design, bead);
  cairo_set_source_rgb(c, 0.15, 0.15, 0.15);
  cairo_set_line_width(c, std::max(bead / 4, 1.0 / scale));
  for (const auto& p : printed.paths) {
    cairo_move_to(c, p.points[0].x, p.points[0].y);
    for (std::size_t k = 1; k < p.points.size(); ++k)
      cairo_line_to(c, p.points[k].x, p.points[k].y);
    cairo_stroke(c);
  }
  cairo_set_source_rgba(c, 0.9, 0.1, 0.1, 0.8);
  stroke(red, bead);
  cairo_set_source_rgba(c, 0.1, 0.3, 0.95, 0.8);
  stroke(blue, bead);
  cairo_surface_flush(surface.get());
  save_png(surface.get(), path);
}

void render_scores_png(const std::vector<double>& scores, std::size_t best,
                       const std::string& title, const std::string& path) {
  const int W = 900, H = 500, L = 70, R = 20, T = 40, B = 50;
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_t* c = cr.get();
  cairo_set_source_rgb(c, 1, 1, 1);
  cairo_paint(c);
  double lo = scores.empty() ? 0 : *std::min_element(scores.begin(), scores.end());
  double hi = scores.empty() ? 1 : *std::max_element(scores.begin(), scores.end());
  if (hi - lo < 1e-12) {
    lo -= 0.5;
    hi += 0.5;
  }
  const double pad = (hi - lo) * 0.05;
  lo -= pad;
  hi += pad;
  auto X = [&](double i) {
    return L + (W - L - R) * (scores.size() > 1 ? i / (scores.size() - 1) : 0.5);
  };
  auto Y = [&](double s) { return H - B - (H - T - B) * (s - lo) / (hi - lo); };
  plot_axes(c, L, T, W - R, H - B);
  char buf[128];
  for (int k = 0; k <= 4; ++k) {
    const double s = lo + (hi - lo) * k / 4;
    std::snprintf(buf, sizeof buf, "%.4g", s);
    cairo_move_to(c, 5, Y(s) + 4);
    cairo_show_text(c, buf);
    cairo_move_to(c, L - 4, Y(s));
    cairo_line_to(c, L, Y(s));
    cairo_stroke(c);
  }
  std::snprintf(buf, sizeof buf, "iteration (1..%zu)", scores.size());
  cairo_move_to(c, W / 2.0 - 60, H - 15);
  cairo_show_text(c, buf);
  cairo_set_font_size(c, 15);
  cairo_move_to(c, L, 25);
  cairo_show_text(c, title.c_str());
  cairo_set_source_rgba(c, 0.1, 0.3, 0.8, 0.7);
  for (std::size_t i = 0; i < scores.size(); ++i) {
    cairo_arc(c, X(i), Y(scores[i]), 2.5, 0, 2 * M_PI);
    cairo_fill(c);
  }
  // A solution ringed and named at the top right: the best in red, the worst (lowest score, first
  // such iteration) in green, as the paper's Fig. 2 (i).
  const auto ring = [&](std::size_t i, double r, double g, double b, const char* what, double y) {
    cairo_set_source_rgb(c, r, g, b);
    cairo_new_path(c);  // not joined to where earlier text ended
    cairo_arc(c, X(i), Y(scores[i]), 6, 0, 2 * M_PI);
    cairo_stroke(c);
    std::snprintf(buf, sizeof buf, "%s %.4g (iteration %zu)", what, scores[i], i + 1);
    cairo_set_font_size(c, 13);
    cairo_move_to(c, W - R - 230, y);
    cairo_show_text(c, buf);
  };
  if (best < scores.size()) ring(best, 0.85, 0.1, 0.1, "best", 25);
  if (!scores.empty())
    ring(static_cast<std::size_t>(std::min_element(scores.begin(), scores.end()) - scores.begin()),
         0.1, 0.6, 0.2, "worst", 42);
  cairo_surface_flush(surface.get());
  save_png(surface.get(), path);
}

}  // namespace impl

}  // namespace trellis

namespace trellis {

namespace impl {

void render_series_png(const std::vector<double>& x, const std::vector<PlotSeries>& series,
                       const std::string& title, const std::string& x_label,
                       const std::string& path) {
  const int W = 1000, H = 500, L = 70, R = 20, T = 50, B = 50;
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_t* c = cr.get();
  cairo_set_source_rgb(c, 1, 1, 1);
  cairo_paint(c);
  double x0 = x.empty() ? 0 : *std::min_element(x.begin(), x.end());
  double x1 = x.empty() ? 1 : *std::max_element(x.begin(), x.end());
  double lo = 0, hi = 0;
  for (const auto& s : series)
    for (const double v : s.values)
      if (std::isfinite(v)) hi = std::max(hi, v), lo = std::min(lo, v);
  if (hi - lo < 1e-12) hi = lo + 1;
  hi += 0.05 * (hi - lo);
  if (x1 - x0 < 1e-12) x1 = x0 + 1;
  auto X = [&](double v) { return L + (W - L - R) * (v - x0) / (x1 - x0); };
  auto Y = [&](double v) { return H - B - (H - T - B) * (v - lo) / (hi - lo); };
  plot_axes(c, L, T, W - R, H - B);
  char buf[128];
  for (int k = 0; k <= 4; ++k) {
    const double v = lo + (hi - lo) * k / 4, u = x0 + (x1 - x0) * k / 4;
    std::snprintf(buf, sizeof buf, "%.3g", v);
    cairo_move_to(c, 5, Y(v) + 4);
    cairo_show_text(c, buf);
    cairo_move_to(c, L - 4, Y(v));
    cairo_line_to(c, L, Y(v));
    std::snprintf(buf, sizeof buf, "%.6g", u);
    cairo_move_to(c, X(u) - 10, H - B + 18);
    cairo_show_text(c, buf);
    cairo_move_to(c, X(u), H - B);
    cairo_line_to(c, X(u), H - B + 4);
    cairo_stroke(c);
  }
  cairo_move_to(c, W / 2.0 - 40, H - 12);
  cairo_show_text(c, x_label.c_str());
  cairo_set_font_size(c, 15);
  cairo_move_to(c, L, 22);
  cairo_show_text(c, title.c_str());
  cairo_set_font_size(c, 13);
  double legend_x = W - R - 260;
  for (const auto& s : series) {
    cairo_set_source_rgb(c, s.r, s.g, s.b);
    cairo_set_line_width(c, 1.2);
    bool first = true;
    for (std::size_t i = 0; i < x.size() && i < s.values.size(); ++i) {
      if (!std::isfinite(s.values[i])) {
        first = true;
        continue;
      }
      if (first)
        cairo_move_to(c, X(x[i]), Y(s.values[i]));
      else
        cairo_line_to(c, X(x[i]), Y(s.values[i]));
      first = false;
    }
    cairo_stroke(c);
    cairo_rectangle(c, legend_x, 32, 18, 4);
    cairo_fill(c);
    cairo_move_to(c, legend_x + 24, 38);
    cairo_show_text(c, s.label.c_str());
    legend_x += 130;
  }
  cairo_surface_flush(surface.get());
  save_png(surface.get(), path);
}

}  // namespace impl

}  // namespace trellis

TRELLIS_MODULE_ENTRY(cairo, trellis::RenderModule, &trellis::impl::render_layer_png,
                     &trellis::impl::render_3d_png, &trellis::impl::render_overlay_png,
                     &trellis::impl::render_scores_png, &trellis::impl::render_series_png)
