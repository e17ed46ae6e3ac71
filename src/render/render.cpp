// PNG pictures with cairo, built as the run-time module trellis_cairo (see src/core/module.hpp):
// cairo and the ~20 libraries it loads are paid for only by programs that draw.
#include "trellis/render/render.hpp"

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <tuple>

#include "render_module.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

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

// Blue (first) to red (last) through green.
void order_colour(cairo_t* cr, double t) {
  const double h = (1 - t) * 240.0 / 60.0;  // hue in sextants, 4 (blue) .. 0 (red)
  const double x = 1 - std::abs(std::fmod(h, 2.0) - 1);
  double r = 0, g = 0, b = 0;
  if (h < 1)
    r = 1, g = x;
  else if (h < 2)
    r = x, g = 1;
  else if (h < 3)
    g = 1, b = x;
  else
    b = 1, g = x;
  cairo_set_source_rgb(cr, r * 0.9, g * 0.75, b * 0.9);
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
  const int W = std::max(16, static_cast<int>(std::ceil(w * scale)));
  const int H = std::max(16, static_cast<int>(std::ceil(h * scale)));
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_set_source_rgb(cr.get(), 1, 1, 1);
  cairo_paint(cr.get());
  // Millimetres, y up.
  cairo_translate(cr.get(), 0, H);
  cairo_scale(cr.get(), scale, -scale);
  cairo_translate(cr.get(), -box.min.x + opt.margin_mm, -box.min.y + opt.margin_mm);
  cairo_set_line_cap(cr.get(), CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr.get(), CAIRO_LINE_JOIN_ROUND);
  const std::size_t n = layer.paths.size();
  if (opt.travel && n > 1) {
    cairo_set_source_rgba(cr.get(), 0.4, 0.4, 0.4, 0.8);
    cairo_set_line_width(cr.get(), 1.0 / scale);
    const double dash[] = {4.0 / scale, 3.0 / scale};
    cairo_set_dash(cr.get(), dash, 2, 0);
    for (std::size_t i = 1; i < n; ++i) {
      const Vec3 a = layer.paths[i - 1].points.back(), b = layer.paths[i].points.front();
      cairo_move_to(cr.get(), a.x, a.y);
      cairo_line_to(cr.get(), b.x, b.y);
    }
    cairo_stroke(cr.get());
    cairo_set_dash(cr.get(), nullptr, 0, 0);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const Path& p = layer.paths[i];
    const double bead = opt.bead_width > 0 ? opt.bead_width : (p.width > 0 ? p.width : 0.2);
    cairo_set_line_width(cr.get(), std::max(bead, 1.5 / scale));
    if (opt.colour_by_mixture && p.mixture.size() >= 3) {
      // Three materials: A red, B green, C blue, mixed.
      cairo_set_source_rgb(cr.get(), std::clamp(p.mixture[0], 0.0, 1.0),
                           std::clamp(p.mixture[1], 0.0, 1.0), std::clamp(p.mixture[2], 0.0, 1.0));
    } else if (opt.colour_by_mixture && !p.mixture.empty()) {
      order_colour(cr.get(), std::clamp(p.mixture[0], 0.0, 1.0));
    } else if (opt.colour_by_role) {
      switch (p.role) {
        case PathRole::Contour: cairo_set_source_rgb(cr.get(), 0.85, 0.1, 0.1); break;
        case PathRole::Infill: cairo_set_source_rgb(cr.get(), 0.1, 0.3, 0.85); break;
        case PathRole::Skin: cairo_set_source_rgb(cr.get(), 0.1, 0.6, 0.2); break;
        default: cairo_set_source_rgb(cr.get(), 0.15, 0.15, 0.15); break;
      }
    } else {
      order_colour(cr.get(), n > 1 ? static_cast<double>(i) / (n - 1) : 0.0);
    }
    cairo_move_to(cr.get(), p.points[0].x, p.points[0].y);
    for (std::size_t k = 1; k < p.points.size(); ++k)
      cairo_line_to(cr.get(), p.points[k].x, p.points[k].y);
    cairo_stroke(cr.get());
  }
  if (opt.starts)
    for (const auto& p : layer.paths) {
      cairo_set_source_rgb(cr.get(), 0.0, 0.6, 0.0);
      cairo_arc(cr.get(), p.points.front().x, p.points.front().y, 3.5 / scale, 0, 2 * M_PI);
      cairo_fill(cr.get());
      cairo_set_source_rgb(cr.get(), 0.1, 0.1, 0.1);
      cairo_arc(cr.get(), p.points.back().x, p.points.back().y, 2.0 / scale, 0, 2 * M_PI);
      cairo_fill(cr.get());
    }
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
  const double scale = opt.size_px / std::max(w, h);
  const int W = std::max(16, static_cast<int>(std::ceil(w * scale)));
  const int H = std::max(16, static_cast<int>(std::ceil(h * scale + title_px)));
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_set_source_rgb(cr.get(), 1, 1, 1);
  cairo_paint(cr.get());
  if (!opt.title.empty()) {
    cairo_set_source_rgb(cr.get(), 0.1, 0.1, 0.1);
    cairo_select_font_face(cr.get(), "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr.get(), 16);
    cairo_move_to(cr.get(), 8, 20);
    cairo_show_text(cr.get(), opt.title.c_str());
  }
  auto to_px = [&](Vec3 p) {
    const auto [u, v] = project(p);
    return std::pair<double, double>{(u - u0 + margin) * scale, H - (v - v0 + margin) * scale};
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
      cairo_line_to(cr.get(), bx, by);
    }
    cairo_stroke(cr.get());
    cairo_set_dash(cr.get(), nullptr, 0, 0);
  }
  cairo_set_line_width(cr.get(), 2.0);
  for (std::size_t i = 0; i < shown; ++i) {
    order_colour(cr.get(), n > 1 ? static_cast<double>(i) / (n - 1) : 0.0);
    stroke_path(*paths[i]);
  }
  for (std::size_t i = 0; i < shown; ++i) {
    const auto [x, y] = to_px(paths[i]->points.front());
    cairo_set_source_rgb(cr.get(), 0.0, 0.6, 0.0);
    cairo_arc(cr.get(), x, y, 3.0, 0, 2 * M_PI);
    cairo_fill(cr.get());
  }
  cairo_set_source_rgb(cr.get(), 0.9, 0.0, 0.0);
  cairo_set_line_width(cr.get(), 2.0);
  for (const auto& m : opt.marks) {
    const auto [x, y] = to_px(m);
    cairo_arc(cr.get(), x, y, 7.0, 0, 2 * M_PI);
    cairo_stroke(cr.get());
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
  const int W = std::max(16, static_cast<int>(std::ceil(w * scale)));
  const int H = std::max(16, static_cast<int>(std::ceil(h * scale)));
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  cairo_t* c = cr.get();
  cairo_set_source_rgb(c, 1, 1, 1);
  cairo_paint(c);
  cairo_translate(c, 0, H);
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
  cairo_set_source_rgb(c, 0, 0, 0);
  cairo_set_line_width(c, 1);
  cairo_move_to(c, L, T);
  cairo_line_to(c, L, H - B);
  cairo_line_to(c, W - R, H - B);
  cairo_stroke(c);
  cairo_select_font_face(c, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(c, 13);
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
  if (best < scores.size()) {
    cairo_set_source_rgb(c, 0.85, 0.1, 0.1);
    cairo_arc(c, X(best), Y(scores[best]), 6, 0, 2 * M_PI);
    cairo_stroke(c);
    std::snprintf(buf, sizeof buf, "best %.4g (iteration %zu)", scores[best], best + 1);
    cairo_set_font_size(c, 13);
    cairo_move_to(c, W - R - 230, 25);
    cairo_show_text(c, buf);
  }
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
  cairo_set_source_rgb(c, 0, 0, 0);
  cairo_set_line_width(c, 1);
  cairo_move_to(c, L, T);
  cairo_line_to(c, L, H - B);
  cairo_line_to(c, W - R, H - B);
  cairo_stroke(c);
  cairo_select_font_face(c, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(c, 13);
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

std::string render_thumbnail_png(const Toolpath& tp, int width, int height) {
  if (width < 1 || height < 1 || width > 4096 || height > 4096)
    throw SettingError("thumbnail size " + std::to_string(width) + "x" + std::to_string(height) +
                       " (1..4096 pixels each way)");
  // The view printer front ends show: from the front, a little above, the part fitted into the
  // image on a transparent background; paths shaded from dark (bottom) to light (top).
  const double az = -90 * M_PI / 180, el = 30 * M_PI / 180;
  auto project = [&](Vec3 p) {
    const double u = -p.x * std::sin(az) + p.y * std::cos(az);
    const double v = -(p.x * std::cos(az) + p.y * std::sin(az)) * std::sin(el) + p.z * std::cos(el);
    return std::pair<double, double>{u, v};
  };
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300, z0 = 1e300, z1 = -1e300;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths)
      for (const auto& q : p.points) {
        const auto [u, v] = project(q);
        u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
        z0 = std::min(z0, q.z), z1 = std::max(z1, q.z);
      }
  Surface surface(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width, height),
                  cairo_surface_destroy);
  Context cr(cairo_create(surface.get()), cairo_destroy);
  if (u0 <= u1) {
    const double margin = 0.05 * std::max(u1 - u0, v1 - v0) + 1e-6;
    const double w = u1 - u0 + 2 * margin, h = v1 - v0 + 2 * margin;
    const double scale = std::min(width / w, height / h);
    const double ox = (width - w * scale) / 2, oy = (height - h * scale) / 2;
    auto to_px = [&](Vec3 p) {
      const auto [u, v] = project(p);
      return std::pair<double, double>{ox + (u - u0 + margin) * scale,
                                       height - oy - (v - v0 + margin) * scale};
    };
    cairo_set_line_cap(cr.get(), CAIRO_LINE_CAP_ROUND);
    cairo_set_line_join(cr.get(), CAIRO_LINE_JOIN_ROUND);
    cairo_set_line_width(cr.get(), std::max(0.6, std::min(width, height) / 100.0));
    for (const auto& l : tp.layers) {
      const double t = z1 > z0 ? (l.z - z0) / (z1 - z0) : 1.0;
      cairo_set_source_rgb(cr.get(), 0.55 + 0.45 * t, 0.25 + 0.45 * t, 0.05 + 0.25 * t);
      for (const auto& p : l.paths) {
        if (p.points.size() < 2) continue;
        auto [x, y] = to_px(p.points[0]);
        cairo_move_to(cr.get(), x, y);
        for (std::size_t k = 1; k < p.points.size(); ++k) {
          std::tie(x, y) = to_px(p.points[k]);
          cairo_line_to(cr.get(), x, y);
        }
        cairo_stroke(cr.get());
      }
    }
  }
  cairo_surface_flush(surface.get());
  std::string png;
  if (cairo_surface_write_to_png_stream(surface.get(), append_png, &png) != CAIRO_STATUS_SUCCESS)
    throw IoError("cannot encode the thumbnail PNG");
  return png;
}

}  // namespace impl

}  // namespace trellis

TRELLIS_MODULE_ENTRY(cairo, trellis::RenderModule, &trellis::impl::render_layer_png,
                     &trellis::impl::render_3d_png, &trellis::impl::render_overlay_png,
                     &trellis::impl::render_scores_png, &trellis::impl::render_series_png,
                     &trellis::impl::render_thumbnail_png)
