// G-code thumbnails drawn straight into their pixel grid: every path's segments projected and
// rasterised as one-pixel lines with a depth buffer (the nearest bead shows), each pixel shaded
// by its layer's height and its depth. Stroking every path with cairo cost a quarter of a slice;
// this is a few per cent of the layers' drawing. Small thumbnails are drawn at up to 4 × 4
// samples a pixel and averaged, so their edges are smooth. cairo only encodes the PNG.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>

#include "render_module.hpp"
#include "trellis/core/error.hpp"

namespace trellis::impl {

namespace {

// The view printer front ends show: from the front (azimuth -90°), 30° above.
constexpr double kAzimuth = -90 * M_PI / 180, kElevation = 30 * M_PI / 180;

// A point in the view: image plane (u right, v up) and depth (towards the viewer).
struct Viewed {
  double u, v, depth;
};

Viewed view(Vec3 p) {
  const double sa = std::sin(kAzimuth), ca = std::cos(kAzimuth);
  const double se = std::sin(kElevation), ce = std::cos(kElevation);
  return {-p.x * sa + p.y * ca, -(p.x * ca + p.y * sa) * se + p.z * ce,
          (p.x * ca + p.y * sa) * ce + p.z * se};
}

// The print's extent in the view, and its heights (for the shading).
struct Extent {
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  double d0 = 1e300, d1 = -1e300, z0 = 1e300, z1 = -1e300;
  bool empty() const { return u0 > u1; }
  void add(Vec3 p) {
    const Viewed q = view(p);
    u0 = std::min(u0, q.u), u1 = std::max(u1, q.u), v0 = std::min(v0, q.v), v1 = std::max(v1, q.v);
    d0 = std::min(d0, q.depth), d1 = std::max(d1, q.depth);
    z0 = std::min(z0, p.z), z1 = std::max(z1, p.z);
  }
};

// One thumbnail's samples: nearest depth (0 = empty) and the layer height there, both in 0..1.
class Canvas {
 public:
  Canvas(int width, int height, const Extent& e) : width_(width), height_(height), extent_(e) {
    // Up to 4 × 4 samples a pixel, at most ~256 samples across.
    ss_ = std::clamp(256 / std::max(width, height), 1, 4);
    w_ = width * ss_;
    h_ = height * ss_;
    depth_.assign(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_), 0.0f);
    shade_.assign(depth_.size(), 0.0f);
    const double margin = 0.05 * std::max(e.u1 - e.u0, e.v1 - e.v0) + 1e-6;
    const double fw = e.u1 - e.u0 + 2 * margin, fh = e.v1 - e.v0 + 2 * margin;
    scale_ = std::min(w_ / fw, h_ / fh);
    ox_ = (w_ - fw * scale_) / 2 - (e.u0 - margin) * scale_;
    oy_ = h_ - (h_ - fh * scale_) / 2 + (e.v0 - margin) * scale_;
  }

  // A path's polyline; points closer than a sample to the last one drawn are passed over.
  void path(const Path& p) {
    if (p.points.size() < 2) return;
    Sample last = sample(p.points[0]);
    plot(last);
    for (std::size_t k = 1; k < p.points.size(); ++k) {
      const Sample s = sample(p.points[k]);
      if (k + 1 < p.points.size() && std::abs(s.x - last.x) < 1 && std::abs(s.y - last.y) < 1)
        continue;
      line(last, s);
      last = s;
    }
  }

  std::string png() const;

 private:
  struct Sample {
    double x, y;
    float depth;  // 0 (farthest) .. 1 (nearest), above 0 where drawn
    float shade;  // height: 0 (bottom) .. 1 (top)
  };
  Sample sample(Vec3 p) const {
    const Viewed q = view(p);
    const double range = extent_.d1 - extent_.d0;
    const double d = range > 0 ? (q.depth - extent_.d0) / range : 1.0;
    const double t = extent_.z1 > extent_.z0 ? (p.z - extent_.z0) / (extent_.z1 - extent_.z0) : 1.0;
    return {ox_ + q.u * scale_, oy_ - q.v * scale_, static_cast<float>(0.01 + 0.99 * d),
            static_cast<float>(t)};
  }
  void plot(const Sample& s) {
    if (s.x < -0.5 || s.y < -0.5) return;
    const long x = static_cast<long>(s.x + 0.5), y = static_cast<long>(s.y + 0.5);  // rounded
    if (x >= w_ || y >= h_) return;
    const std::size_t i =
        static_cast<std::size_t>(y) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(x);
    if (s.depth <= depth_[i]) return;
    depth_[i] = s.depth;
    shade_[i] = s.shade;
  }
  // Samples along a-b, a excluded (it was plotted as the end of the segment before).
  void line(const Sample& a, const Sample& b) {
    const double n = std::ceil(std::max(std::abs(b.x - a.x), std::abs(b.y - a.y)));
    if (n < 1) return plot(b);
    const double dx = (b.x - a.x) / n, dy = (b.y - a.y) / n;
    const auto dd = static_cast<float>((b.depth - a.depth) / n);
    const auto dt = static_cast<float>((b.shade - a.shade) / n);
    Sample s = a;
    for (long k = 1; k <= static_cast<long>(n); ++k) {
      s.x += dx, s.y += dy, s.depth += dd, s.shade += dt;
      plot(s);
    }
  }
  // A drawn sample's colour (0..1 each): copper from dark (bottom) to light (top), darker away
  // from the viewer.
  static void colour(float depth, float t, double rgb[3]) {
    const double k = 0.55 + 0.45 * depth;
    rgb[0] = k * (0.55 + 0.45 * t), rgb[1] = k * (0.25 + 0.45 * t), rgb[2] = k * (0.05 + 0.25 * t);
  }

  int width_, height_, ss_ = 1, w_ = 0, h_ = 0;
  Extent extent_;
  double scale_ = 1, ox_ = 0, oy_ = 0;
  std::vector<float> depth_, shade_;
};

cairo_status_t append_png(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

std::string Canvas::png() const {
  std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surface(
      cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width_, height_), cairo_surface_destroy);
  cairo_surface_flush(surface.get());
  unsigned char* data = cairo_image_surface_get_data(surface.get());
  const int stride = cairo_image_surface_get_stride(surface.get());
  if (!data) throw IoError("cannot make the thumbnail image");
  // Each pixel: the mean of its samples, premultiplied by the share drawn (cairo's ARGB32).
  for (int py = 0; py < height_; ++py) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(py) * stride);
    for (int px = 0; px < width_; ++px) {
      double sum[3] = {0, 0, 0};
      int drawn = 0;
      for (int sy = 0; sy < ss_; ++sy)
        for (int sx = 0; sx < ss_; ++sx) {
          const std::size_t i =
              static_cast<std::size_t>(py * ss_ + sy) * static_cast<std::size_t>(w_) +
              static_cast<std::size_t>(px * ss_ + sx);
          if (depth_[i] <= 0) continue;
          double rgb[3];
          colour(depth_[i], shade_[i], rgb);
          for (int c = 0; c < 3; ++c) sum[c] += rgb[c];
          ++drawn;
        }
      const double n = ss_ * ss_;
      auto byte = [&](double v) { return static_cast<std::uint32_t>(std::lround(255 * v / n)); };
      row[px] = byte(drawn) << 24 | byte(sum[0]) << 16 | byte(sum[1]) << 8 | byte(sum[2]);
    }
  }
  cairo_surface_mark_dirty(surface.get());
  std::string out;
  if (cairo_surface_write_to_png_stream(surface.get(), append_png, &out) != CAIRO_STATUS_SUCCESS)
    throw IoError("cannot encode the thumbnail PNG");
  return out;
}

}  // namespace

std::vector<std::string> render_thumbnails_png(const LayerSource& layers,
                                               const std::vector<std::pair<int, int>>& sizes) {
  for (const auto& [width, height] : sizes)
    if (width < 1 || height < 1 || width > 4096 || height > 4096)
      throw SettingError("thumbnail size " + std::to_string(width) + "x" + std::to_string(height) +
                         " (1..4096 pixels each way)");
  Extent extent;
  layers([&](std::size_t, const Layer& l) {
    for (const auto& p : l.paths)
      for (const Vec3 q : p.points) extent.add(q);
  });
  std::vector<Canvas> canvases;
  for (const auto& [width, height] : sizes) canvases.emplace_back(width, height, extent);
  if (!extent.empty())
    layers([&](std::size_t, const Layer& l) {
      for (const auto& p : l.paths)
        for (Canvas& c : canvases) c.path(p);
    });
  std::vector<std::string> out;
  for (const Canvas& c : canvases) out.push_back(c.png());
  return out;
}

}  // namespace trellis::impl
