// G-code thumbnails drawn straight into their pixel grid: every path's segments projected and
// rasterised as one-sample lines with a depth buffer (the nearest bead shows), each pixel shaded
// by its layer's height and its depth; layers that would land on the samples of the layer above
// are left out. Stroking every path with cairo cost a quarter of a slice.
// Small thumbnails are drawn at up to 3 × 3 samples a pixel and averaged, so their edges are
// smooth. No cairo: `trellis slice` does not load it for its thumbnails.
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>

#include "trellis/core/error.hpp"
#include "trellis/render/render.hpp"

namespace trellis {

namespace {

// The view printer front ends show: from the front (azimuth -90°), 30° above.
constexpr double kAzimuth = -90 * M_PI / 180, kElevation = 30 * M_PI / 180;

// A point in the view: image plane (u right, v up) and depth (towards the viewer).
struct Viewed {
  double u, v, depth;
};

struct View {
  double sa = std::sin(kAzimuth), ca = std::cos(kAzimuth);
  double se = std::sin(kElevation), ce = std::cos(kElevation);
  Viewed operator()(Vec3 p) const {
    const double across = p.x * ca + p.y * sa;
    return {-p.x * sa + p.y * ca, -across * se + p.z * ce, across * ce + p.z * se};
  }
};

// A layer as the thumbnail needs it: its height when all its points lie at one (NaN otherwise),
// and the length of its paths.
struct LayerSummary {
  double flat_z = std::numeric_limits<double>::quiet_NaN();
  double length = 0;
};

// The print's extent in the view, its heights (for the shading), and its layers.
struct Extent {
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  double d0 = 1e300, d1 = -1e300, z0 = 1e300, z1 = -1e300;
  View view;
  std::vector<LayerSummary> layers;
  bool empty() const { return u0 > u1; }
  // The extent and the summary of one layer. The bounds are kept in locals while the points are
  // read: as members they would be reloaded and stored at every point (the points are doubles
  // too, so the compiler cannot tell they do not overlap).
  void add(const Layer& l) {
    const View vw = view;
    double bu0 = u0, bu1 = u1, bv0 = v0, bv1 = v1, bd0 = d0, bd1 = d1, bz0 = z0, bz1 = z1;
    double flat_z = std::numeric_limits<double>::quiet_NaN(), length = 0;
    bool first = true;
    for (const auto& p : l.paths) {
      const Vec3* pts = p.points.data();
      const std::size_t n = p.points.size();
      for (std::size_t k = 0; k < n; ++k) {
        const Vec3 q = pts[k];
        const Viewed w = vw(q);
        bu0 = std::min(bu0, w.u), bu1 = std::max(bu1, w.u);
        bv0 = std::min(bv0, w.v), bv1 = std::max(bv1, w.v);
        bd0 = std::min(bd0, w.depth), bd1 = std::max(bd1, w.depth);
        bz0 = std::min(bz0, q.z), bz1 = std::max(bz1, q.z);
        if (first) flat_z = q.z, first = false;
        if (q.z != flat_z) flat_z = std::numeric_limits<double>::quiet_NaN();
        if (k > 0) length += norm(q - pts[k - 1]);
      }
    }
    u0 = bu0, u1 = bu1, v0 = bv0, v1 = bv1, d0 = bd0, d1 = bd1, z0 = bz0, z1 = bz1;
    layers.push_back({flat_z, length});
  }
};

// One thumbnail's samples: nearest depth (0 = empty) and the layer height there, both in 0..1.
class Canvas {
 public:
  Canvas(int width, int height, const Extent& e) : width_(width), height_(height), view_(e.view) {
    // Small thumbnails: up to 3 × 3 samples a pixel, at most 48 samples across.
    ss_ = std::clamp(48 / std::max(width, height), 1, 3);
    w_ = width * ss_;
    h_ = height * ss_;
    x_max_ = w_ - 0.01, y_max_ = h_ - 0.01;
    pixels_.resize(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_));
    const double margin = 0.05 * std::max(e.u1 - e.u0, e.v1 - e.v0) + 1e-6;
    const double fw = e.u1 - e.u0 + 2 * margin, fh = e.v1 - e.v0 + 2 * margin;
    scale_ = std::min(w_ / fw, h_ / fh);
    ox_ = (w_ - fw * scale_) / 2 - (e.u0 - margin) * scale_;
    oy_ = h_ - (h_ - fh * scale_) / 2 + (e.v0 - margin) * scale_;
    d0_ = e.d0, d_range_ = e.d1 - e.d0;
    z0_ = e.z0, z_range_ = e.z1 > e.z0 ? e.z1 - e.z0 : 0;
  }

  // Whether a layer is drawn, or left out as the layer above will cover it: in this view the
  // higher of two points on one sample is always the nearer, so a flat layer is left out when
  // the next one is flat, has about as much to draw (no feature ends here) and lies less than
  // half a sample above the lowest layer left out since the last one drawn. Most layers of a
  // part land on the samples of their neighbours; drawing every one was most of the work.
  // Called once for each layer, in order.
  bool draws(const LayerSummary& here, const LayerSummary* next) {
    if (next && !std::isnan(here.flat_z) && !std::isnan(next->flat_z) &&
        next->length >= 0.9 * here.length) {
      if (std::isnan(skipped_z_)) skipped_z_ = here.flat_z;
      if (std::abs(next->flat_z - skipped_z_) * view_.ce * scale_ < 0.5) return false;
    }
    skipped_z_ = std::numeric_limits<double>::quiet_NaN();
    return true;
  }

  // A path's polyline; points closer than a sample to the last one drawn are passed over (their
  // depth and height are not worked out).
  void path(const Path& p) {
    const std::size_t n = p.points.size();
    if (n < 2) return;
    const Vec3* pts = p.points.data();
    Sample last = sample(pts[0]);
    plot(last);
    for (std::size_t k = 1; k < n; ++k) {
      const Vec3 q = pts[k];
      const double x = sample_x(q), y = sample_y(q);
      if (k + 1 < n && std::abs(x - last.x) < 1 && std::abs(y - last.y) < 1) continue;
      const Sample s{x, y, sample_depth(q), sample_shade(q)};
      line(last, s);
      last = s;
    }
  }

  std::string png() const;

 private:
  // A point in samples, half a sample on (so that truncating rounds) and kept on the canvas.
  struct Sample {
    double x, y;
    float depth;  // 0 (farthest) .. 1 (nearest), above 0 where drawn
    float shade;  // height: 0 (bottom) .. 1 (top)
  };
  struct Pixel {
    float depth = 0, shade = 0;
  };
  // The view's coordinates one at a time (as View computes them).
  double sample_x(Vec3 p) const {
    const double u = -p.x * view_.sa + p.y * view_.ca;
    return std::clamp(ox_ + u * scale_ + 0.5, 0.0, x_max_);
  }
  double sample_y(Vec3 p) const {
    const double across = p.x * view_.ca + p.y * view_.sa;
    const double v = -across * view_.se + p.z * view_.ce;
    return std::clamp(oy_ - v * scale_ + 0.5, 0.0, y_max_);
  }
  float sample_depth(Vec3 p) const {
    const double across = p.x * view_.ca + p.y * view_.sa;
    const double depth = across * view_.ce + p.z * view_.se;
    const double d = d_range_ > 0 ? (depth - d0_) / d_range_ : 1.0;
    return static_cast<float>(0.01 + 0.99 * d);
  }
  float sample_shade(Vec3 p) const {
    return static_cast<float>(z_range_ > 0 ? (p.z - z0_) / z_range_ : 1.0);
  }
  Sample sample(Vec3 p) const {
    return {sample_x(p), sample_y(p), sample_depth(p), sample_shade(p)};
  }
  void plot(const Sample& s) { plot(pixels_.data(), s.x, s.y, s.depth, s.shade); }
  // x and y lie in 0 .. w_, h_ (a step's rounding may take them a hair below 0: truncated to 0).
  void plot(Pixel* px, double x, double y, float depth, float shade) const {
    Pixel& p = px[static_cast<long>(y) * w_ + static_cast<long>(x)];
    if (depth > p.depth) p = {depth, shade};
  }
  // Samples along a-b, a excluded (it was plotted as the end of the segment before).
  void line(const Sample& a, const Sample& b) {
    const double m = std::max(std::abs(b.x - a.x), std::abs(b.y - a.y));
    long steps = static_cast<long>(m);  // ceil(m), m >= 0
    if (steps < m) ++steps;
    if (steps < 1) return plot(b);
    const double step = 1 / static_cast<double>(steps);
    const double dx = (b.x - a.x) * step, dy = (b.y - a.y) * step;
    const auto dd = static_cast<float>((b.depth - a.depth) * step);
    const auto dt = static_cast<float>((b.shade - a.shade) * step);
    Pixel* px = pixels_.data();
    double x = a.x, y = a.y;
    float depth = a.depth, shade = a.shade;
    for (long k = steps; k > 0; --k) {
      x += dx, y += dy, depth += dd, shade += dt;
      plot(px, x, y, depth, shade);
    }
  }
  // A drawn sample's colour (0..1 each): copper from dark (bottom) to light (top), darker away
  // from the viewer.
  static void colour(float depth, float t, double rgb[3]) {
    const double k = 0.55 + 0.45 * depth;
    rgb[0] = k * (0.55 + 0.45 * t), rgb[1] = k * (0.25 + 0.45 * t), rgb[2] = k * (0.05 + 0.25 * t);
  }

  int width_, height_, ss_ = 1, w_ = 0, h_ = 0;
  View view_;
  double scale_ = 1, ox_ = 0, oy_ = 0, x_max_ = 0, y_max_ = 0;
  double d0_ = 0, d_range_ = 0, z0_ = 0, z_range_ = 0;
  double skipped_z_ = std::numeric_limits<double>::quiet_NaN();  // the lowest layer left out
  std::vector<Pixel> pixels_;
};

// A PNG of 8-bit RGBA rows (no filter; zlib's fastest level: a thumbnail is small and written
// once per G-code file).
std::string encode_png(const std::vector<std::uint8_t>& rgba, int width, int height) {
  std::string raw;
  raw.reserve(static_cast<std::size_t>(height) * (4 * static_cast<std::size_t>(width) + 1));
  for (int y = 0; y < height; ++y) {
    raw.push_back('\0');  // filter: none
    const auto* row =
        rgba.data() + static_cast<std::size_t>(y) * 4 * static_cast<std::size_t>(width);
    raw.append(reinterpret_cast<const char*>(row), 4 * static_cast<std::size_t>(width));
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size,
                reinterpret_cast<const Bytef*>(raw.data()), static_cast<uLong>(raw.size()),
                Z_BEST_SPEED) != Z_OK)
    throw IoError("cannot encode the thumbnail PNG");
  packed.resize(packed_size);
  std::string out("\x89PNG\r\n\x1a\n", 8);
  auto be32 = [&](std::string& s, std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) s.push_back(static_cast<char>(v >> shift & 0xff));
  };
  auto chunk = [&](const char* type, const std::string& data) {
    be32(out, static_cast<std::uint32_t>(data.size()));
    const std::string body = type + data;
    out += body;
    be32(out, static_cast<std::uint32_t>(crc32(0L, reinterpret_cast<const Bytef*>(body.data()),
                                               static_cast<uInt>(body.size()))));
  };
  std::string header;
  be32(header, static_cast<std::uint32_t>(width));
  be32(header, static_cast<std::uint32_t>(height));
  header +=
      std::string("\x08\x06\x00\x00\x00", 5);  // 8 bits, RGBA, deflate, no filter, no interlace
  chunk("IHDR", header);
  chunk("IDAT", packed);
  chunk("IEND", {});
  return out;
}

// std::lround of a value in 0 .. 255, without the call: x - trunc(x) is exact there, so the
// halves round up as lround rounds them.
std::uint8_t to_byte(double x) {
  auto i = static_cast<int>(x);
  if (x - i >= 0.5) ++i;
  return static_cast<std::uint8_t>(i);
}

std::string Canvas::png() const {
  // Each pixel: the mean colour of its drawn samples, as opaque as the share drawn.
  std::vector<std::uint8_t> rgba(4 * static_cast<std::size_t>(width_) *
                                 static_cast<std::size_t>(height_));
  for (int py = 0; py < height_; ++py)
    for (int px = 0; px < width_; ++px) {
      double sum[3] = {0, 0, 0};
      int drawn = 0;
      for (int sy = 0; sy < ss_; ++sy)
        for (int sx = 0; sx < ss_; ++sx) {
          const Pixel& p =
              pixels_[static_cast<std::size_t>(py * ss_ + sy) * static_cast<std::size_t>(w_) +
                      static_cast<std::size_t>(px * ss_ + sx)];
          if (p.depth <= 0) continue;
          double rgb[3];
          colour(p.depth, p.shade, rgb);
          for (int c = 0; c < 3; ++c) sum[c] += rgb[c];
          ++drawn;
        }
      auto* out = &rgba[4 * (static_cast<std::size_t>(py) * static_cast<std::size_t>(width_) +
                             static_cast<std::size_t>(px))];
      for (int c = 0; c < 3; ++c) out[c] = drawn ? to_byte(255 * sum[c] / drawn) : 0;
      out[3] = to_byte(255.0 * drawn / (ss_ * ss_));
    }
  return encode_png(rgba, width_, height_);
}

}  // namespace

std::vector<std::string> render_thumbnails_png(const LayerSource& layers,
                                               const std::vector<std::pair<int, int>>& sizes) {
  for (const auto& [width, height] : sizes)
    if (width < 1 || height < 1 || width > 4096 || height > 4096)
      throw SettingError("thumbnail size " + std::to_string(width) + "x" + std::to_string(height) +
                         " (1..4096 pixels each way)");
  Extent extent;
  layers([&](std::size_t, const Layer& l) { extent.add(l); });
  std::vector<Canvas> canvases;
  for (const auto& [width, height] : sizes) canvases.emplace_back(width, height, extent);
  if (!extent.empty()) {
    std::size_t k = 0;
    layers([&](std::size_t, const Layer& l) {
      const LayerSummary* next = k + 1 < extent.layers.size() ? &extent.layers[k + 1] : nullptr;
      for (Canvas& c : canvases)
        if (c.draws(extent.layers[k], next))
          for (const auto& p : l.paths) c.path(p);
      ++k;
    });
  }
  std::vector<std::string> out;
  for (const Canvas& c : canvases) out.push_back(c.png());
  return out;
}

std::string render_thumbnail_png(const Toolpath& toolpath, int width, int height) {
  return render_thumbnails_png(layers_of(toolpath), {{width, height}}).front();
}

std::string render_thumbnail_png(const LayerSource& layers, int width, int height) {
  return render_thumbnails_png(layers, {{width, height}}).front();
}

}  // namespace trellis
