// G-code thumbnails (render/thumbnail.cpp) against a plain renderer written from their
// description: every layer's summary, the same layer skipping, every point projected in full
// and every segment stepped in doubles, std::ceil and std::lround. The fast renderer must give the
// same pixels on many generated toolpaths and sizes (its speed-ups must not move a pixel).
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "trellis/render/render.hpp"

using namespace trellis;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct RefView {
  double sa = std::sin(-90 * M_PI / 180), ca = std::cos(-90 * M_PI / 180);
  double se = std::sin(30 * M_PI / 180), ce = std::cos(30 * M_PI / 180);
  void operator()(Vec3 p, double& u, double& v, double& d) const {
    const double across = p.x * ca + p.y * sa;
    u = -p.x * sa + p.y * ca, v = -across * se + p.z * ce, d = across * ce + p.z * se;
  }
};

// The plain renderer: RGBA rows of one thumbnail.
std::vector<std::uint8_t> reference(const Toolpath& tp, int width, int height) {
  RefView view;
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300, d0 = 1e300, d1 = -1e300, z0 = 1e300,
         z1 = -1e300;
  std::vector<double> flat, length;
  for (const Layer& l : tp.layers) {
    double f = kNaN, len = 0;
    bool first = true;
    for (const Path& p : l.paths)
      for (std::size_t k = 0; k < p.points.size(); ++k) {
        const Vec3 q = p.points[k];
        double u, v, d;
        view(q, u, v, d);
        u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
        d0 = std::min(d0, d), d1 = std::max(d1, d), z0 = std::min(z0, q.z), z1 = std::max(z1, q.z);
        if (first) f = q.z, first = false;
        if (q.z != f) f = kNaN;
        if (k > 0) len += norm(q - p.points[k - 1]);
      }
    flat.push_back(f);
    length.push_back(len);
  }
  const int ss = std::clamp(48 / std::max(width, height), 1, 3), w = width * ss, h = height * ss;
  std::vector<float> depth(static_cast<std::size_t>(w) * h, 0), shade(depth.size(), 0);
  if (u0 <= u1) {
    const double margin = 0.05 * std::max(u1 - u0, v1 - v0) + 1e-6;
    const double fw = u1 - u0 + 2 * margin, fh = v1 - v0 + 2 * margin;
    const double scale = std::min(w / fw, h / fh);
    const double ox = (w - fw * scale) / 2 - (u0 - margin) * scale;
    const double oy = h - (h - fh * scale) / 2 + (v0 - margin) * scale;
    struct S {
      double x, y;
      float d, t;
    };
    auto sample = [&](Vec3 p) {
      double u, v, d;
      view(p, u, v, d);
      const double dd = d1 - d0 > 0 ? (d - d0) / (d1 - d0) : 1.0;
      const double t = z1 > z0 ? (p.z - z0) / (z1 - z0) : 1.0;
      return S{std::clamp(ox + u * scale + 0.5, 0.0, w - 0.01),
               std::clamp(oy - v * scale + 0.5, 0.0, h - 0.01),
               static_cast<float>(0.01 + 0.99 * dd), static_cast<float>(t)};
    };
    auto plot = [&](double x, double y, float d, float t) {
      const std::size_t i =
          static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      if (d > depth[i]) depth[i] = d, shade[i] = t;
    };
    double skipped = kNaN;
    for (std::size_t li = 0; li < tp.layers.size(); ++li) {
      const bool has_next = li + 1 < tp.layers.size();
      if (has_next && !std::isnan(flat[li]) && !std::isnan(flat[li + 1]) &&
          length[li + 1] >= 0.9 * length[li]) {
        if (std::isnan(skipped)) skipped = flat[li];
        if (std::abs(flat[li + 1] - skipped) * view.ce * scale < 0.5) continue;
      }
      skipped = kNaN;
      for (const Path& p : tp.layers[li].paths) {
        if (p.points.size() < 2) continue;
        S last = sample(p.points[0]);
        plot(last.x, last.y, last.d, last.t);
        for (std::size_t k = 1; k < p.points.size(); ++k) {
          const S s = sample(p.points[k]);
          if (k + 1 < p.points.size() && std::abs(s.x - last.x) < 1 && std::abs(s.y - last.y) < 1)
            continue;
          const double n = std::ceil(std::max(std::abs(s.x - last.x), std::abs(s.y - last.y)));
          if (n < 1) {
            plot(s.x, s.y, s.d, s.t);
          } else {
            double x = last.x, y = last.y;
            float d = last.d, t = last.t;
            const double step = 1 / n;
            const auto dd = static_cast<float>((s.d - last.d) * step);
            const auto dt = static_cast<float>((s.t - last.t) * step);
            const double sx = (s.x - last.x) * step, sy = (s.y - last.y) * step;
            for (long k2 = static_cast<long>(n); k2 > 0; --k2) {
              x += sx, y += sy, d += dd, t += dt;
              plot(x, y, d, t);
            }
          }
          last = s;
        }
      }
    }
  }
  std::vector<std::uint8_t> rgba(4 * static_cast<std::size_t>(width) * height);
  for (int py = 0; py < height; ++py)
    for (int px = 0; px < width; ++px) {
      double sum[3] = {0, 0, 0};
      int drawn = 0;
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          const std::size_t i = static_cast<std::size_t>(py * ss + sy) * w + (px * ss + sx);
          if (depth[i] <= 0) continue;
          const double k = 0.55 + 0.45 * depth[i], t = shade[i];
          sum[0] += k * (0.55 + 0.45 * t), sum[1] += k * (0.25 + 0.45 * t);
          sum[2] += k * (0.05 + 0.25 * t);
          ++drawn;
        }
      auto* out = &rgba[4 * (static_cast<std::size_t>(py) * width + px)];
      for (int c = 0; c < 3; ++c)
        out[c] = static_cast<std::uint8_t>(drawn ? std::lround(255 * sum[c] / drawn) : 0);
      out[3] = static_cast<std::uint8_t>(std::lround(255.0 * drawn / (ss * ss)));
    }
  return rgba;
}

unsigned be32(const std::string& s, std::size_t at) {
  return (static_cast<unsigned char>(s[at]) << 24) | (static_cast<unsigned char>(s[at + 1]) << 16) |
         (static_cast<unsigned char>(s[at + 2]) << 8) | static_cast<unsigned char>(s[at + 3]);
}

// A PNG's RGBA rows read back (IHDR's size; IDAT inflated; every row's filter byte 0 or undone
// here for Sub/Up so that the check does not depend on the encoder's filter choice).
std::vector<std::uint8_t> decode(const std::string& png, int& width, int& height) {
  std::string idat;
  for (std::size_t at = 8; at + 12 <= png.size();) {
    const unsigned n = be32(png, at);
    const std::string type = png.substr(at + 4, 4);
    if (type == "IHDR")
      width = static_cast<int>(be32(png, at + 8)), height = static_cast<int>(be32(png, at + 12));
    if (type == "IDAT") idat += png.substr(at + 8, n);
    at += 12 + n;
  }
  const std::size_t stride = 4 * static_cast<std::size_t>(width);
  std::vector<std::uint8_t> raw((stride + 1) * height);
  uLongf size = static_cast<uLongf>(raw.size());
  EXPECT_EQ(uncompress(raw.data(), &size, reinterpret_cast<const Bytef*>(idat.data()),
                       static_cast<uLong>(idat.size())),
            Z_OK);
  EXPECT_EQ(size, raw.size());
  std::vector<std::uint8_t> rgba(stride * height);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t filter = raw[y * (stride + 1)];
    EXPECT_LE(filter, 2);
    for (std::size_t x = 0; x < stride; ++x) {
      std::uint8_t v = raw[y * (stride + 1) + 1 + x];
      if (filter == 1 && x >= 4) v = static_cast<std::uint8_t>(v + rgba[y * stride + x - 4]);
      if (filter == 2 && y > 0) v = static_cast<std::uint8_t>(v + rgba[(y - 1) * stride + x]);
      rgba[y * stride + x] = v;
    }
  }
  return rgba;
}

// A part-like toolpath: flat layers of closed loops and infill lines whose size changes slowly
// (so that many layers are left out), some layers ending features, some paths not flat (so that
// their layers are drawn), short and repeated points, one-point paths.
Toolpath generated(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  Toolpath tp;
  const int layers = 1 + static_cast<int>(u(rng) * 120);
  const double h = 0.05 + 0.3 * u(rng), cx = 50 + 200 * u(rng), cy = 50 + 200 * u(rng);
  const double r0 = 1 + 60 * u(rng);
  for (int i = 0; i < layers; ++i) {
    Layer l;
    const double z = 0.2 + i * h;
    l.z = z;
    const double r =
        r0 * (0.6 + 0.4 * std::sin(i * 0.05 + u(rng) * 0.02)) * (u(rng) < 0.05 ? 0.5 : 1);
    Path loop;
    const int n = 3 + static_cast<int>(u(rng) * 80);
    for (int k = 0; k <= n; ++k) {
      const double a = 2 * M_PI * k / n;
      loop.points.push_back({cx + r * std::cos(a), cy + 0.7 * r * std::sin(a), z});
      if (u(rng) < 0.1) loop.points.push_back(loop.points.back());  // a repeated point
    }
    l.paths.push_back(loop);
    const int lines = static_cast<int>(u(rng) * 12);
    for (int k = 0; k < lines; ++k) {
      Path line;
      const double y = cy - 0.6 * r + 1.2 * r * k / std::max(lines, 1);
      line.points.push_back({cx - 0.8 * r, y, z});
      if (u(rng) < 0.3) line.points.push_back({cx + 0.01 * r * u(rng), y + 0.001, z});
      line.points.push_back({cx + 0.8 * r, y, z});
      l.paths.push_back(line);
    }
    if (u(rng) < 0.08) {  // not flat: a ramp
      Path ramp;
      ramp.points = {{cx, cy, z}, {cx + r, cy + r, z + 0.5 * h}};
      l.paths.push_back(ramp);
    }
    if (u(rng) < 0.05) l.paths.push_back(Path{{{cx, cy, z}}});  // a single point
    tp.layers.push_back(std::move(l));
  }
  return tp;
}

TEST(Thumbnail, PixelsAsThePlainRenderer) {
  std::mt19937 rng(40);
  const std::vector<std::pair<int, int>> sizes = {{16, 16}, {220, 124}, {1, 1},  {7, 300},
                                                  {48, 17}, {300, 300}, {25, 25}};
  int checked = 0, drawn = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const Toolpath tp = generated(rng);
    const std::vector<std::string> pngs = render_thumbnails_png(layers_of(tp), sizes);
    ASSERT_EQ(pngs.size(), sizes.size());
    for (std::size_t i = 0; i < sizes.size(); ++i) {
      int w = 0, h = 0;
      const std::vector<std::uint8_t> got = decode(pngs[i], w, h);
      ASSERT_EQ(w, sizes[i].first);
      ASSERT_EQ(h, sizes[i].second);
      const std::vector<std::uint8_t> want = reference(tp, w, h);
      std::size_t differ = 0;
      for (std::size_t k = 0; k < got.size(); ++k) differ += got[k] != want[k];
      EXPECT_EQ(differ, 0u) << "trial " << trial << ", " << w << "x" << h;
      for (std::size_t k = 3; k < got.size(); k += 4) drawn += got[k] > 0;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 60 * 7);
  EXPECT_GT(drawn, 100000);  // the pictures are not empty
}

TEST(Thumbnail, OnePictureAlsoAsThePlainRenderer) {
  std::mt19937 rng(41);
  for (int trial = 0; trial < 10; ++trial) {
    const Toolpath tp = generated(rng);
    int w = 0, h = 0;
    const std::vector<std::uint8_t> got = decode(render_thumbnail_png(tp, 220, 124), w, h);
    EXPECT_EQ(got, reference(tp, 220, 124)) << "trial " << trial;
  }
}

}  // namespace
