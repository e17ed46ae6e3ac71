// 3MF level-set designs (Volumetric & Implicit Extension v1.0) read into the field kernel: a
// design written here as a function graph equals the same design written as .vcad, at random
// points and in the G-code it slices to; the specification's examples read; every malformed
// package is refused naming the part, line and column.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <numbers>
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
#include "trellis/field/vcad.hpp"

using namespace trellis;

using namespace trellis::test;

namespace {

// The gyroid sin(kx)cos(ky) + sin(ky)cos(kz) + sin(kz)cos(kx), k = 2π/cell: q = k·pos, then
// sin(q) · cos(q.yzx) (the graph of the 3MF Consortium's ImplicitGyroid sample, scaled).
std::string gyroid_function(double cell) {
  const double k = 2 * std::numbers::pi / cell;
  return "<i:implicitfunction id=\"2\" displayname=\"gyroid\">\n"
         "<i:in><i:vector identifier=\"pos\"/></i:in>\n" +
         node("constant", "k", {}, "scalar", "value", " value=\"" + num(k) + "\"") +
         node("vectorfromscalar", "kv", {{"scalarref", "A", "k.value"}}, "vector") +
         node("multiplication", "q",
              {{"vectorref", "A", "inputs.pos"}, {"vectorref", "B", "kv.result"}}, "vector") +
         "<i:decomposevector identifier=\"d\"><i:in><i:vectorref identifier=\"A\" "
         "ref=\"q.result\"/>"
         "</i:in><i:out><i:scalar identifier=\"x\"/><i:scalar identifier=\"y\"/>"
         "<i:scalar identifier=\"z\"/></i:out></i:decomposevector>\n" +
         node("composevector", "yzx",
              {{"scalarref", "x", "d.y"}, {"scalarref", "y", "d.z"}, {"scalarref", "z", "d.x"}},
              "vector") +
         node("sin", "s", {{"vectorref", "A", "q.result"}}, "vector") +
         node("cos", "c", {{"vectorref", "A", "yzx.result"}}, "vector") +
         node("dot", "g", {{"vectorref", "A", "s.result"}, {"vectorref", "B", "c.result"}},
              "scalar") +
         "<i:out><i:scalarref identifier=\"shape\" ref=\"g.result\"/></i:out>\n"
         "</i:implicitfunction>\n";
}

// A model: box mesh (object 1), the function (resource 2), the level-set object 3 on the box.
std::string model(const std::string& function, std::array<double, 3> lo, std::array<double, 3> hi,
                  const std::string& item_attrs = "", const std::string& unit = "millimeter",
                  const std::string& levelset_attrs = "") {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<model unit=\"" +
         unit +
         "\" xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\" "
         "xmlns:v=\"http://schemas.3mf.io/3dmanufacturing/volumetric/2022/01\" "
         "xmlns:i=\"http://schemas.3mf.io/3dmanufacturing/implicit/2023/12\" "
         "requiredextensions=\"v i\">\n"
         "<resources>\n<object id=\"1\" type=\"model\">" +
         box_mesh(lo, hi) + "</object>\n" + function +
         "<object id=\"3\" type=\"model\"><v:levelset functionid=\"2\" channel=\"shape\" "
         "meshid=\"1\" "
         "meshbboxonly=\"true\"" +
         levelset_attrs +
         "/></object>\n"
         "</resources>\n<build><item objectid=\"3\"" +
         item_attrs + "/></build>\n</model>\n";
}

std::string vcad_box(std::array<double, 3> lo, std::array<double, 3> hi) {
  return "root((" + num(lo[0]) + "," + num(lo[1]) + "," + num(lo[2]) + "),(" + num(hi[0]) + "," +
         num(hi[1]) + "," + num(hi[2]) + "),(0.5,0.5,0.5))";
}

// The largest |a − b| over n random points of [lo − 2, hi + 2] (outside the box too).
double max_difference(const Field& a, const Field& b, std::array<double, 3> lo,
                      std::array<double, 3> hi, int n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(lo[0] - 2, hi[0] + 2), uy(lo[1] - 2, hi[1] + 2),
      uz(lo[2] - 2, hi[2] + 2);
  Evaluator ea(a), eb(b);
  double worst = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3 p{ux(rng), uy(rng), uz(rng)};
    const double va = ea.value(p), vb = eb.value(p);
    EXPECT_TRUE(std::isfinite(va)) << p.x << " " << p.y << " " << p.z;
    worst = std::max(worst, std::abs(va - vb));
  }
  return worst;
}

// The 1-based line of the first line of `text` holding `marker`.
long line_of(const std::string& text, const std::string& marker) {
  const auto at = text.find(marker);
  EXPECT_NE(at, std::string::npos) << marker;
  return 1 +
         static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

const std::string kData = std::string(TRELLIS_TEST_DATA) + "/3mf_volumetric/";

}  // namespace

TEST(Implicit3mf, SphereAndGyroidEqualTheirVcadAtRandomPoints) {
  test::TempDir dir("implicit3mf");
  const std::array<double, 3> lo{-10, -10, -10}, hi{10, 10, 10};
  for (double r : {3.0, 7.5, 10.0}) {
    const std::string path = dir.file("sphere.3mf");
    write_3mf(path, model(sphere_function(r), lo, hi));
    ASSERT_TRUE(is_implicit_3mf(path));
    ASSERT_TRUE(is_field_design(path));
    const VcadDesign d = read_field_design(path);
    const VcadDesign v = parse_vcad(vcad_box(lo, hi) + " { sphere(" + num(r) + "); }", "s.vcad");
    EXPECT_LE(max_difference(d.field, v.field, lo, hi, 3000, 7), 1e-9) << "r " << r;
    EXPECT_TRUE(d.has_root);
    EXPECT_EQ(d.root_min.x, -10);
    EXPECT_EQ(d.root_max.z, 10);
  }
  for (double cell : {2.5, 5.0, 12.0}) {
    const std::string path = dir.file("gyroid.3mf");
    write_3mf(path, model(gyroid_function(cell), lo, hi));
    const VcadDesign d = read_implicit_3mf(path);
    const VcadDesign v = parse_vcad(vcad_box(lo, hi) + " { gyroid(" + num(cell) + "); }", "g.vcad");
    EXPECT_LE(max_difference(d.field, v.field, lo, hi, 3000, 11), 1e-9) << "cell " << cell;
  }
}

// The item's transform places the object (Core §3.4.3.1: row vectors, translation last), the
// level set's transform maps object to function coordinates (Part I §4.1.1), and the model unit
// scales both into millimetres.
TEST(Implicit3mf, TransformsAndUnitsMapOntoTheKernel) {
  test::TempDir dir("implicit3mf");
  const std::string path = dir.file("moved.3mf");
  // Object: the box [-1, 1] cm; item: translate (0.5, 0.25, 1) cm; level set: the function sees
  // object coordinates scaled by 2 (a sphere of radius 1 there is 0.5 cm = 5 mm in the object).
  write_3mf(path, model(sphere_function(1), {-1, -1, -1}, {1, 1, 1},
                        " transform=\"1 0 0 0 1 0 0 0 1 0.5 0.25 1\"", "centimeter",
                        " transform=\"2 0 0 0 2 0 0 0 2 0 0 0\""));
  const VcadDesign d = read_implicit_3mf(path);
  EXPECT_DOUBLE_EQ(d.root_min.x, -5);
  EXPECT_DOUBLE_EQ(d.root_max.z, 20);
  Evaluator e(d.field);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p{5 + 10 * u(rng), 2.5 + 10 * u(rng), 10 + 10 * u(rng)};
    const Vec3 q{(p.x - 5) / 10 * 2, (p.y - 2.5) / 10 * 2, (p.z - 10) / 10 * 2};  // function coords
    const double inside_box =
        std::max({std::abs(p.x - 5), std::abs(p.y - 2.5), std::abs(p.z - 10)}) - 10;
    const double expect = std::max(std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z) - 1, inside_box);
    EXPECT_NEAR(e.value(p), expect, 1e-12);
  }
}

TEST(Implicit3mf, TheSpecificationsExamplesRead) {
  // Part II ch. 3's sphere called through ch. 5's functioncall: |p| − 10 in the box.
  const std::string sphere = kData + "spec_sphere_functioncall.3mf";
  ASSERT_TRUE(is_implicit_3mf(sphere));
  const VcadDesign s = read_implicit_3mf(sphere);
  Evaluator es(s.field);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-12, 12);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 p{u(rng), u(rng), u(rng)};
    EXPECT_NEAR(es.value(p), std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z) - 10, 1e-12);
  }
  // The Consortium's gyroid sample (2022 draft syntax): the gyroid at the item-translated
  // position wherever the pyramid mesh does not cut it, and the pyramid's box as the extent.
  const std::string gyroid = kData + "ImplicitGyroid.3mf";
  ASSERT_TRUE(is_implicit_3mf(gyroid));
  VcadOptions coarse;
  coarse.mesh_voxel = 1;  // the pyramid's distance field (the points below are far from its faces)
  const VcadDesign g = read_implicit_3mf(gyroid, coarse);
  EXPECT_NEAR(g.root_min.x, 0, 1e-4);
  EXPECT_NEAR(g.root_max.x, 160 - 15.2786, 1e-4);
  EXPECT_NEAR(g.root_max.z, 100, 1e-9);
  Evaluator eg(g.field);
  int outside = 0, inside = 0;
  for (double z = 5; z < 40; z += 1.7)
    for (double a = -10; a <= 10; a += 1.3)
      for (double b = -10; b <= 10; b += 1.3) {
        const Vec3 p{80 - 15.2786 + a, 80 - 3.91548 + b, z};  // near the pyramid's axis
        const double x = p.x + 15.2786, y = p.y + 3.91548;
        const double phi =
            std::sin(x) * std::cos(y) + std::sin(y) * std::cos(z) + std::sin(z) * std::cos(x);
        const double v = eg.value(p);
        if (phi > 0) {
          ++outside;
          EXPECT_NEAR(v, phi, 1e-9);  // max(φ, mesh distance < 0) = φ
        } else {
          ++inside;
          EXPECT_LE(v, 1e-12);
        }
      }
  EXPECT_GT(outside, 100);
  EXPECT_GT(inside, 100);
}

TEST(Implicit3mf, MeshPackagesAndOtherFilesAreNotImplicit) {
  EXPECT_FALSE(is_implicit_3mf(std::string(TRELLIS_TEST_DATA) + "/mesh/occt_motor.3mf"));
  EXPECT_FALSE(is_field_design(std::string(TRELLIS_TEST_DATA) + "/mesh/occt_motor.3mf"));
  test::TempDir dir("implicit3mf");
  const std::string junk = dir.file("junk.3mf");
  std::ofstream(junk) << "not a zip";
  EXPECT_FALSE(is_implicit_3mf(junk));
}

// Each broken model is refused with a ParseError naming the file, the part, and the line and
// column of the element at fault (or of expat's error), and the message names what is wrong.
TEST(Implicit3mf, MalformedPackagesAreRefusedWithTheirLocation) {
  test::TempDir dir("implicit3mf");
  const std::array<double, 3> lo{-5, -5, -5}, hi{5, 5, 5};
  struct Case {
    std::string name, model, marker, says;
  };
  const std::string base = model(sphere_function(3), lo, hi);
  // The base model with each (from, to) replaced once, in order.
  auto edit = [&](std::vector<std::pair<std::string, std::string>> changes) {
    std::string m = base;
    for (const auto& [from, to] : changes) {
      const auto at = m.find(from);
      EXPECT_NE(at, std::string::npos) << from;
      if (at != std::string::npos) m.replace(at, from.size(), to);
    }
    return m;
  };
  const std::vector<Case> cases = {
      {"unknown node",
       edit({{"<i:length identifier", "<i:wobble identifier"}, {"</i:length>", "</i:wobble>"}}),
       "<i:wobble", "<wobble>"},
      {"mesh node without its position",
       edit({{"<i:length identifier", "<i:mesh identifier"}, {"</i:length>", "</i:mesh>"}}),
       "<i:mesh identifier", "has no input \"pos\""},
      {"type mismatch", edit({{"ref=\"len.result\"", "ref=\"inputs.pos\""}}),
       "identifier=\"A\" ref=\"inputs.pos\"/>\n<i:scalarref", "names a vector, not a scalar"},
      {"dangling ref", edit({{"ref=\"radius.value\"", "ref=\"nothing.value\""}}),
       "ref=\"nothing.value\"", "no node \"nothing\""},
      {"cycle", edit({{"ref=\"len.result\"", "ref=\"sub.result\""}}), "<i:subtraction",
       "depends on itself"},
      {"image function",
       edit({{"<i:implicitfunction id=\"2\"",
              "<v:functionfromimage3d id=\"2\"/><i:implicitfunction id=\"9\""}}),
       "<v:functionfromimage3d", "no image3did"},
      {"bad number", edit({{"value=\"3\"", "value=\"3 mm\""}}), "value=\"3 mm\"", "not a number"},
      {"broken XML", edit({{"</i:in>", "</i:inn>"}}), "</i:inn>", "mismatched tag"},
      {"no such function", edit({{"functionid=\"2\"", "functionid=\"4\""}}), "<v:levelset",
       "no function with id 4"},
  };
  for (const Case& c : cases) {
    const std::string path = dir.file("bad.3mf");
    write_3mf(path, c.model);
    ASSERT_TRUE(is_implicit_3mf(path)) << c.name;
    try {
      read_implicit_3mf(path);
      ADD_FAILURE() << c.name << ": read";
    } catch (const ParseError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(c.says), std::string::npos) << c.name << ": " << what;
      EXPECT_NE(what.find("/3D/3dmodel.model"), std::string::npos) << c.name << ": " << what;
      EXPECT_EQ(e.where().file, path) << c.name;
      EXPECT_EQ(e.where().line, line_of(c.model, c.marker)) << c.name << ": " << what;
      EXPECT_GT(e.where().column, 0) << c.name;
    }
  }
}

// XY length of the extruding moves (G1 with E and X or Y) of G-code lines.
double extruded_length(const std::vector<std::string>& lines) {
  double x = 0, y = 0, total = 0;
  for (const std::string& l : lines) {
    if (l.rfind("G0 ", 0) != 0 && l.rfind("G1 ", 0) != 0) continue;
    double nx = x, ny = y;
    bool moved = false, extrudes = false;
    std::istringstream in(l.substr(3));
    for (std::string w; in >> w;) {
      if (w[0] == 'X') nx = std::stod(w.substr(1)), moved = true;
      if (w[0] == 'Y') ny = std::stod(w.substr(1)), moved = true;
      if (w[0] == 'E') extrudes = true;
    }
    if (moved && extrudes && l[1] == '1') total += std::hypot(nx - x, ny - y);
    x = nx, y = ny;
  }
  return total;
}

// The sliced G-code of a sphere written as a 3MF level set: move for move the G-code of the same
// function written as a .vcad function() (the same arithmetic through the same unbounded field
// path; the headers differ only in the input's name), and within 0.1% of the .vcad sphere()
// primitive's extruded length with the same path counts. Not byte-equal to the primitive: the
// primitive gives the contour finder interval bounds, so it skips grid blocks proven inside or
// outside and places the outline's vertices from other samples, a general function (theirs or
// ours) has none.
TEST(Implicit3mf, SlicedSphereGcodeEqualsTheVcadSpheres) {
  test::TempDir dir("implicit3mf");
  const std::array<double, 3> lo{-8, -8, -8}, hi{8, 8, 8};
  const std::string m3f = dir.file("ball.3mf"), fn = dir.file("fn.vcad"),
                    prim = dir.file("prim.vcad");
  write_3mf(m3f, model(sphere_function(8), lo, hi));
  std::ofstream(fn) << vcad_box(lo, hi)
                    << " { function((-8,-8,-8),(8,8,8),\"sqrt(x^2+y^2+z^2)-8\"); }\n";
  std::ofstream(prim) << vcad_box(lo, hi) << " { sphere(8); }\n";
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  const std::string opts =
      " --machine " + prof +
      " --layer-height 0.5 --set extrusion.nozzle_diameter=0.8 --bead-width 0.4 --walls 2 "
      "--infill 0.2 --strategy none -o ";
  // The G-code's lines other than comments, and the summary's counts (before the timings).
  auto slice = [&](const std::string& design, const std::string& out, std::string* summary) {
    const test::CliRun r = test::run_cli("slice " + design + opts + out, dir.path());
    EXPECT_EQ(r.code, 0) << r.err;
    *summary = r.out.substr(0, r.out.find("), "));  // layers and path counts
    std::istringstream in(read_file(out));
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);)
      if (!l.empty() && l[0] != ';') lines.push_back(l);
    return lines;
  };
  std::string sa, sb, sc;
  const auto a = slice(m3f, dir.file("a.gcode"), &sa);
  const auto b = slice(fn, dir.file("b.gcode"), &sb);
  const auto c = slice(prim, dir.file("c.gcode"), &sc);
  EXPECT_GT(a.size(), 5000u);
  EXPECT_NE(sa.find("32 layers"), std::string::npos) << sa;
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]) << "line " << i;
  EXPECT_EQ(sa, sc);
  const double la = extruded_length(a), lc = extruded_length(c);
  EXPECT_GT(la, 1000);
  EXPECT_NEAR(la, lc, 0.001 * lc) << la << " mm against the primitive's " << lc << " mm";
}

// A level set's minfeaturesize finer than the bead width is warned about by the slice route, as
// Part I §4.1.1 asks of a consumer that cannot resolve it; one the route resolves is not.
namespace {

// fine.3mf and coarse.3mf in `dir`: a level-set sphere of radius r with either minfeaturesize.
void min_feature_spheres(const test::TempDir& dir, double r, const char* fine, const char* coarse) {
  const std::array<double, 3> lo{-r, -r, -r}, hi{r, r, r};
  for (const auto& [name, size] : {std::pair{"fine.3mf", fine}, std::pair{"coarse.3mf", coarse}})
    write_3mf(dir.file(name), model(sphere_function(r), lo, hi, "", "millimeter",
                                    std::string(" minfeaturesize=\"") + size + "\""));
}

}  // namespace

TEST(Implicit3mf, SliceWarnsOfAMinFeatureSizeItCannotResolve) {
  test::TempDir dir("implicit3mf_minfeature");
  min_feature_spheres(dir, 4, "0.1", "1");
  const std::string fine = dir.file("fine.3mf"), coarse = dir.file("coarse.3mf");
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  const std::string opts = " --machine " + prof +
                           " --layer-height 0.5 --set extrusion.nozzle_diameter=0.8 "
                           "--bead-width 0.4 -o ";
  const test::CliRun f = test::run_cli("slice " + fine + opts + dir.file("f.gcode"), dir.path());
  EXPECT_EQ(f.code, 0) << f.err;
  for (const char* w : {"fine.3mf", "0.1 mm (minfeaturesize)", "bead width is 0.4 mm"})
    EXPECT_NE(f.err.find(w), std::string::npos) << w << ": " << f.err;
  const test::CliRun c = test::run_cli("slice " + coarse + opts + dir.file("c.gcode"), dir.path());
  EXPECT_EQ(c.code, 0) << c.err;
  EXPECT_EQ(c.err.find("minfeaturesize"), std::string::npos) << c.err;
}

// The pbf routes say the same of a minfeaturesize finer than the laser's melt pool (the lattice
// route filling the level set, and a solid scan strategy): as the slice route does of the bead.
TEST(Implicit3mf, PbfWarnsOfAMinFeatureSizeItCannotResolve) {
  test::TempDir dir("implicit3mf_pbf_minfeature");
  min_feature_spheres(dir, 1, "0.02", "0.2");
  const std::string fine = dir.file("fine.3mf"), coarse = dir.file("coarse.3mf");
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_25um.toml";
  for (const char* strategy : {"hybrid", "meander"}) {
    const std::string opts = std::string(" --machine ") + prof +
                             " --set scan.layer=0.1 --set pbf.strategy=" + strategy + " -o ";
    const test::CliRun f = test::run_cli("pbf " + fine + opts + dir.file("f.cli"), dir.path());
    EXPECT_EQ(f.code, 0) << f.err;
    for (const char* w : {"fine.3mf", "0.02 mm (minfeaturesize)",
                          "melt pool (laser.melt_pool_width) is 0.0638 mm", "pbf.resolution"})
      EXPECT_NE(f.err.find(w), std::string::npos) << strategy << ": " << w << ": " << f.err;
    const test::CliRun c = test::run_cli("pbf " + coarse + opts + dir.file("c.cli"), dir.path());
    EXPECT_EQ(c.code, 0) << c.err;
    EXPECT_EQ(c.err.find("minfeaturesize"), std::string::npos) << strategy << ": " << c.err;
  }
}

// `trellis pbf` takes a 3MF level-set design as it takes a .vcad (the laser route, not the
// solid-mesh one): the .cli of a sphere from 3MF is the .vcad function()'s but for the job line
// naming the input.
TEST(Implicit3mf, PbfBuildFileEqualsTheVcadFunctions) {
  test::TempDir dir("implicit3mf");
  const std::array<double, 3> lo{-2, -2, -2}, hi{2, 2, 2};
  const std::string m3f = dir.file("ball.3mf"), fn = dir.file("fn.vcad");
  write_3mf(m3f, model(sphere_function(2), lo, hi));
  std::ofstream(fn) << vcad_box(lo, hi)
                    << " { function((-2,-2,-2),(2,2,2),\"sqrt(x^2+y^2+z^2)-2\"); }\n";
  const std::string prof = std::string(TRELLIS_SOURCE_DIR) + "/profiles/pbf_316l_25um.toml";
  auto body = [&](const std::string& design, const std::string& out) {
    const test::CliRun r =
        test::run_cli("pbf " + design + " --machine " + prof + " -o " + out, dir.path());
    EXPECT_EQ(r.code, 0) << r.err;
    std::istringstream in(read_file(out));
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);)
      if (l.rfind("//job: input", 0) != 0) lines.push_back(l);
    return lines;
  };
  const auto a = body(m3f, dir.file("a.cli")), b = body(fn, dir.file("b.cli"));
  EXPECT_GT(a.size(), 1000u);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]) << "line " << i;
}

namespace {

// A chain of n additions r_i = r_(i-1) + 1 after |pos|: the value |pos| + n. Past the reader's
// limit (1000 nested references, which bounds its recursion) the file is refused by name.
std::string fmt_id(int i) {
  char b[16];
  std::snprintf(b, sizeof b, "r%d", i);
  return b;
}

// A chain of n additions r_i = r_(i-1) + 1 after |pos|: the value |pos| + n. Past the reader's
// limit (1000 nested references, which bounds its recursion) the file is refused by name.
std::string chain_function(int n) {
  std::string s = "<i:implicitfunction id=\"2\">\n<i:in><i:vector identifier=\"pos\"/></i:in>\n" +
                  node("constant", "one", {}, "scalar", "value", " value=\"1\"") +
                  node("length", "r0", {{"vectorref", "A", "inputs.pos"}}, "scalar");
  for (int i = 1; i <= n; ++i) {
    const std::string id = fmt_id(i), previous = fmt_id(i - 1) + ".result";
    s += node("addition", id, {{"scalarref", "A", previous}, {"scalarref", "B", "one.value"}},
              "scalar");
  }
  return s + "<i:out><i:scalarref identifier=\"shape\" ref=\"" + fmt_id(n) +
         ".result\"/></i:out>\n</i:implicitfunction>\n";
}

}  // namespace

TEST(Implicit3mf, DeepGraphsReadUpToTheLimitAndAreRefusedPastIt) {
  test::TempDir dir("implicit3mf");
  const std::string path = dir.file("chain.3mf");
  write_3mf(path, model(chain_function(900), {-1, -1, -1}, {1, 1, 1}));
  Evaluator e(read_implicit_3mf(path).field);
  EXPECT_NEAR(e.value({0.3, 0.4, 0}), 900.5, 1e-9);
  write_3mf(path, model(chain_function(3000), {-1, -1, -1}, {1, 1, 1}));
  try {
    read_implicit_3mf(path);
    ADD_FAILURE() << "read";
  } catch (const ParseError& err) {
    EXPECT_NE(std::string(err.what()).find("deeper than 1000"), std::string::npos) << err.what();
    EXPECT_GT(err.where().line, 0);
  }
}

namespace {

// A function whose output is `body` (nodes after x, y, z = the position's components) at its
// output node "o".
std::string scalar_function(const std::string& body) {
  return "<i:implicitfunction id=\"2\">\n<i:in><i:vector identifier=\"pos\"/></i:in>\n"
         "<i:decomposevector identifier=\"p\"><i:in><i:vectorref identifier=\"A\" "
         "ref=\"inputs.pos\"/></i:in><i:out><i:scalar identifier=\"x\"/><i:scalar "
         "identifier=\"y\"/><i:scalar identifier=\"z\"/></i:out></i:decomposevector>\n" +
         body + "<i:out><i:scalarref identifier=\"shape\" ref=\"o.result\"/></i:out>\n" +
         "</i:implicitfunction>\n";
}

// The design's values at random points of [-3, 3]^3 against `expect` (x, y, z), clipped to the
// box [-4, 4]^3 (max with its distance); the fallback 0 where `expect` is not a number.
void expect_values(const std::string& name, const std::string& body,
                   const std::function<double(double, double, double)>& expect) {
  test::TempDir dir("implicit3mf");
  const std::string path = dir.file("op.3mf");
  write_3mf(path, model(scalar_function(body), {-4, -4, -4}, {4, 4, 4}));
  Evaluator e(read_implicit_3mf(path).field);
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int i = 0; i < 200; ++i) {
    const double x = u(rng), y = u(rng), z = u(rng);
    const double box = std::max({std::abs(x), std::abs(y), std::abs(z)}) - 4;  // < 0 here
    const double f = expect(x, y, z);
    if (!std::isfinite(f)) {
      EXPECT_EQ(e.value({x, y, z}), 0) << name << ": the fallback value";
      continue;
    }
    const double want = std::max(f, box);  // clipped to the level set's mesh box
    EXPECT_NEAR(e.value({x, y, z}), want, 1e-12 * std::max(1.0, std::abs(want))) << name;
  }
}

}  // namespace

// Each native node against its definition in Part II ch. 5, on scalars from the position.
TEST(Implicit3mf, NativeNodesFollowTheSpecification) {
  using F = std::function<double(double)>;
  const std::vector<std::pair<std::string, F>> unary = {
      {"abs", [](double a) { return std::abs(a); }},
      {"sin", [](double a) { return std::sin(a); }},
      {"cos", [](double a) { return std::cos(a); }},
      {"tan", [](double a) { return std::tan(a); }},
      {"arcsin", [](double a) { return std::asin(a / 3); }},
      {"arccos", [](double a) { return std::acos(a / 3); }},
      {"arctan", [](double a) { return std::atan(a); }},
      {"sqrt", [](double a) { return std::sqrt(a); }},
      {"exp", [](double a) { return std::exp(a); }},
      {"log", [](double a) { return std::log(a); }},
      {"log2", [](double a) { return std::log2(a); }},
      {"log10", [](double a) { return std::log10(a); }},
      {"cosh", [](double a) { return std::cosh(a); }},
      {"sinh", [](double a) { return std::sinh(a); }},
      {"tanh", [](double a) { return std::tanh(a); }},
      {"round", [](double a) { return std::round(a); }},
      {"ceil", [](double a) { return std::ceil(a); }},
      {"floor", [](double a) { return std::floor(a); }},
      {"sign", [](double a) { return a < 0   ? -1.0
                                     : a > 0 ? 1.0
                                             : 0.0; }},
      {"fract", [](double a) { return a - std::floor(a); }},
  };
  for (const auto& [op, f] : unary) {
    const bool scaled = op == "arcsin" || op == "arccos";  // arguments within [-1, 1]
    const std::string in = scaled ? "s.result" : "p.x";
    const std::string pre =
        scaled ? node("constant", "three", {}, "scalar", "value", " value=\"3\"") +
                     node("division", "s",
                          {{"scalarref", "A", "p.x"}, {"scalarref", "B", "three.value"}}, "scalar")
               : "";
    expect_values(op, pre + node(op, "o", {{"scalarref", "A", in}}, "scalar"),
                  [&, f = f](double x, double, double) { return f(x); });
  }
  using G = std::function<double(double, double)>;
  const std::vector<std::pair<std::string, G>> binary = {
      {"addition", [](double a, double b) { return a + b; }},
      {"subtraction", [](double a, double b) { return a - b; }},
      {"multiplication", [](double a, double b) { return a * b; }},
      {"division", [](double a, double b) { return a / b; }},
      {"min", [](double a, double b) { return std::min(a, b); }},
      {"max", [](double a, double b) { return std::max(a, b); }},
      {"fmod", [](double a, double b) { return std::fmod(a, b); }},
      {"mod", [](double a, double b) { return a - b * std::floor(a / b); }},  // GLSL
      {"pow", [](double a, double b) { return std::pow(a, b); }},
      {"arctan2", [](double a, double b) { return std::atan2(a, b); }},
  };
  for (const auto& [op, f] : binary)
    expect_values(op,
                  node(op, "o", {{"scalarref", "A", "p.x"}, {"scalarref", "B", "p.y"}}, "scalar"),
                  [&, f = f](double x, double y, double) { return f(x, y); });
  expect_values(
      "clamp",
      node("clamp", "o",
           {{"scalarref", "A", "p.x"}, {"scalarref", "min", "p.y"}, {"scalarref", "max", "p.z"}},
           "scalar"),
      [](double x, double y, double z) { return std::max(y, std::min(x, z)); });
  expect_values("select",
                node("constant", "c", {}, "scalar", "value", " value=\"7\"") +
                    node("select", "o",
                         {{"scalarref", "A", "p.x"},
                          {"scalarref", "B", "p.y"},
                          {"scalarref", "C", "p.z"},
                          {"scalarref", "D", "c.value"}},
                         "scalar"),
                [](double x, double y, double z) { return x < y ? z : 7.0; });
  // Vectors and matrices: cross with a constant, dotted with the position; a matrix, its
  // inverse and transpose: M⁻¹·(M·p) = p, and (Mᵀ)ᵀ = M.
  expect_values(
      "cross",
      node("constvec", "c", {}, "vector", "vector", " x=\"1\" y=\"-2\" z=\"0.5\"") +
          node("cross", "k", {{"vectorref", "A", "inputs.pos"}, {"vectorref", "B", "c.vector"}},
               "vector") +
          node("constvec", "w", {}, "vector", "vector", " x=\"0.3\" y=\"0.7\" z=\"-1.1\"") +
          node("dot", "o", {{"vectorref", "A", "k.result"}, {"vectorref", "B", "w.vector"}},
               "scalar"),
      [](double x, double y, double z) {
        const double cx = y * 0.5 - z * -2, cy = z * 1 - x * 0.5, cz = x * -2 - y * 1;
        return cx * 0.3 + cy * 0.7 + cz * -1.1;
      });
  const std::string m = " matrix=\"2 0.5 0 1  0 3 0.25 -2  0.1 0 1.5 0.5  0 0 0 1\"";
  expect_values(
      "matrices",
      node("constmat", "m", {}, "matrix", "matrix", m) +
          node("transpose", "t", {{"matrixref", "A", "m.matrix"}}, "matrix") +
          node("transpose", "tt", {{"matrixref", "A", "t.result"}}, "matrix") +
          node("inverse", "mi", {{"matrixref", "A", "tt.result"}}, "matrix") +
          node("matrixvectormultiplication", "mp",
               {{"matrixref", "A", "m.matrix"}, {"vectorref", "B", "inputs.pos"}}, "vector") +
          node("matrixvectormultiplication", "back",
               {{"matrixref", "A", "mi.result"}, {"vectorref", "B", "mp.result"}}, "vector") +
          node("subtraction", "diff",
               {{"vectorref", "A", "back.result"}, {"vectorref", "B", "inputs.pos"}}, "vector") +
          node("length", "err", {{"vectorref", "A", "diff.result"}}, "scalar") +
          node("decomposevector", "mpx", {{"vectorref", "A", "mp.result"}}, "scalar", "x") +
          node("addition", "o", {{"scalarref", "A", "err.result"}, {"scalarref", "B", "mpx.x"}},
               "scalar"),
      [](double x, double y, double z) { return 2 * x + 0.5 * y + 1; });
}
