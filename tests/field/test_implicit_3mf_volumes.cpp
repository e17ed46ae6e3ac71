// 3MF designs beyond a single function graph: volumetric image stacks (<functionfromimage3d> over
// an <image3d> of PNG sheets, Part I ch. 2-3), objects made of components, and the mesh and
// unsignedmesh nodes (Part II ch. 5). Each is checked against the analytic field it encodes, and
// each malformed package is refused naming the part, line and column.
#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "support/cli_run.hpp"
#include "support/implicit_3mf.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/implicit_3mf.hpp"

using namespace trellis;
using namespace trellis::test;

namespace {

// ---- PNG sheets written with libpng

void on_write(png_structp p, png_bytep data, png_size_t n) {
  static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(data), n);
}

// A PNG of `channels` (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA) of `bits` (8 or 16), the values row
// by row from the top, channels interleaved.
std::string png(int width, int height, int channels, int bits,
                const std::vector<std::uint16_t>& values) {
  std::string out;
  png_structp p = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(p);
  std::vector<png_byte> row(static_cast<std::size_t>(width * channels * bits / 8));
  if (setjmp(png_jmpbuf(p))) {
    png_destroy_write_struct(&p, &info);
    ADD_FAILURE() << "libpng could not write the sheet";
    return {};
  }
  const int types[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                        PNG_COLOR_TYPE_RGB_ALPHA};
  png_set_write_fn(p, &out, on_write, nullptr);
  png_set_IHDR(p, info, width, height, bits, types[channels], PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(p, info);
  const std::size_t per_row = static_cast<std::size_t>(width * channels);
  for (int r = 0; r < height; ++r) {
    for (std::size_t i = 0; i < per_row; ++i) {
      const std::uint16_t v = values[static_cast<std::size_t>(r) * per_row + i];
      if (bits == 16)
        row[2 * i] = static_cast<png_byte>(v >> 8), row[2 * i + 1] = static_cast<png_byte>(v);
      else
        row[i] = static_cast<png_byte>(v);
    }
    png_write_row(p, row.data());
  }
  png_write_end(p, nullptr);
  png_destroy_write_struct(&p, &info);
  return out;
}

struct Stack {
  int columns = 0, rows = 0, sheets = 0;
  std::vector<std::pair<std::string, std::string>> parts;  // sheet part name, PNG
  // The <image3d> resource `id` listing the sheets.
  std::string xml(int id) const {
    std::string s = "<v:image3d id=\"" + std::to_string(id) + "\"><v:imagestack rowcount=\"" +
                    std::to_string(rows) + "\" columncount=\"" + std::to_string(columns) +
                    "\" sheetcount=\"" + std::to_string(sheets) + "\">\n";
    for (const auto& [name, bytes] : parts) s += "<v:imagesheet path=\"/" + name + "\"/>\n";
    return s + "</v:imagestack></v:image3d>\n";
  }
};

// A stack of `n` sheets of w × h pixels, value(row, column, sheet, channel) per pixel.
Stack make_stack(int w, int h, int n, int channels, int bits,
                 const std::function<std::uint16_t(int, int, int, int)>& value) {
  Stack st{w, h, n, {}};
  for (int k = 0; k < n; ++k) {
    std::vector<std::uint16_t> v;
    for (int i = 0; i < h; ++i)
      for (int j = 0; j < w; ++j)
        for (int c = 0; c < channels; ++c) v.push_back(value(i, j, k, c));
    char name[64];
    std::snprintf(name, sizeof name, "3D/volumetric/stack/sheet%04d.png", k);
    st.parts.emplace_back(name, png(w, h, channels, bits, v));
  }
  return st;
}

const std::string kHead =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<model unit=\"millimeter\" "
    "xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\" "
    "xmlns:v=\"http://schemas.3mf.io/3dmanufacturing/volumetric/2022/01\" "
    "xmlns:i=\"http://schemas.3mf.io/3dmanufacturing/implicit/2023/12\" "
    "xmlns:p=\"http://schemas.microsoft.com/3dmanufacturing/production/2015/06\" "
    "requiredextensions=\"v i\">\n<resources>\n";

// A model whose build places object `object` (other resources in `resources`; object 1 is the
// box mesh [lo, hi]³ every level set here is evaluated in).
std::string model_of(const std::string& resources, double lo, double hi, int object = 3) {
  return kHead + "<object id=\"1\" type=\"model\">" + box_mesh({lo, lo, lo}, {hi, hi, hi}) +
         "</object>\n" + resources + "</resources>\n<build><item objectid=\"" +
         std::to_string(object) + "\"/></build>\n</model>\n";
}

std::string level_set(int object, int function, const std::string& channel,
                      const std::string& attrs = "") {
  return "<object id=\"" + std::to_string(object) + "\" type=\"model\"><v:levelset functionid=\"" +
         std::to_string(function) + "\" channel=\"" + channel +
         "\" meshid=\"1\" meshbboxonly=\"true\"" + attrs + "/></object>\n";
}

// The sphere |p| − 6 sampled at the voxel centres of the cube [-8, 8]³ in n³ voxels, 16-bit grey
// V = (d + 16) / 32 (the function's valuescale 32, valueoffset −16 give d back).
constexpr double kHalf = 8, kRadius = 6;
Stack sphere_stack(int n) {
  return make_stack(n, n, n, 1, 16, [n](int i, int j, int k, int) {
    auto centre = [n](int index) { return -kHalf + 2 * kHalf * (index + 0.5) / n; };
    const double x = centre(j), y = centre(n - 1 - i), z = centre(k);  // row 0 is the top
    const double d = std::sqrt(x * x + y * y + z * z) - kRadius;
    return static_cast<std::uint16_t>(std::lround((d + 16) / 32 * 65535));
  });
}

// Object → uvw of that cube: u = (x + 8) / 16 (3MF matrices: row vectors, translation last).
const std::string kToUvw = " transform=\"0.0625 0 0 0 0.0625 0 0 0 0.0625 0.5 0.5 0.5\"";

std::string image_function(int id, const std::string& attrs) {
  return "<v:functionfromimage3d id=\"" + std::to_string(id) + "\" image3did=\"4\"" + attrs +
         "/>\n";
}

std::string sphere_image_model(const Stack& st, const std::string& filter) {
  return model_of(
      st.xml(4) +
          image_function(2, " valuescale=\"32\" valueoffset=\"-16\" filter=\"" + filter +
                                "\" tilestyleu=\"clamp\" "
                                "tilestylev=\"clamp\" tilestylew=\"clamp\"") +
          level_set(3, 2, "red", kToUvw),
      -kHalf, kHalf);
}

// Calls `check(p, value)` at n random points of [-r, r]³.
void at_random_points(const Field& f, double r, int n, unsigned seed,
                      const std::function<void(Vec3, double)>& check) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-r, r);
  Evaluator e(f);
  for (int i = 0; i < n; ++i) {
    const Vec3 p{u(rng), u(rng), u(rng)};
    check(p, e.value(p));
  }
}

double length(Vec3 p) {
  return std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
}

// The ParseError reading `path` throws; fails the test when it reads.
ParseError refusal(const std::string& path) {
  try {
    read_implicit_3mf(path);
  } catch (const ParseError& e) {
    return e;
  }
  ADD_FAILURE() << path << " read";
  return ParseError("", {});
}

long line_of(const std::string& text, const std::string& marker) {
  const auto at = text.find(marker);
  EXPECT_NE(at, std::string::npos) << marker;
  return 1 +
         static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

struct Refused {
  std::string name, model, marker, says;
  std::vector<std::pair<std::string, std::string>> parts;
};

void expect_refusals(const std::vector<Refused>& cases) {
  test::TempDir dir("implicit3mf_volumes");
  for (const Refused& c : cases) {
    const std::string path = dir.file("bad.3mf");
    write_3mf(path, c.model, c.parts);
    const ParseError e = refusal(path);
    const std::string what = e.what();
    EXPECT_NE(what.find(c.says), std::string::npos) << c.name << ": " << what;
    EXPECT_NE(what.find("/3D/3dmodel.model"), std::string::npos) << c.name << ": " << what;
    EXPECT_EQ(e.where().line, line_of(c.model, c.marker)) << c.name << ": " << what;
    EXPECT_GT(e.where().column, 0) << c.name;
  }
}

}  // namespace

// A sphere's distance stored in 33 PNG sheets reads back as the sphere: linear filtering within
// 0.03 mm of |p| − 6 away from the centre (trilinear error ≤ h²/(4(|p| − h)), h = 16/33), nearest
// within half a voxel's diagonal, and the sign right wherever the surface is farther than a voxel.
TEST(Implicit3mfVolumes, ImageStackOfASphereReadsAsTheSphere) {
  test::TempDir dir("implicit3mf_volumes");
  const int n = 33;
  const double h = 2 * kHalf / n;
  const Stack st = sphere_stack(n);
  for (const std::string filter : {"linear", "nearest"}) {
    const std::string path = dir.file(filter + ".3mf");
    write_3mf(path, sphere_image_model(st, filter), st.parts);
    ASSERT_TRUE(is_implicit_3mf(path));
    const VcadDesign d = read_implicit_3mf(path);
    int checked = 0;
    at_random_points(d.field, kHalf - h / 2, 4000, 17, [&](Vec3 p, double v) {
      const double exact = length(p) - kRadius;
      if (std::abs(exact) > h) {
        EXPECT_EQ(v < 0, exact < 0) << filter << " " << p.x << " " << p.y << " " << p.z;
      }
      if (filter == "nearest") {
        EXPECT_NEAR(v, exact, h * std::sqrt(3.0) / 2 + 1e-3) << p.x << " " << p.y << " " << p.z;
      } else if (length(p) > 4) {
        EXPECT_NEAR(v, exact, 0.03) << p.x << " " << p.y << " " << p.z;
        ++checked;
      }
    });
    if (filter == "linear") {
      EXPECT_GT(checked, 2000);
    }
  }
}

// Sliced, the image stack's sphere is the analytic sphere's part within a voxel: the same
// layers, each layer's extrusion box within one voxel, the extruded length within 2 %.
TEST(Implicit3mfVolumes, ImageStackSlicesToTheAnalyticSphere) {
  test::TempDir dir("implicit3mf_volumes");
  const int n = 33;
  const double h = 2 * kHalf / n;
  const Stack st = sphere_stack(n);
  const std::string image = dir.file("image.3mf"), exact = dir.file("exact.3mf");
  write_3mf(image, sphere_image_model(st, "linear"), st.parts);
  write_3mf(exact, model_of(sphere_function(kRadius) + level_set(3, 2, "shape"), -kHalf, kHalf));
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  struct Layer {
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9, length = 0;
  };
  auto slice = [&](const std::string& design, const std::string& out) {
    const test::CliRun r = test::run_cli(
        "slice " + design + " --machine " + prof +
            " --layer-height 0.5 --set extrusion.nozzle_diameter=0.8 --bead-width 0.4 --walls 2 "
            "--infill 0.2 --strategy none -o " +
            out,
        dir.path());
    EXPECT_EQ(r.code, 0) << r.err;
    std::vector<Layer> layers;
    std::istringstream in(read_file(out));
    double x = 0, y = 0;
    for (std::string l; std::getline(in, l);) {
      if (l.rfind(";LAYER:", 0) == 0) layers.emplace_back();
      if (l.rfind("G1 ", 0) != 0 || layers.empty()) continue;
      double nx = x, ny = y;
      bool extrudes = false;
      std::istringstream words(l.substr(3));
      for (std::string w; words >> w;) {
        if (w[0] == 'X') nx = std::stod(w.substr(1));
        if (w[0] == 'Y') ny = std::stod(w.substr(1));
        if (w[0] == 'E' && std::stod(w.substr(1)) > 0) extrudes = true;
      }
      if (extrudes) {
        Layer& L = layers.back();
        L.x0 = std::min({L.x0, x, nx}), L.x1 = std::max({L.x1, x, nx});
        L.y0 = std::min({L.y0, y, ny}), L.y1 = std::max({L.y1, y, ny});
        L.length += std::hypot(nx - x, ny - y);
      }
      x = nx, y = ny;
    }
    return layers;
  };
  const auto a = slice(image, dir.file("image.gcode")), b = slice(exact, dir.file("exact.gcode"));
  ASSERT_GT(b.size(), 20u);
  ASSERT_EQ(a.size(), b.size());
  double la = 0, lb = 0;
  int printed_a = 0, printed_b = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    la += a[i].length, lb += b[i].length;
    printed_a += a[i].length > 0, printed_b += b[i].length > 0;
    if (a[i].length == 0 || b[i].length == 0) continue;
    EXPECT_NEAR(a[i].x0, b[i].x0, h) << "layer " << i;
    EXPECT_NEAR(a[i].x1, b[i].x1, h) << "layer " << i;
    EXPECT_NEAR(a[i].y0, b[i].y0, h) << "layer " << i;
    EXPECT_NEAR(a[i].y1, b[i].y1, h) << "layer " << i;
  }
  EXPECT_NEAR(printed_a, printed_b, 1);  // a pole's last speck may fall either side
  EXPECT_GT(lb, 500);
  EXPECT_NEAR(la, lb, 0.02 * lb);
}

// Part I §2.2 and §3.2 on the specification's own 3 × 4 × 2 grid (Figures 2-3 and 3-1): voxel
// (row i, column j, sheet k) holds red = 10·(4i + j) + 100k, so a sample names its voxel.
// Nearest: (1/8, 2/3, 0) is voxel (0,0,0) and (½, ½, 0) is (1,1,0), the lower index on ties;
// tile styles wrap, mirror and clamp map u outside [0, 1]; linear filtering halfway between two
// centres is their mean; an RGB image's alpha is 1; a grey image gives red = green = blue.
TEST(Implicit3mfVolumes, SamplingFollowsTheSpecificationsGrid) {
  test::TempDir dir("implicit3mf_volumes");
  const Stack rgb = make_stack(4, 3, 2, 3, 8, [](int i, int j, int k, int c) {
    return static_cast<std::uint16_t>(c == 0 ? 10 * (4 * i + j) + 100 * k : 7 * c);
  });
  // The field at object point p is the channel at uvw = p (identity transform), 255 × the value.
  auto field = [&](const std::string& attrs, const std::string& channel, const Stack& st) {
    const std::string path = dir.file("grid.3mf");
    write_3mf(path,
              model_of(st.xml(4) + image_function(2, " valuescale=\"255\"" + attrs) +
                           level_set(3, 2, channel),
                       -5, 5),
              st.parts);
    return read_implicit_3mf(path).field;
  };
  struct Probe {
    Vec3 uvw;
    double expect;
  };
  auto expect_at = [&](const Field& f, const std::vector<Probe>& probes, const std::string& what) {
    Evaluator e(f);
    for (const Probe& p : probes)
      EXPECT_NEAR(e.value(p.uvw), p.expect, 1e-9)
          << what << " at " << p.uvw.x << " " << p.uvw.y << " " << p.uvw.z;
  };
  const double w0 = 0.25;  // the centre of sheet 0
  expect_at(field(" filter=\"nearest\"", "red", rgb),
            {{{1.0 / 8, 2.0 / 3, 0}, 0},       // Figure 2-3: (0,0,0), not (1,0,0)
             {{0.5, 0.5, 0}, 50},              // (1,1,0), not (1,2,0)
             {{7.0 / 8, 1.0 / 6, w0}, 110},    // bottom right: (2,3,0)
             {{1.0 / 8, 5.0 / 6, 0.75}, 100},  // sheet 1
             {{1 + 1.0 / 8, 5.0 / 6, w0}, 0},  // wrap: u − 1
             {{-1.0 / 8, 5.0 / 6, w0}, 30}},   // wrap: 7/8, column 3
            "nearest wrap");
  expect_at(field(" filter=\"nearest\" tilestyleu=\"mirror\"", "red", rgb),
            {{{-1.0 / 8, 5.0 / 6, w0}, 0},       // mirrored to 1/8
             {{1 + 1.0 / 8, 5.0 / 6, w0}, 30},   // mirrored to 7/8
             {{2 + 3.0 / 8, 5.0 / 6, w0}, 10}},  // two widths on: 3/8
            "nearest mirror");
  expect_at(field(" filter=\"nearest\" tilestyleu=\"clamp\"", "red", rgb),
            {{{-3, 5.0 / 6, w0}, 0}, {{4, 5.0 / 6, w0}, 30}}, "nearest clamp");
  expect_at(field(" tilestyleu=\"clamp\" tilestylev=\"clamp\" tilestylew=\"clamp\"", "red", rgb),
            {{{1.0 / 8, 5.0 / 6, w0}, 0},    // a centre: its value
             {{0.25, 5.0 / 6, w0}, 5},       // halfway between columns 0 and 1
             {{1.0 / 8, 2.0 / 3, w0}, 20},   // halfway between rows 0 and 1
             {{1.0 / 8, 5.0 / 6, 0.5}, 50},  // halfway between the sheets
             {{0.0, 5.0 / 6, w0}, 0}},       // past the last centre, clamped
            "linear clamp");
  expect_at(field("", "red", rgb), {{{0.0, 5.0 / 6, w0}, 15}}, "linear wrap: columns 3 and 0");
  expect_at(field("", "alpha", rgb), {{{0.3, 0.3, 0.3}, 255}}, "RGB has alpha 1");
  expect_at(field("", "blue", rgb), {{{0.3, 0.3, 0.3}, 14}}, "blue");
  const Stack grey = make_stack(4, 3, 2, 2, 8, [](int i, int j, int k, int c) {
    return static_cast<std::uint16_t>(c == 0 ? 10 * (4 * i + j) + 100 * k : 200);
  });
  for (const std::string channel : {"red", "green", "blue"})
    expect_at(field(" filter=\"nearest\"", channel, grey), {{{0.5, 0.5, 0}, 50}},
              "grey " + channel);
  expect_at(field("", "alpha", grey), {{{0.3, 0.3, 0.3}, 200}}, "grey alpha");
}

// An implicit function may call a <functionfromimage3d> through functioncall (Part II ch. 3):
// its pos is the uvw the graph computes, its outputs those of Part I §2.2. Mapping the object to
// uvw in the graph gives the same field as the level set's transform.
TEST(Implicit3mfVolumes, AFunctionCallReachesTheImage) {
  test::TempDir dir("implicit3mf_volumes");
  const Stack st = sphere_stack(17);
  const std::string fn = " valuescale=\"32\" valueoffset=\"-16\"";
  const std::string caller =
      "<i:implicitfunction id=\"5\">\n<i:in><i:vector identifier=\"pos\"/></i:in>\n" +
      node("constvec", "scale", {}, "vector", "vector", " x=\"0.0625\" y=\"0.0625\" z=\"0.0625\"") +
      node("constvec", "half", {}, "vector", "vector", " x=\"0.5\" y=\"0.5\" z=\"0.5\"") +
      node("multiplication", "m",
           {{"vectorref", "A", "inputs.pos"}, {"vectorref", "B", "scale.vector"}}, "vector") +
      node("addition", "uvw", {{"vectorref", "A", "m.result"}, {"vectorref", "B", "half.vector"}},
           "vector") +
      "<i:constresourceid identifier=\"img\" value=\"2\"><i:out><i:resourceid "
      "identifier=\"value\"/></i:out></i:constresourceid>\n"
      "<i:functioncall identifier=\"call\"><i:in><i:resourceref identifier=\"functionID\" "
      "ref=\"img.value\"/><i:vectorref identifier=\"pos\" ref=\"uvw.result\"/></i:in>"
      "<i:out><i:scalar identifier=\"red\"/><i:vector identifier=\"color\"/></i:out>"
      "</i:functioncall>\n"
      "<i:out><i:scalarref identifier=\"shape\" ref=\"call.red\"/></i:out>\n"
      "</i:implicitfunction>\n";
  const std::string called = dir.file("called.3mf"), direct = dir.file("direct.3mf");
  write_3mf(called,
            model_of(st.xml(4) + image_function(2, fn) + caller + level_set(3, 5, "shape"), -kHalf,
                     kHalf),
            st.parts);
  write_3mf(
      direct,
      model_of(st.xml(4) + image_function(2, fn) + level_set(3, 2, "red", kToUvw), -kHalf, kHalf),
      st.parts);
  const Field a = read_implicit_3mf(called).field, b = read_implicit_3mf(direct).field;
  Evaluator eb(b);
  at_random_points(a, kHalf, 2000, 23,
                   [&](Vec3 p, double v) { EXPECT_NEAR(v, eb.value(p), 1e-12); });
}

TEST(Implicit3mfVolumes, MalformedImageStacksAreRefusedByName) {
  const Stack st = sphere_stack(5);
  const std::string fn = image_function(2, "");
  const std::string good = model_of(st.xml(4) + fn + level_set(3, 2, "red", kToUvw), -8, 8);
  auto edit = [&](const std::string& from, const std::string& to) {
    std::string m = good;
    const auto at = m.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) m.replace(at, from.size(), to);
    return m;
  };
  auto without_last_sheet = st.parts;
  without_last_sheet.pop_back();
  auto other_size = st.parts;
  other_size[2].second =
      make_stack(4, 5, 1, 1, 16, [](int, int, int, int) { return 0; }).parts[0].second;
  auto other_depth = st.parts;
  other_depth[1].second =
      make_stack(5, 5, 1, 1, 8, [](int, int, int, int) { return 0; }).parts[0].second;
  auto not_png = st.parts;
  not_png[3].second = "GIF89a";
  expect_refusals({
      {"missing sheet", good, "sheet0004.png", "no part /3D/volumetric/stack/sheet0004.png",
       without_last_sheet},
      {"sheet size", good, "sheet0002.png", "not columncount × rowcount = 5 × 5", other_size},
      {"bit depth", good, "sheet0001.png", "share one pixel layout and bit depth", other_depth},
      {"not a PNG", good, "sheet0003.png", "is not a PNG file", not_png},
      {"sheet count", edit("sheetcount=\"5\"", "sheetcount=\"6\""), "<v:imagestack",
       "has 5 <imagesheet>s, sheetcount says 6", st.parts},
      {"filter", edit("image3did=\"4\"", "image3did=\"4\" filter=\"cubic\""),
       "<v:functionfromimage3d", "filter=\"cubic\" is not linear or nearest", st.parts},
      {"tile style", edit("image3did=\"4\"", "image3did=\"4\" tilestylew=\"repeat\""),
       "<v:functionfromimage3d", "tilestylew=\"repeat\" is not wrap, mirror or clamp", st.parts},
      {"no image", edit("image3did=\"4\"", "image3did=\"9\""), "<v:functionfromimage3d",
       "no <image3d> with id 9", st.parts},
      {"channel", edit("channel=\"red\"", "channel=\"purple\""), "<v:levelset",
       "no scalar output \"purple\"", st.parts},
  });
}

// Each image sheet's part is related to the model part by the 3D Texture relationship (Part I
// §3.2.2, a MUST): relative and differently cased targets name the same part; a sheet without
// one is refused by name.
TEST(Implicit3mfVolumes, SheetsNeedTheTextureRelationship) {
  test::TempDir dir("implicit3mf_rels");
  const Stack st = sphere_stack(5);
  const std::string model =
      model_of(st.xml(4) + image_function(2, "") + level_set(3, 2, "red", kToUvw), -8, 8);
  const std::string absolute = dir.file("a.3mf"), relative = dir.file("r.3mf"),
                    none = dir.file("n.3mf");
  write_3mf(absolute, model, st.parts);
  write_3mf(relative, model, st.parts, TextureRels::RelativeUpperCase);
  write_3mf(none, model, st.parts, TextureRels::None);
  const Field a = read_implicit_3mf(absolute).field, r = read_implicit_3mf(relative).field;
  Evaluator ea(a);
  at_random_points(r, 8, 200, 5, [&](Vec3 p, double v) { EXPECT_EQ(v, ea.value(p)); });
  const std::string what = refusal(none).what();
  for (const char* w : {"sheet 0", "/3D/volumetric/stack/sheet0000.png", "3D Texture relationship",
                        "§3.2.2", "3dtexture"})
    EXPECT_NE(what.find(w), std::string::npos) << w << ": " << what;
}

// Volumetric data (Part I ch. 5) applied to a shape is refused by name, not dropped; a level
// set's minfeaturesize (§4.1.1) is kept in mm for the routes' warning.
TEST(Implicit3mfVolumes, VolumeDataIsRefusedAndMinFeatureSizeKept) {
  const std::string sphere = sphere_function(kRadius);
  const std::string with_volume = model_of(sphere + level_set(3, 2, "shape"), -kHalf, kHalf);
  auto edit = [](std::string m, const std::string& from, const std::string& to) {
    const auto at = m.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) m.replace(at, from.size(), to);
    return m;
  };
  expect_refusals({
      {"volumeid on the level set",
       edit(with_volume, "<v:levelset ", "<v:levelset volumeid=\"7\" "),
       "<v:levelset",
       "volumeid=\"7\" applies volumetric data",
       {}},
      {"volumeid on a mesh placed beside",
       edit(edit(with_volume, "<mesh>", "<mesh volumeid=\"8\">"), "<item objectid=\"3\"/>",
            "<item objectid=\"3\"/><item objectid=\"1\"/>"),
       "<mesh volumeid",
       "<mesh> volumeid=\"8\" applies volumetric data",
       {}},
      {"the 2022 draft's colour beside its boundary",
       edit(edit(with_volume, "<item objectid=\"3\"/>", "<item objectid=\"4\"/>"), "</resources>",
            "<object id=\"4\" type=\"model\">" + box_mesh({-8, -8, -8}, {8, 8, 8}) +
                "<v:volumedata><v:boundary functionid=\"2\" channel=\"shape\"/>\n<v:color "
                "functionid=\"2\" channel=\"shape\"/></v:volumedata></object>\n</resources>"),
       "<v:color",
       "<volumedata><color> (Part I ch. 5 volumetric data) is not read",
       {}},
  });
  test::TempDir dir("implicit3mf_minfeature");
  const std::string path = dir.file("m.3mf");
  std::string cm = edit(with_volume, "<v:levelset ", "<v:levelset minfeaturesize=\"0.5\" ");
  cm = edit(cm, "unit=\"millimeter\"", "unit=\"centimeter\"");
  write_3mf(path, cm);
  EXPECT_DOUBLE_EQ(read_implicit_3mf(path).min_feature_size, 5.0);  // 0.5 cm
  write_3mf(path, with_volume);
  EXPECT_EQ(read_implicit_3mf(path).min_feature_size, 0.0);
}

// An object made of components (3MF Core §4.2) is the union of its components' fields, each
// placed by its transform within the object and the object by its item; components nest.
TEST(Implicit3mfVolumes, ComponentsPlaceLevelSetObjects) {
  test::TempDir dir("implicit3mf_volumes");
  const std::string resources =
      sphere_function(3, 2) + sphere_function(2, 5) + level_set(3, 2, "shape") +
      level_set(4, 5, "shape") +
      "<object id=\"6\" type=\"model\"><components>"
      "<component objectid=\"4\" transform=\"1 0 0 0 1 0 0 0 1 0 -1 0\"/></components></object>\n"
      "<object id=\"10\" type=\"model\"><components>\n"
      "<component objectid=\"3\" transform=\"1 0 0 0 1 0 0 0 1 5 0 0\"/>\n"
      "<component objectid=\"6\" transform=\"0 1 0 -1 0 0 0 0 1 -5 0 0\"/>\n"
      "</components></object>\n";
  std::string m = model_of(resources, -4, 4, 10);
  m.replace(m.find("<item objectid=\"10\"/>"), 21,
            "<item objectid=\"10\" transform=\"1 0 0 0 1 0 0 0 1 0 0 2\"/>");
  const std::string path = dir.file("components.3mf");
  write_3mf(path, m);
  ASSERT_TRUE(is_implicit_3mf(path));
  const VcadDesign d = read_implicit_3mf(path);
  // Sphere 3 at (5, 0, 2) in its box ±4; sphere 4 moved by (0, −1, 0) in object 6, which is
  // turned 90° about z (row vectors: x → y) and moved to (−5, 0, 2): its centre (−5 + 1, 0, 2).
  auto in_box = [](Vec3 q, Vec3 c) {
    return std::max({std::abs(q.x - c.x), std::abs(q.y - c.y), std::abs(q.z - c.z)}) - 4;
  };
  auto sphere = [&](Vec3 q, Vec3 c, double r) {
    return std::max(length({q.x - c.x, q.y - c.y, q.z - c.z}) - r, in_box(q, c));
  };
  at_random_points(d.field, 10, 3000, 29, [&](Vec3 p, double v) {
    const double expect = std::min(sphere(p, {5, 0, 2}, 3), sphere(p, {-4, 0, 2}, 2));
    EXPECT_NEAR(v, expect, 1e-12) << p.x << " " << p.y << " " << p.z;
  });
  EXPECT_NEAR(d.root_min.x, -8, 1e-12);
  EXPECT_NEAR(d.root_max.x, 9, 1e-12);
  EXPECT_NEAR(d.root_min.z, -2, 1e-12);

  const std::string cycle =
      sphere_function(3, 2) + level_set(3, 2, "shape") +
      "<object id=\"10\" type=\"model\"><components><component objectid=\"11\"/></components>"
      "</object>\n<object id=\"11\" type=\"model\"><components>\n<component objectid=\"10\"/>"
      "</components></object>\n";
  const std::string other_part =
      sphere_function(3, 2) + level_set(3, 2, "shape") +
      "<object id=\"10\" type=\"model\"><components>\n<component objectid=\"3\" "
      "p:path=\"/3D/other.model\"/></components></object>\n";
  expect_refusals({
      {"cycle", model_of(cycle, -4, 4, 10), "<component objectid=\"10\"/>",
       "object 10 contains itself"},
      {"production path", model_of(other_part, -4, 4, 10), "p:path", "another model part"},
      {"empty", model_of("<object id=\"10\" type=\"model\"><components/></object>\n", -4, 4, 10),
       "<components/>", "has no <component>"},
  });
}

// Signed distance to a mesh (Part II ch. 5, mesh): a box mesh's distance within a voxel of the
// exact box distance over the whole domain (inside, near, and at the domain's corners, so the
// field's band covers it); unsigned distance (unsignedmesh) to an open square within a voxel of
// the exact one, so a level set of it minus 0.5 is a slab around the square.
TEST(Implicit3mfVolumes, MeshNodesMeasureTheDistanceToAMesh) {
  test::TempDir dir("implicit3mf_volumes");
  auto distance_function = [](const std::string& kind, double minus) {
    return "<i:implicitfunction id=\"2\">\n<i:in><i:vector identifier=\"pos\"/></i:in>\n"
           "<i:constresourceid identifier=\"m\" value=\"6\"><i:out><i:resourceid "
           "identifier=\"value\"/></i:out></i:constresourceid>\n" +
           node(kind, "d", {{"vectorref", "pos", "inputs.pos"}, {"resourceref", "mesh", "m.value"}},
                "scalar", "distance") +
           node("constant", "c", {}, "scalar", "value", " value=\"" + num(minus) + "\"") +
           node("subtraction", "s",
                {{"scalarref", "A", "d.distance"}, {"scalarref", "B", "c.value"}}, "scalar") +
           "<i:out><i:scalarref identifier=\"shape\" ref=\"s.result\"/></i:out>\n"
           "</i:implicitfunction>\n";
  };
  const std::string square =
      "<object id=\"6\" type=\"model\"><mesh><vertices><vertex x=\"-3\" y=\"-3\" z=\"0\"/>"
      "<vertex x=\"3\" y=\"-3\" z=\"0\"/><vertex x=\"3\" y=\"3\" z=\"0\"/><vertex x=\"-3\" "
      "y=\"3\" z=\"0\"/></vertices><triangles><triangle v1=\"0\" v2=\"1\" v3=\"2\"/><triangle "
      "v1=\"0\" v2=\"2\" v3=\"3\"/></triangles></mesh></object>\n";
  const std::string box =
      "<object id=\"6\" type=\"model\">" + box_mesh({-3, -2, -1}, {3, 2, 1}) + "</object>\n";
  VcadOptions fine;
  fine.mesh_voxel = 0.2;
  const double tol = 0.2;
  {
    const std::string path = dir.file("signed.3mf");
    write_3mf(path, model_of(box + distance_function("mesh", 0) + level_set(3, 2, "shape"), -5, 5));
    const VcadDesign d = read_implicit_3mf(path, fine);
    auto exact = [](Vec3 p) {
      const Vec3 q{std::abs(p.x) - 3, std::abs(p.y) - 2, std::abs(p.z) - 1};
      const Vec3 o{std::max(q.x, 0.0), std::max(q.y, 0.0), std::max(q.z, 0.0)};
      return length(o) + std::min(std::max({q.x, q.y, q.z}), 0.0);
    };
    at_random_points(d.field, 5, 2000, 31, [&](Vec3 p, double v) {
      EXPECT_NEAR(v, exact(p), tol) << p.x << " " << p.y << " " << p.z;
    });
    Evaluator e(d.field);
    EXPECT_NEAR(e.value({5, 5, 5}), exact({5, 5, 5}), tol);  // the domain's corner: 5.4 mm
    EXPECT_LT(e.value({0, 0, 0}), -0.9);
  }
  {
    const std::string path = dir.file("unsigned.3mf");
    write_3mf(path,
              model_of(square + distance_function("unsignedmesh", 0.5) + level_set(3, 2, "shape"),
                       -5, 5));
    const VcadDesign d = read_implicit_3mf(path, fine);
    auto exact = [](Vec3 p) {
      const double dx = std::max(std::abs(p.x) - 3, 0.0), dy = std::max(std::abs(p.y) - 3, 0.0);
      return std::sqrt(dx * dx + dy * dy + p.z * p.z) - 0.5;
    };
    at_random_points(d.field, 5, 2000, 37, [&](Vec3 p, double v) {
      EXPECT_NEAR(v, exact(p), tol) << p.x << " " << p.y << " " << p.z;
    });
  }
  const std::string not_mesh = sphere_function(3, 7) + distance_function("mesh", 0) +
                               level_set(3, 2, "shape") +
                               "<object id=\"6\" type=\"model\"><components><component "
                               "objectid=\"1\"/></components></object>\n";
  expect_refusals({
      {"open mesh, signed",
       model_of(square + distance_function("mesh", 0) + level_set(3, 2, "shape"), -5, 5), "<i:mesh",
       "<mesh>: object 6"},
      {"not a mesh object", model_of(not_mesh, -5, 5), "<i:mesh", "object 6 is not a mesh object"},
  });
}
