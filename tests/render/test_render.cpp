#include <gtest/gtest.h>

#include <filesystem>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
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
  EXPECT_EQ(be32(png, 20), 240u);  // height: 12 mm
  EXPECT_THROW(render_layer_png(tp, 3, path, o), SettingError);
  render_scores_png({0.1, 0.3, 0.2}, 1, "scores", path);
  EXPECT_EQ(read_file(path).substr(1, 3), "PNG");
}
