#include <cairo.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/render/palette.hpp"
#include "trellis/render/render.hpp"

using namespace trellis;
namespace fs = std::filesystem;

static unsigned be32(const std::string& s, std::size_t at) {
  return (static_cast<unsigned char>(s[at]) << 24) | (static_cast<unsigned char>(s[at + 1]) << 16) |
         (static_cast<unsigned char>(s[at + 2]) << 8) | static_cast<unsigned char>(s[at + 3]);
}

TEST(Render, LayerPngHasTheAspectOfTheLayer) {
  Toolpath tp;
  Path p;
  p.points = {{0, 0, 0.2}, {20, 0, 0.2}, {20, 10, 0.2}};
  Path q;
  q.points = {{0, 10, 0.2}, {0, 2, 0.2}};
  tp.layers.push_back({0.2, {p, q}});
  const trellis::test::TempDir tmp("trellis_render");
  const std::string path = tmp.file("layer.png");
  RenderOptions o;
  o.size_px = 440;
  o.margin_mm = 1;
  render_layer_png(tp, 0, path, o);
  const std::string png = read_file(path);
  ASSERT_GT(png.size(), 100u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_EQ(be32(png, 16), 440u);  // width: 22 mm
  // height: 12 mm, plus the title band above and the legend band below
  EXPECT_EQ(be32(png, 20), 240u + 2 * layer_band_px(440));
  EXPECT_THROW(render_layer_png(tp, 3, path, o), SettingError);
  render_scores_png({0.1, 0.3, 0.2}, 1, "scores", path);
  EXPECT_EQ(read_file(path).substr(1, 3), "PNG");
}

namespace {

// A decoded PNG: RGB of every pixel.
struct Image {
  int w = 0, h = 0;
  std::vector<unsigned> px;  // 0xRRGGBB
  unsigned at(int x, int y) const { return px[static_cast<std::size_t>(y) * w + x]; }
};

Image decode(const std::string& path) {
  cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
  EXPECT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS);
  Image im;
  im.w = cairo_image_surface_get_width(s);
  im.h = cairo_image_surface_get_height(s);
  const int stride = cairo_image_surface_get_stride(s);
  const unsigned char* data = cairo_image_surface_get_data(s);
  for (int y = 0; y < im.h; ++y)
    for (int x = 0; x < im.w; ++x)
      im.px.push_back(*reinterpret_cast<const std::uint32_t*>(data + y * stride + 4 * x) &
                      0xffffff);
  cairo_surface_destroy(s);
  return im;
}

std::size_t count(const Image& im, int y0, int y1, unsigned rgb) {
  std::size_t n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < im.w; ++x) n += im.at(x, y) == rgb;
  return n;
}

// Longest run of black pixels in one row of the band [y0, y1).
int longest_black_run(const Image& im, int y0, int y1) {
  int best = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = 0, run = 0; x < im.w; ++x) {
      run = im.at(x, y) == 0 ? run + 1 : 0;
      best = std::max(best, run);
    }
  return best;
}

Toolpath two_features() {
  Toolpath tp;
  Path wall, fill;
  wall.role = PathRole::Contour;
  wall.points = {{0, 0, 0.2}, {40, 0, 0.2}, {40, 20, 0.2}, {0, 20, 0.2}, {0, 0, 0.2}};
  fill.role = PathRole::Infill;
  fill.points = {{2, 2, 0.2}, {38, 18, 0.2}};
  wall.width = fill.width = 0.4;
  tp.layers.push_back({0.2, {wall, fill}});
  tp.source = "two_features.json";
  return tp;
}

// Layer 0 of `tp` drawn 800 px wide with `o` (no margin): each categorical colour k in `ks`
// (render/palette.hpp tool_rgb) drawn in the 400 px of the layer and as a legend swatch, and no
// contour red in the drawing.
void expect_categories(const Toolpath& tp, RenderOptions o, std::initializer_list<int> ks) {
  const trellis::test::TempDir tmp("trellis_render_categories");
  const std::string path = tmp.file("layer.png");
  o.size_px = 800;
  o.margin_mm = 0;
  render_layer_png(tp, 0, path, o);
  const Image im = decode(path);
  const int band = layer_band_px(800);
  for (int k : ks) {
    const Rgb c = tool_rgb(k);
    const auto rgb = static_cast<unsigned>(c[0] << 16 | c[1] << 8 | c[2]);
    EXPECT_GT(count(im, band, band + 400, rgb), 100u) << "colour " << k;
    EXPECT_GT(count(im, band + 400, im.h, rgb), 20u) << "colour " << k << "'s swatch";
  }
  EXPECT_EQ(count(im, band, band + 400, 0xd62728), 0u);  // no feature colour (the contour's)
}

}  // namespace

// Every layer PNG explains itself: a title band with dark text, a legend band with a swatch of
// each feature type drawn and a scale bar whose length in pixels is a round number of mm.
TEST(Render, LayerPngHasTitleLegendAndScaleBar) {
  const Toolpath tp = two_features();
  const trellis::test::TempDir tmp("trellis_render_legend");
  const std::string path = tmp.file("layer.png");
  RenderOptions o;
  o.size_px = 800;
  o.margin_mm = 0;
  o.colour_by_role = true;
  render_layer_png(tp, 0, path, o);
  const Image im = decode(path);
  const int band = layer_band_px(800);
  ASSERT_EQ(im.h, 400 + 2 * band);  // 40 x 20 mm at 20 px/mm
  const unsigned contour = 0xd62728, infill = 0x2ca02c;
  // The drawing has both colours, and so has the legend band below it.
  EXPECT_GT(count(im, band, band + 400, contour), 100u);
  EXPECT_GT(count(im, band, band + 400, infill), 100u);
  EXPECT_GT(count(im, band + 400, im.h, contour), 20u);
  EXPECT_GT(count(im, band + 400, im.h, infill), 20u);
  // Title text, two lines (the file; layer, Z and what colour means): dark pixels in each.
  auto dark = [&](int y0, int y1) {
    std::size_t n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < im.w; ++x) {
        const unsigned c = im.at(x, y);
        n += (c >> 16) < 0x60 && ((c >> 8) & 0xff) < 0x60 && (c & 0xff) < 0x60;
      }
    return n;
  };
  EXPECT_GT(dark(0, band * 55 / 100), 50u);
  EXPECT_GT(dark(band * 6 / 10, band), 50u);
  // Scale bar: 0.25 of 40 mm rounds down to 10 mm = 200 px at 20 px/mm.
  EXPECT_NEAR(longest_black_run(im, band + 400, im.h), 200, 2);
}

// Colour by tool (the lasers of a multi-laser build file): each path in its tool's colour of the
// palette, before its feature type, and a swatch per tool drawn in the legend band.
TEST(Render, LayerPngColouredByTool) {
  Toolpath tp = two_features();
  tp.layers[0].paths[0].tool = 0;  // the contour on laser 1, the hatch on laser 2
  tp.layers[0].paths[1].tool = 1;
  ASSERT_NE(tool_rgb(0), tool_rgb(1));
  RenderOptions o;
  o.colour_by_role = true;
  o.colour_by_tool = true;
  o.tools_are_lasers = true;
  expect_categories(tp, o, {0, 1});
}

// By laser parameter set: two hatches of one role told apart by their power and speed (the
// toolpath's named sets), the contour in no named set its own; each a colour in the drawing and
// a swatch in the legend, none of the role's colour.
TEST(Render, LayerPngColouredByParameterSet) {
  Toolpath tp = two_features();
  Path& fill = tp.layers[0].paths[1];
  fill.role = PathRole::Hatch;
  fill.power = 100, fill.speed = 1000;
  Path core = fill;
  core.points = {{2, 18, 0.2}, {38, 2, 0.2}};
  core.power = 180, core.speed = 1200;
  tp.layers[0].paths.push_back(core);
  tp.layers[0].paths[0].power = 60;
  tp.parameter_sets = {{"hatch", PathRole::Hatch, 100, 1000},
                       {"core hatch", PathRole::Hatch, 180, 1200}};
  RenderOptions o;
  o.colour_by_set = true;
  o.colour_by_tool = true;  // the set wins
  o.starts = false;
  expect_categories(tp, o, {0, 1, 2});  // hatch, core hatch, then the contour's own
}

// Print order: the legend band carries a colour bar (many distinct colours).
TEST(Render, LayerPngOrderHasColourBar) {
  const Toolpath tp = two_features();
  const trellis::test::TempDir tmp("trellis_render_bar");
  const std::string path = tmp.file("layer.png");
  RenderOptions o;
  o.size_px = 800;
  render_layer_png(tp, 0, path, o);
  const Image im = decode(path);
  std::set<unsigned> colours;
  const int band = layer_band_px(800);
  for (int y = im.h - band; y < im.h; ++y)
    for (int x = 0; x < im.w; ++x) {
      const unsigned c = im.at(x, y);
      const int r = c >> 16, g = (c >> 8) & 0xff, b = c & 0xff;
      if (std::max({r, g, b}) - std::min({r, g, b}) > 60) colours.insert(c);
    }
  EXPECT_GT(colours.size(), 50u);
}

// The 3D view and the analysis overlay carry a legend band too: the 3D view a print-order colour
// bar and a scale bar, the overlay a swatch for each of its four colours and a scale bar.
TEST(Render, ThreeDAndOverlayHaveLegends) {
  const Toolpath tp = two_features();
  const trellis::test::TempDir tmp("trellis_render_3d");
  const std::string p3 = tmp.file("3d.png"), po = tmp.file("overlay.png");
  View3dOptions v;
  v.size_px = 800;
  render_3d_png(tp, p3, v);
  const Image a = decode(p3);
  const int band = layer_band_px(800);
  std::set<unsigned> colours;
  for (int y = a.h - band; y < a.h; ++y)
    for (int x = 0; x < a.w; ++x) {
      const unsigned c = a.at(x, y);
      const int r = c >> 16, g = (c >> 8) & 0xff, b = c & 0xff;
      if (std::max({r, g, b}) - std::min({r, g, b}) > 60) colours.insert(c);
    }
  EXPECT_GT(colours.size(), 50u);
  EXPECT_GT(longest_black_run(a, a.h - band, a.h), 40);
  render_overlay_png({{{0, 0}, {40, 0}}}, tp.layers[0], {{{0, 20}, {40, 20}}},
                     {{{0, 10}, {40, 10}}}, 0.4, po, 800);
  const Image o = decode(po);
  auto near = [&](int y0, int y1, int r, int g, int b) {
    std::size_t n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < o.w; ++x) {
        const unsigned c = o.at(x, y);
        n += std::abs(int(c >> 16) - r) < 8 && std::abs(int((c >> 8) & 0xff) - g) < 8 &&
             std::abs(int(c & 0xff) - b) < 8;
      }
    return n;
  };
  EXPECT_GT(near(o.h - band, o.h, 230, 25, 25), 50u);    // deposited twice
  EXPECT_GT(near(o.h - band, o.h, 25, 76, 242), 50u);    // missing strut
  EXPECT_GT(near(o.h - band, o.h, 217, 217, 217), 50u);  // design
  EXPECT_NEAR(longest_black_run(o, o.h - band, o.h), 10 * 800 / 42.0,
              2);  // 10 mm; 42 mm wide with margins
}

// 3D views coloured by height: one path climbing from z 0 to 10 is drawn in many colours (by
// print order it is one colour), and the legend band holds the height colour bar; coloured by
// tool (the two-material non-planar groups), each tool's colour is in the drawing and as a
// legend swatch.
TEST(Render, ThreeDHeightColourBarAndToolGroups) {
  const trellis::test::TempDir tmp("trellis_render_3d_height");
  Toolpath ramp;
  Path up;
  for (int i = 0; i <= 50; ++i) up.points.push_back({i * 0.8, 0, i * 0.2});
  ramp.layers.push_back({0, {up}});
  const int band = layer_band_px(800);
  auto saturated = [](const Image& im, int y0, int y1) {
    std::set<unsigned> colours;
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < im.w; ++x) {
        const unsigned c = im.at(x, y);
        const int r = c >> 16, g = (c >> 8) & 0xff, b = c & 0xff;
        if (std::max({r, g, b}) - std::min({r, g, b}) > 60) colours.insert(c);
      }
    return colours.size();
  };
  View3dOptions v;
  v.size_px = 800;
  v.colour = View3dOptions::Colour::Height;
  render_3d_png(ramp, tmp.file("height.png"), v);
  const Image h = decode(tmp.file("height.png"));
  v.colour = View3dOptions::Colour::Order;
  render_3d_png(ramp, tmp.file("order.png"), v);
  const Image o = decode(tmp.file("order.png"));
  // The top of the ramp has the bar's high-end colour and its foot the low end's (the palette's
  // continuous map); by print order the one path has one colour, not the high end.
  auto count_if = [](const Image& im, int y0, int y1, auto pred) {
    std::size_t n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < im.w; ++x) {
        const unsigned c = im.at(x, y);
        n += pred(int(c >> 16), int((c >> 8) & 0xff), int(c & 0xff));
      }
    return n;
  };
  auto near_rgb = [](const Rgb& c) {
    return [c](int r, int g, int b) {
      return std::abs(r - c[0]) <= 3 && std::abs(g - c[1]) <= 3 && std::abs(b - c[2]) <= 3;
    };
  };
  // The last segment's mid z is 9.9 of 10, the first's 0.1.
  const auto red = near_rgb(continuous_rgb(0.99)), blue = near_rgb(continuous_rgb(0.01));
  EXPECT_GT(count_if(h, 0, h.h - band, red), 4u);  // each about 0.8 mm long
  EXPECT_GT(count_if(h, 0, h.h - band, blue), 4u);
  EXPECT_LT(count_if(o, 0, o.h - band, red), 5u);
  EXPECT_GT(saturated(h, h.h - band, h.h), 50u);         // the colour bar
  EXPECT_GT(longest_black_run(h, h.h - band, h.h), 40);  // the scale bar

  Toolpath two;
  Path a, b;
  a.points = {{0, 0, 0}, {20, 0, 1}, {20, 20, 2}};
  b.points = {{0, 5, 0}, {15, 5, 3}, {15, 15, 1}};
  b.tool = 1;
  two.layers.push_back({0, {a, b}});
  v.colour = View3dOptions::Colour::Tool;
  render_3d_png(two, tmp.file("tools.png"), v);
  const Image t = decode(tmp.file("tools.png"));
  auto near = [&](int y0, int y1, unsigned rgb) {
    std::size_t n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < t.w; ++x) {
        const unsigned c = t.at(x, y);
        n += std::abs(int(c >> 16) - int(rgb >> 16)) < 10 &&
             std::abs(int((c >> 8) & 0xff) - int((rgb >> 8) & 0xff)) < 10 &&
             std::abs(int(c & 0xff) - int(rgb & 0xff)) < 10;
      }
    return n;
  };
  for (unsigned tool : {0x1f77b4u, 0xff7f0eu}) {
    EXPECT_GT(near(0, t.h - band, tool), 100u) << std::hex << tool;
    EXPECT_GT(count(t, t.h - band, t.h, tool), 20u) << std::hex << tool;  // legend swatch
  }
}

// One picture language: a layer PNG coloured by mixture draws fractions 0, 0.5 and 1 in the
// colours the viewer computes for them (viewer/src/colors.js: mixColor, a round-half-up blend of
// the two mixture2 colours of src/render/palette.json, the file both bundle), pixel for pixel;
// the legend band's bar runs between the same two colours; feature types use the palette's
// role colours, the new laser and non-planar roles included.
TEST(Render, MixtureAndRolePixelsAreTheViewersColours) {
  const auto json = nlohmann::json::parse(
      read_file(std::string(TRELLIS_SOURCE_DIR) + "/src/render/palette.json"));
  auto viewer_mix = [&](double t) {  // colors.js mixColor, written out again
    const auto& a = json["mixture2"][0];
    const auto& b = json["mixture2"][1];
    unsigned rgb = 0;
    for (int i = 0; i < 3; ++i) {
      const double v = a[i].get<double>() + (b[i].get<double>() - a[i].get<double>()) * t;
      rgb = rgb << 8 | static_cast<unsigned>(std::floor(v + 0.5));
    }
    return rgb;
  };
  Toolpath tp;
  Layer layer{0.2, {}};
  const double fractions[] = {0, 0.5, 1};
  for (int i = 0; i < 3; ++i) {
    Path p;
    p.points = {{0, 4.0 * i, 0.2}, {30, 4.0 * i, 0.2}};
    p.width = 2;
    p.mixture = {fractions[i], 1 - fractions[i]};
    layer.paths.push_back(p);
  }
  tp.layers.push_back(layer);
  const trellis::test::TempDir tmp("trellis_render_palette");
  RenderOptions o;
  o.size_px = 600;
  o.colour_by_mixture = true;
  o.travel = false;
  o.starts = false;
  render_layer_png(tp, 0, tmp.file("mix.png"), o);
  const Image im = decode(tmp.file("mix.png"));
  const int band = layer_band_px(600);
  const double scale = 600.0 / 32;  // 30 mm + 2 mm of margin
  std::set<unsigned> seen;
  for (int i = 0; i < 3; ++i) {
    // The middle of line i: x = 15 mm, y = 4 i mm (y up, from the bottom of the drawing).
    const int x = static_cast<int>(std::lround((15 + 1) * scale)) +
                  (im.w - static_cast<int>(std::ceil(32 * scale))) / 2;
    const int y = band + static_cast<int>(std::ceil((8 + 2) * scale)) -
                  static_cast<int>(std::lround((4.0 * i + 1) * scale));
    const unsigned px = im.at(x, y);
    EXPECT_EQ(px, viewer_mix(fractions[i]))
        << "mixture " << fractions[i] << std::hex << " pixel " << px;
    const Rgb c = mixture_rgb(fractions[i]);
    EXPECT_EQ(px, unsigned(c[0] << 16 | c[1] << 8 | c[2]));
    seen.insert(px);
  }
  EXPECT_EQ(seen.size(), 3u);
  // The legend's bar runs between the same two colours (its 1 px columns sit at fractional x, so
  // within 3 of them).
  auto near = [&](unsigned rgb) {
    std::size_t n = 0;
    for (int y = im.h - band; y < im.h; ++y)
      for (int x = 0; x < im.w; ++x) {
        const unsigned c = im.at(x, y);
        bool close = true;
        for (int s = 0; s < 24; s += 8)
          close = close && std::abs(int((c >> s) & 0xff) - int((rgb >> s) & 0xff)) <= 3;
        n += close;
      }
    return n;
  };
  EXPECT_GT(near(viewer_mix(0)), 5u);
  EXPECT_GT(near(viewer_mix(1)), 5u);

  // Feature types: each role's palette colour in the drawing and as a legend swatch.
  Toolpath roles;
  Layer rl{0.2, {}};
  const PathRole shown[] = {PathRole::Hatch, PathRole::Nonplanar, PathRole::Contour};
  for (int i = 0; i < 3; ++i) {
    Path p;
    p.points = {{0, 4.0 * i, 0.2}, {30, 4.0 * i, 0.2}};
    p.width = 2;
    p.role = shown[i];
    rl.paths.push_back(p);
  }
  roles.layers.push_back(rl);
  o.colour_by_mixture = false;
  o.colour_by_role = true;
  render_layer_png(roles, 0, tmp.file("roles.png"), o);
  const Image r = decode(tmp.file("roles.png"));
  for (const PathRole role : shown) {
    const auto& entry = json["roles"][static_cast<std::size_t>(role)];
    ASSERT_EQ(entry[0].get<std::string>(), to_string(role));
    const unsigned rgb = entry[1][0].get<unsigned>() << 16 | entry[1][1].get<unsigned>() << 8 |
                         entry[1][2].get<unsigned>();
    EXPECT_GT(count(r, band, r.h - band, rgb), 500u) << to_string(role);
    EXPECT_GT(count(r, r.h - band, r.h, rgb), 20u) << to_string(role);
  }
}
