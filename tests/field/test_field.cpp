// The implicit kernel: primitive distances, CSG, transforms, TPMS, expressions, bounds that hold,
// material fractions, and the .vcad reader (the FGM paper's listings and its errors).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>

#include "trellis/core/error.hpp"
#include "trellis/field/field.hpp"
#include "trellis/field/vcad.hpp"

using namespace trellis;

namespace {

const std::string kDesigns = std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/";

TEST(Field, PrimitiveDistancesAreExact) {
  Evaluator s(sphere(10));
  EXPECT_NEAR(s.value({0, 0, 0}), -10, 1e-12);
  EXPECT_NEAR(s.value({13, 4, 0}), std::hypot(13, 4) - 10, 1e-12);
  Evaluator b(rectprism({4, 6, 8}));  // full side lengths
  EXPECT_NEAR(b.value({2, 0, 0}), 0, 1e-12);
  EXPECT_NEAR(b.value({0, 0, 7}), 3, 1e-12);
  EXPECT_NEAR(b.value({5, 6, 0}), std::hypot(3, 3), 1e-12);
  Evaluator c(cylinder(15, 70));  // radius, height, centred
  EXPECT_NEAR(c.value({15, 0, 0}), 0, 1e-12);
  EXPECT_NEAR(c.value({0, 0, 35}), 0, 1e-12);
  EXPECT_NEAR(c.value({0, 0, 0}), -15, 1e-12);
  Evaluator t(torus(10, 2));
  EXPECT_NEAR(t.value({10, 0, 0}), -2, 1e-12);
  EXPECT_NEAR(t.value({0, 0, 0}), 8, 1e-12);
  Evaluator k(cone(5, 10));  // base r=5 at z=-5, tip at z=+5
  EXPECT_NEAR(k.value({0, 0, -5}), 0, 1e-12);
  EXPECT_NEAR(k.value({0, 0, 5}), 0, 1e-12);
  EXPECT_LT(k.value({0, 0, 0}), 0);
  EXPECT_NEAR(k.value({2.5, 0, 0}), 0, 1e-12);  // halfway up the radius is 2.5
}

TEST(Field, CsgAndTransforms) {
  Evaluator d(subtract({cylinder(50, 15), cylinder(15, 15)}));
  EXPECT_GT(d.value({0, 0, 0}), 0);  // in the hole
  EXPECT_LT(d.value({30, 0, 0}), 0);
  Evaluator u(unite({translate(sphere(1), {5, 0, 0}), translate(sphere(1), {-5, 0, 0})}));
  EXPECT_NEAR(u.value({5, 0, 0}), -1, 1e-12);
  EXPECT_NEAR(u.value({0, 0, 0}), 4, 1e-12);
  Evaluator r(rotate(rectprism({10, 2, 2}), {0, 0, 90}));  // long axis now along Y
  EXPECT_LT(r.value({0, 4, 0}), 0);
  EXPECT_GT(r.value({4, 0, 0}), 0);
  Evaluator sc(scale(sphere(1), {2, 2, 2}));
  EXPECT_NEAR(sc.value({3, 0, 0}), 1, 1e-12);
  // Smooth union lies at or below the sharp one, by at most k/4.
  Evaluator sharp(unite({sphere(2), translate(sphere(2), {3, 0, 0})}));
  Evaluator smooth(smooth_unite({sphere(2), translate(sphere(2), {3, 0, 0})}, 1.0));
  for (double x = -3; x <= 6; x += 0.25) {
    const double a = sharp.value({x, 1.5, 0}), b = smooth.value({x, 1.5, 0});
    EXPECT_LE(b, a + 1e-12);
    EXPECT_GE(b, a - 0.25 - 1e-12);
  }
}

TEST(Field, SizeAndSmallestPeriodOfADesign) {
  const Field s = sphere(1);
  const Field u = unite({translate(s, {5, 0, 0}), translate(s, {-5, 0, 0}), s});
  EXPECT_EQ(u.nodes(), 1 + 2 * 2 + 1);  // a shared sphere counts each time it is used
  Field deep = s;
  for (int i = 0; i < 20000; ++i) deep = translate(deep, {0.001, 0, 0});  // no recursion
  EXPECT_EQ(deep.nodes(), 20001);
  Field wide = unite({s, s});
  for (int i = 0; i < 12; ++i) wide = unite({wide, wide});  // a DAG of 14 nodes, 16,383 uses
  EXPECT_EQ(wide.nodes(), std::pow(2.0, 14) - 1);
  EXPECT_TRUE(std::isinf(u.smallest_period()));
  const Field boxed = intersect({rectprism({10, 10, 2}), tpms(TpmsKind::Gyroid, {2, 3, 4})});
  EXPECT_DOUBLE_EQ(boxed.smallest_period(), 2);
  EXPECT_DOUBLE_EQ(translate(boxed, {1, 1, 1}).smallest_period(), 2);
}

TEST(Field, TpmsSheetAndExpressions) {
  Evaluator g(tpms(TpmsKind::Gyroid, {5, 5, 5}, {}));
  EXPECT_NEAR(g.value({0, 0, 0}), 0, 1e-12);  // gyroid passes through the origin
  Evaluator sheet(tpms(TpmsKind::Gyroid, {5, 5, 5}, {"0.3"}));
  EXPECT_NEAR(sheet.value({0, 0, 0}), -0.09, 1e-12);
  const Vec3 p{1.1, 0.7, 2.3};
  const double phi = g.value(p);
  Evaluator graded(tpms(TpmsKind::Gyroid, {5, 5, 5}, {"0.1 + z/100"}));
  EXPECT_NEAR(graded.value(p), phi * phi - std::pow(0.1 + 2.3 / 100, 2), 1e-12);
  Evaluator f(function({-2, -2, -2}, {2, 2, 2}, {"x^2 + y^2 + z^2 - 1"}));
  EXPECT_NEAR(f.value({0, 0, 0}), -1, 1e-12);
  EXPECT_GT(f.value({3, 0, 0}), 0);  // cut to the box
  EXPECT_THROW(check_expression("sin(x"), ParseError);
  EXPECT_THROW(check_expression("foo(x)"), ParseError);
  check_expression("abs(phi)/pi + rho + theta + phis + r + d");
}

// Bounds must contain every value in the box, on random CSG trees and random boxes.
TEST(Field, BoundsAreConservative) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  auto leaf = [&]() -> Field {
    switch (rng() % 5) {
      case 0:
        return sphere(1 + 3 * std::abs(U(rng)));
      case 1:
        return rectprism(
            {1 + 4 * std::abs(U(rng)), 1 + 4 * std::abs(U(rng)), 1 + 4 * std::abs(U(rng))});
      case 2:
        return cylinder(1 + 2 * std::abs(U(rng)), 2 + 5 * std::abs(U(rng)));
      case 3:
        return torus(3, 0.5 + std::abs(U(rng)));
      default:
        return tpms(TpmsKind::SchwarzP, {4, 4, 4}, {"0.4"});
    }
  };
  for (int trial = 0; trial < 60; ++trial) {
    Field f = leaf();
    for (int d = 0; d < 3; ++d) {
      Field g = translate(leaf(), {3 * U(rng), 3 * U(rng), 3 * U(rng)});
      switch (rng() % 6) {
        case 0:
          f = unite({f, g});
          break;
        case 1:
          f = intersect({f, g});
          break;
        case 2:
          f = subtract({f, g});
          break;
        case 3:
          f = smooth_unite({f, g}, 1.0);
          break;
        case 4:
          f = rotate(f, {90 * U(rng), 90 * U(rng), 90 * U(rng)});
          break;
        default:
          f = scale(f, {1 + 0.5 * std::abs(U(rng)), 1, 1 + std::abs(U(rng))});
          break;
      }
    }
    Evaluator ev(f);
    for (int b = 0; b < 20; ++b) {
      BBox3 box;
      const Vec3 c{4 * U(rng), 4 * U(rng), 4 * U(rng)};
      const double h = 0.05 + 2 * std::abs(U(rng));
      box.add(c - Vec3{h, h, h});
      box.add(c + Vec3{h, h, h});
      const Interval iv = ev.bound(box);
      for (int s = 0; s < 30; ++s) {
        const Vec3 p = c + Vec3{h * U(rng), h * U(rng), h * U(rng)};
        const double v = ev.value(p);
        ASSERT_GE(v, iv.lo - 1e-9) << "trial " << trial;
        ASSERT_LE(v, iv.hi + 1e-9) << "trial " << trial;
      }
    }
  }
}

TEST(Field, MaterialFractions) {
  const auto d = read_vcad(kDesigns + "fgm_column2_plate.vcad");
  ASSERT_EQ(d.field.materials(), (std::vector<std::string>{"blue", "yellow"}));
  Evaluator ev(d.field);
  auto f = ev.fractions({0, 0, 0});
  EXPECT_NEAR(f[0], 0.5, 1e-12);
  EXPECT_NEAR(f[1], 0.5, 1e-12);
  f = ev.fractions({0, 37.5, 0});
  EXPECT_NEAR(f[0], 1.0, 1e-12);
  // Listing 3 uses phi (cylindrical angle) and pi.
  Evaluator ring(read_vcad(kDesigns + "fgm_column3_ring_angular.vcad").field);
  f = ring.fractions({-30, 1e-9, 0});
  EXPECT_NEAR(f[0], 1.0, 1e-6);
  f = ring.fractions({0, 30, 0});
  EXPECT_NEAR(f[0], 0.5, 1e-9);
  // Listing 4: radial.
  Evaluator radial(read_vcad(kDesigns + "fgm_column5_ring_radial.vcad").field);
  f = radial.fractions({32.5, 0, 0});
  EXPECT_NEAR(f[0], 0.5, 1e-9);
}

// Fractions over a row of points (each expression evaluated over the row) are the same numbers
// as point by point: Listings 2-4 (x, y, phi, pi, radial), the distance d, three materials, a
// grade under a transform and beside a plain material, points inside and outside.
TEST(Field, BatchFractionsEqualPointByPoint) {
  std::vector<Field> designs;
  for (const char* name :
       {"fgm_column2_plate.vcad", "fgm_column3_ring_angular.vcad", "fgm_column5_ring_radial.vcad"})
    designs.push_back(read_vcad(kDesigns + name).field);
  designs.push_back(
      parse_vcad("fgrade([\"clamp(-d/4, 0, 1)\", \"1 - clamp(-d/4, 0, 1)\"], [\"core\", \"skin\"]) "
                 "{ sphere(10); }\n",
                 "d.vcad")
          .field);
  designs.push_back(
      parse_vcad("union() {\n"
                 "  translate((3, -2, 1)) { fgrade([\"x*x\", \"abs(y)\", \"1 + sin(theta)*r\"],\n"
                 "                                   [\"a\", \"b\", \"c\"]) { sphere(8); } }\n"
                 "  translate((20, 0, 0)) { sphere(4, \"c\"); }\n"
                 "}\n",
                 "three.vcad")
          .field);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-40, 40);
  for (std::size_t k = 0; k < designs.size(); ++k) {
    Evaluator batch(designs[k]), single(designs[k]);
    const std::size_t m = designs[k].materials().size();
    ASSERT_GE(m, 2u) << "design " << k;
    for (std::size_t n : {1, 2, 17, 300}) {
      std::vector<Vec3> p(n);
      for (auto& q : p) q = {U(rng), U(rng), U(rng) / 8};
      std::vector<double> out(n * m, -1.0);
      batch.fractions(p.data(), n, out.data());
      for (std::size_t i = 0; i < n; ++i) {
        const std::vector<double> f = single.fractions(p[i]);
        ASSERT_EQ(f.size(), m);
        for (std::size_t j = 0; j < m; ++j)
          ASSERT_EQ(out[i * m + j], f[j]) << "design " << k << " point " << i << " material " << j;
      }
    }
  }
}

// A fraction that is not a finite number is an error naming the same point in a row as alone.
TEST(Field, BatchFractionsNotFiniteNamesThePoint) {
  const Field f =
      parse_vcad("fgrade([\"1/(x - 2)\", \"1\"], [\"a\", \"b\"]) { sphere(10); }\n", "inf.vcad")
          .field;
  Evaluator ev(f);
  const std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  std::vector<double> out(p.size() * 2);
  std::string batch_message, single_message;
  try {
    ev.fractions(p.data(), p.size(), out.data());
  } catch (const GeometryError& e) {
    batch_message = e.what();
  }
  try {
    ev.fractions(p[2]);
  } catch (const GeometryError& e) {
    single_message = e.what();
  }
  EXPECT_NE(batch_message.find("(2, 0, 0)"), std::string::npos) << batch_message;
  EXPECT_EQ(batch_message, single_message);
}

TEST(Vcad, AppendixBListingsParse) {
  for (const char* name :
       {"fgm_column1_cylinder.vcad", "fgm_column2_plate.vcad", "fgm_column3_ring_angular.vcad",
        "fgm_column5_ring_radial.vcad", "gyroid_sheet_cube.vcad", "csg_bracket.vcad"}) {
    const auto d = read_vcad(kDesigns + name);
    EXPECT_FALSE(d.field.empty()) << name;
    const BBox3 e = d.field.extent();
    EXPECT_TRUE(std::isfinite(e.min.x) && std::isfinite(e.max.z)) << name;
  }
  const auto vase = read_vcad(kDesigns + "fgm_column6_vase.vcad");
  const BBox3 e = vase.field.extent();
  EXPECT_NEAR(e.max.x - e.min.x, 135, 0.5);
  EXPECT_NEAR(e.max.y - e.min.y, 175, 0.5);
  EXPECT_NEAR(e.max.z - e.min.z, 100, 0.5);
  const auto plate = read_vcad(kDesigns + "fgm_column2_plate.vcad");
  const BBox3 p = plate.field.extent();
  EXPECT_NEAR(p.max.x - p.min.x, 150, 1e-9);
  EXPECT_NEAR(p.max.z - p.min.z, 2.5, 1e-9);
}

TEST(Vcad, RootTuplesMaterialsAndComments) {
  const auto d = parse_vcad(
      "/* a block */ root((-5,-5,-5),(5,5,5),(0.05,0.05,0.05)) {\n"
      "  union(1) { sphere(3, \"red\"); translate((4,0,0)) { rectprism((2,2,2), \"blue\"); } }\n"
      "  // more\n"
      "}\n",
      "t.vcad");
  EXPECT_TRUE(d.has_root);
  EXPECT_DOUBLE_EQ(d.resolution.x, 0.05);
  EXPECT_EQ(d.field.materials(), (std::vector<std::string>{"red", "blue"}));
  Evaluator ev(d.field);
  EXPECT_LT(ev.value({0, 0, 0}), 0);
  EXPECT_GT(ev.value({0, 0, 4.9}), 0);
  EXPECT_NEAR(ev.fractions({0, 0, 0})[0], 1.0, 1e-12);
  EXPECT_NEAR(ev.fractions({4, 0, 0})[1], 1.0, 1e-12);
}

struct BadCase {
  const char* text;
  long line, column;
  const char* words;
};

TEST(Vcad, ErrorsNameLineAndColumn) {
  const BadCase cases[] = {
      {"sphere(1);\n  spere(2);", 2, 3, "unknown node 'spere'"},
      {"cylinder(15);", 1, 1, "cylinder takes 2 arguments"},
      {"union() {\n sphere(1);\n", 1, 1, "missing '}'"},
      {"sphere(1) }", 1, 11, "expected a node name"},
      {"fgrade([\"x/2\", \"1-x/\"], [\"a\", \"b\"]) { sphere(1); }", 1, 21, "bad expression"},
      {"fgrade([\"x\"], [\"a\", \"b\"]) { sphere(1); }", 1, 1, "1 expressions but 2 materials"},
      {"fgrade([\"x\", \"1-x\"], [\"a\", \"b\"], \"banana\") { sphere(1); }", 1, 34,
       "mode \"banana\" is not supported"},
      {"sphere(-1);", 1, 1, "positive"},
      {"sphere(1", 1, 9, "expected"},
      {"sphere(\"a);", 1, 8, "string not closed"},
      {"mesh(\"no_such_file.stl\");", 1, 6, "no_such_file.stl"},
      {"translate(1,2) { sphere(1); }", 1, 1, "translate takes (x, y, z)"},
      {"root((0,0,0),(1,1,1),(0.1,0.1,0.1)) { sphere(1); } sphere(2);", 1, 52,
       "nothing may follow"},
      {"", 1, 1, "empty design"},
      {"rotate(0,0,0) { }", 1, 1, "empty block"},
  };
  for (const auto& c : cases) {
    try {
      parse_vcad(c.text, "bad.vcad");
      ADD_FAILURE() << "accepted: " << c.text;
    } catch (const ParseError& e) {
      EXPECT_EQ(e.where().file, "bad.vcad");
      EXPECT_EQ(e.where().line, c.line) << c.text << " -> " << e.what();
      EXPECT_EQ(e.where().column, c.column) << c.text << " -> " << e.what();
      EXPECT_NE(std::string(e.what()).find(c.words), std::string::npos) << e.what();
    }
  }
}

TEST(Vcad, DeepNestingIsAnErrorNotACrash) {
  std::string text;
  for (int i = 0; i < 5000; ++i) text += "union() {";
  text += "sphere(1);";
  for (int i = 0; i < 5000; ++i) text += "}";
  EXPECT_THROW(parse_vcad(text, "deep.vcad"), ParseError);
}

}  // namespace

namespace {

// Inputs that once crashed a fuzz target (tests/data/fuzz_regressions/vcad_*): each must parse
// or fail with a ParseError, and evaluate without undefined behaviour.
TEST(Vcad, FuzzRegressions) {
  const std::string dir = std::string(TRELLIS_SOURCE_DIR) + "/tests/data/fuzz_regressions/";
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("vcad_", 0) != 0) continue;
    try {
      const auto d = read_vcad(entry.path().string());
      Evaluator ev(d.field);
      (void)ev.value({1e30, 1e30, 1e53});
    } catch (const ParseError&) {
    }
  }
  // TPMS far away (1e53 mm): finite values, no overflow in the fast sine.
  Evaluator g(tpms(TpmsKind::Gyroid, {0.3, 0.3, 0.3}));
  EXPECT_TRUE(std::isfinite(g.value({1, 2, 1e53})));
}

}  // namespace

namespace {

// value_gradient gives exactly value() and gradient(): one evaluation for a TPMS (all five
// kinds, anisotropic cells, far and near points), and the two calls for other fields.
TEST(Field, ValueGradientEqualsValueAndGradient) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> U(-40, 40);
  std::vector<Field> fields;
  for (const TpmsKind k :
       {TpmsKind::Gyroid, TpmsKind::SchwarzP, TpmsKind::SchwarzD, TpmsKind::Neovius, TpmsKind::Iwp})
    fields.push_back(tpms(k, {2.5, 3.0, 1.7}));
  fields.push_back(sphere(4));  // no analytic gradient
  fields.push_back(translate(tpms(TpmsKind::Gyroid, {2, 2, 2}), {0.3, 0, 1}));
  std::size_t checked = 0;
  for (const Field& f : fields) {
    Evaluator a(f), b(f);
    for (int i = 0; i < 2000; ++i) {
      const Vec3 p{U(rng), U(rng), U(rng)};
      Vec3 g;
      const double v = a.value_gradient(p, &g);
      const Vec3 g2 = b.gradient(p);
      EXPECT_EQ(v, b.value(p));
      EXPECT_EQ(g.x, g2.x);
      EXPECT_EQ(g.y, g2.y);
      EXPECT_EQ(g.z, g2.z);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 14000u);
}

}  // namespace

namespace {

// TPMS bounds (the smaller of the Lipschitz and the second-order spread): every value in the
// box inside, on all five kinds with anisotropic cells, for cubes and for flat boxes (the
// blocks a layer's contouring asks about); and on the gyroid's 0.1 mm layer blocks the bound is
// on average under 3/4 the width of the Lipschitz bound alone (measured 0.64: the narrower band
// contouring samples).
TEST(Field, TpmsBoundsAreConservativeAndNarrow) {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> U(-1, 1);
  for (const TpmsKind kind : {TpmsKind::Gyroid, TpmsKind::SchwarzP, TpmsKind::SchwarzD,
                              TpmsKind::Neovius, TpmsKind::Iwp}) {
    Evaluator ev(tpms(kind, {2.5, 1.9, 3.1}));
    for (int b = 0; b < 400; ++b) {
      const Vec3 c{10 * U(rng), 10 * U(rng), 10 * U(rng)};
      const double h = 0.005 + 1.5 * std::abs(U(rng)) * std::abs(U(rng));
      const Vec3 half{h, h * (0.3 + std::abs(U(rng))), b % 2 ? 0.0 : h};
      BBox3 box;
      box.add(c - half);
      box.add(c + half);
      const Interval iv = ev.bound(box);
      for (int s = 0; s < 200; ++s) {
        const Vec3 p = s < 8 ? c + Vec3{s & 1 ? half.x : -half.x, s & 2 ? half.y : -half.y,
                                        s & 4 ? half.z : -half.z}
                             : c + Vec3{half.x * U(rng), half.y * U(rng), half.z * U(rng)};
        const double v = ev.value(p);
        ASSERT_GE(v, iv.lo - 1e-12) << to_string(kind) << " box " << b;
        ASSERT_LE(v, iv.hi + 1e-12) << to_string(kind) << " box " << b;
      }
    }
  }
  Evaluator gyroid(tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5}));
  const double k = 2 * std::numbers::pi / 2.5, lipschitz = 1.01 * std::sqrt(3.0) * k;
  double ratio = 0;
  const int n = 2000;
  for (int b = 0; b < n; ++b) {
    const Vec3 c{5 * U(rng), 5 * U(rng), 5 * U(rng)};
    BBox3 box;
    box.add(c - Vec3{0.05, 0.05, 0});
    box.add(c + Vec3{0.05, 0.05, 0});
    const Interval iv = gyroid.bound(box);
    ratio += (iv.hi - iv.lo) / (2 * lipschitz * std::hypot(0.05, 0.05));
  }
  EXPECT_LT(ratio / n, 0.75);
}

}  // namespace

namespace {

// The values (and, for TPMS, gradients) at a grid of a plane by values_grid / gradients_grid,
// against values() / gradient() point by point at the same coordinates.
struct GridCheck {
  double worst_value = 0, worst_gradient = 0;
  bool has_gradients = false;
};
GridCheck compare_grid(const Field& f, double x0, double y0, double step, std::size_t w,
                       std::size_t rows, double z) {
  Evaluator ev(f);
  std::vector<double> xs(w), ys(rows);
  for (std::size_t i = 0; i < w; ++i) xs[i] = x0 + static_cast<double>(i) * step;
  for (std::size_t j = 0; j < rows; ++j) ys[j] = y0 + static_cast<double>(j) * step;
  std::vector<double> grid(w * rows, std::numeric_limits<double>::quiet_NaN());
  ev.values_grid(xs.data(), w, ys.data(), rows, z, grid.data());
  std::vector<Vec3> grads(w * rows);
  GridCheck c;
  c.has_gradients = ev.gradients_grid(xs.data(), w, ys.data(), rows, z, grads.data());
  Evaluator one(f);  // a fresh evaluator: nothing shared with the grid's
  for (std::size_t j = 0; j < rows; ++j)
    for (std::size_t i = 0; i < w; ++i) {
      const Vec3 p{xs[i], ys[j], z};
      const double v = one.value(p);
      const double d = std::isfinite(grid[j * w + i]) ? std::abs(grid[j * w + i] - v) : 1e300;
      c.worst_value = std::max(c.worst_value, d);
      if (c.has_gradients)
        c.worst_gradient = std::max(c.worst_gradient, norm(grads[j * w + i] - one.gradient(p)));
    }
  return c;
}

}  // namespace

TEST(Field, GridValuesEqualPointValues) {
  // Every TPMS kind, anisotropic cells, alone and as sheets cut by boxes (the PBF route's part),
  // on grids large enough for CSG to skip children by their bounds and small ones that do not.
  const TpmsKind kinds[] = {TpmsKind::Gyroid, TpmsKind::SchwarzP, TpmsKind::SchwarzD,
                            TpmsKind::Neovius, TpmsKind::Iwp};
  for (const TpmsKind kind : kinds) {
    const Field phi = tpms(kind, {2.5, 3.0, 2.0});
    const Field part = intersect({sheet(phi, {"0.3"}), rectprism({6, 5, 4})});
    const std::vector<std::pair<std::string, Field>> fields = {
        {"phi", phi},
        {"sheet", sheet(phi, {"0.3"})},
        {"part", part},
        {"part+solid", unite({part, translate(sphere(1), {1, 1, 0})})},
        {"part-hole", subtract({part, cylinder(0.8, 10)})},
        {"smooth", smooth_intersect({sheet(phi, {"0.3"}), rectprism({6, 5, 4})}, 0.2)},
        {"clip", clip_box(sheet(phi, {"0.2"}), {-2, -2, -2}, {2, 1.5, 2})},
        {"graded", fgrade(part, {{"0.5"}, {"0.5"}}, {"a", "b"})},
        // Paths without a grid of their own fall back to points: a rotated TPMS (x and y mix),
        // a c that varies, a uniform thickness, a blend, an expression.
        {"rotated", rotate(phi, {0, 0, 30})},
        {"c(x)", sheet(phi, {"0.2 + 0.05*x"})},
        {"thickness", sheet(phi, {}, 0.1)},
        {"blend", blend(phi, tpms(TpmsKind::SchwarzP, {2, 2, 2}), {"0.3"})},
        {"expression", expression_field({"sin(x)*cos(y) + z"})},
    };
    for (const auto& [name, f] : fields)
      for (const auto& [w, rows, step] : {std::tuple<std::size_t, std::size_t, double>{5, 5, 0.025},
                                          {17, 9, 0.1},
                                          {1, 7, 0.05},
                                          {3, 1, 0.3}}) {
        const GridCheck c = compare_grid(f, -3.3, -2.8, step, w, rows, 0.37);
        EXPECT_LE(c.worst_value, 1e-12)
            << to_string(kind) << " " << name << " " << w << "x" << rows;
        // Grids inside the boxes near their faces (a clip box's shortcut: no square root), and
        // across their edges.
        for (const Vec2 o :
             {Vec2{1.895, 1.395}, Vec2{0.3, 1.45}, Vec2{1.95, 0.3}, Vec2{-2.05, 0.3}})
          EXPECT_LE(compare_grid(f, o.x, o.y, step, w, rows, 0.37).worst_value, 1e-12)
              << to_string(kind) << " " << name << " " << w << "x" << rows << " at " << o.x << ","
              << o.y;
        if (name == "phi") {
          EXPECT_TRUE(c.has_gradients) << to_string(kind);
          EXPECT_LE(c.worst_gradient, 1e-12) << to_string(kind) << " " << w << "x" << rows;
        }
        if (name == "rotated") EXPECT_FALSE(c.has_gradients);  // no grid path: the caller's
      }
    // Far from the origin (sines by libm's full reduction, not through the memo).
    EXPECT_LE(compare_grid(phi, 3e6, -2e6, 0.1, 5, 5, 1e6).worst_value, 1e-12) << to_string(kind);
  }
}

// A TPMS repeats after its cell along each axis (Field::period), translations keep it, other
// transforms and other primitives claim none; half a cell is not a period (the test would fail
// with one).
TEST(Field, TpmsPeriodIsItsCell) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-20, 20);
  for (auto kind : {TpmsKind::Gyroid, TpmsKind::SchwarzP, TpmsKind::SchwarzD, TpmsKind::Neovius,
                    TpmsKind::Iwp}) {
    const Vec3 cell{2.5, 3.2, 1.7};
    for (const Field& f : {tpms(kind, cell), translate(tpms(kind, cell), {0.31, -1.7, 4.2})}) {
      const Vec3 P = f.period();
      EXPECT_NEAR(P.x, cell.x, 1e-12) << to_string(kind);
      EXPECT_NEAR(P.y, cell.y, 1e-12) << to_string(kind);
      EXPECT_NEAR(P.z, cell.z, 1e-12) << to_string(kind);
      Evaluator ev(f);
      double worst = 0, half = 0;
      for (int i = 0; i < 300; ++i) {
        const Vec3 p{u(rng), u(rng), u(rng)};
        const double v = ev.value(p);
        for (const Vec3 step :
             {Vec3{P.x, 0, 0}, Vec3{0, P.y, 0}, Vec3{0, 0, P.z}, Vec3{-3 * P.x, 2 * P.y, 0}}) {
          worst = std::max(worst, std::abs(ev.value(p + step) - v));
          half = std::max(half, std::abs(ev.value(p + step * 0.5) - v));
        }
      }
      EXPECT_LT(worst, 1e-9) << to_string(kind);
      if (kind == TpmsKind::Gyroid || kind == TpmsKind::SchwarzD)
        EXPECT_GT(half, 0.1) << to_string(kind);
    }
  }
  const Field g = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  for (const Field& f : {rotate(g, {0, 0, 30}), scale(g, {2, 2, 2}), sphere(3), sheet(g, {"0.2"}),
                         intersect({g, cube(5)})}) {
    const Vec3 P = f.period();
    EXPECT_EQ(P.x, 0);
    EXPECT_EQ(P.y, 0);
    EXPECT_EQ(P.z, 0);
  }
}

// A box's bound over a query box is exact: its least value is at the query point nearest the
// box's centre on every axis, its greatest at a corner, and no point of the query box is outside
// it (random boxes and queries, inside, across and outside the box).
TEST(Field, BoxBoundsAreExact) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-6, 6), s(0.1, 4);
  for (int trial = 0; trial < 300; ++trial) {
    const Vec3 size{s(rng), s(rng), s(rng)}, at{u(rng), u(rng), u(rng)};
    const Field f = translate(rectprism(size), at);
    Evaluator ev(f);
    BBox3 q;
    q.add({u(rng), u(rng), u(rng)});
    q.add({u(rng), u(rng), u(rng)});
    if (trial % 3 == 0) q.max.z = q.min.z;  // flat, as a layer's blocks
    const Interval b = ev.bound(q);
    const Vec3 nearest{std::clamp(at.x, q.min.x, q.max.x), std::clamp(at.y, q.min.y, q.max.y),
                       std::clamp(at.z, q.min.z, q.max.z)};
    EXPECT_NEAR(b.lo, ev.value(nearest), 1e-12) << trial;
    double corner = -1e300;
    for (int c = 0; c < 8; ++c)
      corner = std::max(corner, ev.value({(c & 1) ? q.max.x : q.min.x, (c & 2) ? q.max.y : q.min.y,
                                          (c & 4) ? q.max.z : q.min.z}));
    EXPECT_NEAR(b.hi, corner, 1e-12) << trial;
    std::uniform_real_distribution<double> px(q.min.x, q.max.x), py(q.min.y, q.max.y),
        pz(q.min.z, std::max(q.min.z, q.max.z));
    for (int i = 0; i < 50; ++i) {
      const double v = ev.value({px(rng), py(rng), q.max.z > q.min.z ? pz(rng) : q.min.z});
      EXPECT_GE(v, b.lo - 1e-12);
      EXPECT_LE(v, b.hi + 1e-12);
    }
  }
}

// Field::inversion_parity: f(−p) = parity · f(p) at random points for every TPMS kind (odd: the
// gyroid and Schwarz D; even: Schwarz P, Neovius, I-WP), kept by a scaling about the origin;
// unknown (0) once translated, or for a sphere (not claimed).
TEST(Field, InversionParityHoldsAtRandomPoints) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-7, 7);
  const std::pair<TpmsKind, int> kinds[] = {{TpmsKind::Gyroid, -1},
                                            {TpmsKind::SchwarzP, 1},
                                            {TpmsKind::SchwarzD, -1},
                                            {TpmsKind::Neovius, 1},
                                            {TpmsKind::Iwp, 1}};
  for (const auto& [kind, parity] : kinds) {
    for (const Field f : {tpms(kind, {2.5, 2.1, 3}), scale(tpms(kind, {2, 2, 2}), {1.5, 1, 2})}) {
      ASSERT_EQ(f.inversion_parity(), parity) << to_string(kind);
      Evaluator e(f);
      for (int k = 0; k < 200; ++k) {
        const Vec3 p{u(rng), u(rng), u(rng)};
        EXPECT_NEAR(e.value(p * -1.0), parity * e.value(p), 1e-12) << to_string(kind);
      }
    }
    EXPECT_EQ(translate(tpms(kind, {2, 2, 2}), {0.3, 0, 0}).inversion_parity(), 0);
  }
  EXPECT_EQ(sphere(2).inversion_parity(), 0);
}
