// Strategy 2 in path order (issue 39): each island filled whole — fgm.perimeters rings around the
// outline, then level lines a bead apart of a potential that follows the material iso-lines,
// paired into loops and bridged into few beads — and the beads cut at the colour zones' edges
// into joined pieces with their colour's mixture. Properties over generated fields and outlines.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "../../src/slice/fgm_outline.hpp"
#include "support/scanline.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/fgm.hpp"

using namespace trellis;

namespace {

struct Case {
  std::string name, vcad;
  int colors = 8, materials = 2;
  double material_resolution = 0.5;
};

std::string two_materials(const std::string& f, const std::string& body) {
  return "fgrade([\"" + f + "\", \"1 - (" + f + ")\"], [\"a\", \"b\"]) {\n  " + body + "\n}\n";
}

// Random smooth two-material fields (a slope and a wave, f clamped by the palette) on a plate,
// a ring and a disc; the palette plate's gradient (extremes and saddles) on a 40 mm plate; a
// radial gradient on a ring; three materials on a disc.
std::vector<Case> cases() {
  std::vector<Case> out;
  std::mt19937 rng(3939);
  std::uniform_real_distribution<double> u(-1, 1);
  const char* bodies[] = {"rectprism(30, 20, 0.6);",
                          "difference() { cylinder(14, 0.6); cylinder(5, 0.6); }",
                          "cylinder(12, 0.6);"};
  for (int k = 0; k < 6; ++k) {
    const double a = 0.5 * u(rng), e = 0.5 * u(rng), b = 0.15 * u(rng), c = 0.4 * u(rng),
                 d = 0.4 * u(rng);
    char f[256];
    std::snprintf(f, sizeof f, "0.5 + %.3f*x/15 + %.3f*sin(%.3f*x + %.3f*y) + %.3f*y/15", a, b, c,
                  d, e);
    Case cs;
    cs.name = f + std::string(", body ") + std::to_string(k % 3);
    cs.vcad = two_materials(f, bodies[k % 3]);
    cs.colors = 2 + static_cast<int>(rng() % 15u);
    out.push_back(cs);
  }
  out.push_back({"palette plate gradient, 40 mm",
                 two_materials("(1 + sin(0.05*x + 0.08*y)*cos(0.08*x - 0.05*y))/2",
                               "rectprism(40, 40, 0.6);"),
                 12, 2, 0.5});
  out.push_back({"radial ring",
                 two_materials("(sqrt(x^2+y^2) - 5)/10",
                               "difference() { cylinder(15, 0.6); cylinder(5, 0.6); }"),
                 10, 2, 0.5});
  out.push_back(
      {"three materials",
       "fgrade([\"(1 + 2*cos(phi)*rho/15)/3\", \"(1 + 2*cos(phi - 2*pi/3)*rho/15)/3\", "
       "\"(1 + 2*cos(phi + 2*pi/3)*rho/15)/3\"], [\"a\", \"b\", \"c\"]) {\n  cylinder(15, "
       "0.6);\n}\n",
       9, 3, 0.5});
  return out;
}

struct Planned {
  Field field;
  std::vector<LayerOutline> outlines;
  FgmOptions options;
  Toolpath toolpath;
  FgmStats stats;
};

Planned plan(const Case& c) {
  Planned p;
  p.field = parse_vcad(c.vcad, "test.vcad").field;
  const BBox3 e = p.field.extent();
  p.outlines = slice_field(p.field, layer_planes(e.min.z, e.max.z, 0.3), FieldSliceOptions{});
  p.options.palette.colors = c.colors;
  p.options.palette.materials = c.materials;
  p.options.layer_height = 0.3;
  p.options.bead_width = 0.4;
  p.options.material_resolution = c.material_resolution;
  p.toolpath = plan_fgm_strategy2(p.field, p.outlines, p.options, &p.stats);
  return p;
}

// The pieces of a layer grouped into beads (a piece that is not joined begins one).
std::vector<std::vector<const Path*>> beads_of(const Layer& layer) {
  std::vector<std::vector<const Path*>> beads;
  for (const Path& q : layer.paths) {
    if (!q.joined || beads.empty()) beads.emplace_back();
    beads.back().push_back(&q);
  }
  return beads;
}

// Pixels of the layer's outline inset by `inset`, each bead (a path and the pieces joined to it)
// painted as round beads of `scale` times each piece's width (Path::width): a pixel counts once
// per bead, and again only for a stretch of the bead more than two beads further along it (the
// bead running over itself: a connector over a line), not where two pieces meet.
struct Raster {
  double coverage = 0, three = 0;
};
Raster raster(const Layer& layer, const Regions& outline, double inset, double scale,
              double px = 0.04) {
  const Regions inner = offset(outline, -inset);
  BBox3 b;
  for (const auto& poly : inner)
    for (const Vec2 q : poly.outer) b.add({q.x, q.y, 0});
  const int nx = static_cast<int>((b.max.x - b.min.x) / px) + 1;
  const int ny = static_cast<int>((b.max.y - b.min.y) / px) + 1;
  std::vector<unsigned char> count(static_cast<std::size_t>(nx) * ny, 0);
  struct Mark {
    int bead = -1;
    double s = 0;
  };
  std::vector<Mark> last(count.size());
  int bead = -1;
  double along = 0;
  for (const Path& p : layer.paths) {
    if (!p.joined) ++bead, along = 0;
    const double r = 0.5 * scale * (p.width > 0 ? p.width : 0.4);
    for (std::size_t k = 0; k + 1 < p.points.size(); ++k) {
      const Vec3 a{p.points[k].x, p.points[k].y, 0}, c{p.points[k + 1].x, p.points[k + 1].y, 0};
      const double len = distance(a, c);
      const int x0 = std::max(0, static_cast<int>((std::min(a.x, c.x) - r - b.min.x) / px));
      const int x1 = std::min(nx - 1, static_cast<int>((std::max(a.x, c.x) + r - b.min.x) / px));
      const int y0 = std::max(0, static_cast<int>((std::min(a.y, c.y) - r - b.min.y) / px));
      const int y1 = std::min(ny - 1, static_cast<int>((std::max(a.y, c.y) + r - b.min.y) / px));
      for (int iy = y0; iy <= y1; ++iy)
        for (int ix = x0; ix <= x1; ++ix) {
          const Vec3 q{b.min.x + (ix + 0.5) * px, b.min.y + (iy + 0.5) * px, 0};
          double t = 0;
          if (distance_to_segment(q, a, c, &t) > r) continue;
          const auto cell = static_cast<std::size_t>(iy) * nx + ix;
          const double s = along + t * len;
          Mark& m = last[cell];
          if (m.bead == bead && std::abs(s - m.s) < 2 * 0.4) continue;
          m = {bead, s};
          if (count[cell] < 255) ++count[cell];
        }
      along += len;
    }
  }
  std::size_t inside = 0, covered = 0, three = 0;
  test::for_each_pixel_inside(inner, {b.min.x, b.min.y}, px, nx, ny, [&](int ix, int iy) {
    const unsigned char n = count[static_cast<std::size_t>(iy) * nx + ix];
    ++inside;
    covered += n >= 1;
    three += n >= 3;
  });
  Raster out;
  out.coverage = inside ? double(covered) / double(inside) : 1;
  out.three = inside ? double(three) / double(inside) : 0;
  return out;
}

}  // namespace

TEST(FgmOutline, EachBeadsPiecesAreTheBead) {
  // The layer's beads as the fill plans them (uncut) against what is printed: each bead's pieces
  // (a first one and the joined ones after it) together are the bead, its points in order and
  // the cut points on its segments, the same length: no bead added or lost.
  std::size_t joined = 0;
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name + ", " + std::to_string(c.colors) + " colours");
    const Planned p = plan(c);
    ASSERT_EQ(p.toolpath.layers.size(), p.outlines.size());
    for (std::size_t li = 0; li < p.outlines.size(); ++li) {
      Evaluator ev(p.field);
      const auto uncut = fgm::layer_beads(ev, p.outlines[li], li, p.options).paths;
      const auto beads = beads_of(p.toolpath.layers[li]);
      ASSERT_EQ(beads.size(), uncut.size()) << "layer " << li;
      for (std::size_t k = 0; k < beads.size(); ++k) {
        std::vector<Vec3> bead;
        for (const Path* q : beads[k]) {
          if (!bead.empty()) {
            ASSERT_LT(distance(bead.back(), q->points.front()), 1e-12) << "joined pieces meet";
            bead.insert(bead.end(), q->points.begin() + 1, q->points.end());
          } else {
            bead = q->points;
          }
          joined += q->joined;
        }
        const auto& orig = uncut[k].points;
        std::size_t at = 0;
        for (std::size_t i = 0; i < orig.size(); ++i) {
          while (at < bead.size() && distance(bead[at], orig[i]) > 1e-9) {
            ASSERT_GT(i, 0u) << "the bead starts where it was planned";
            EXPECT_LT(distance_to_segment(bead[at], orig[i - 1], orig[i]), 1e-9)
                << "a cut off the bead";
            ++at;
          }
          ASSERT_LT(at, bead.size())
              << "layer " << li << " bead " << k << ": point " << i << " missing";
          ++at;
        }
        EXPECT_EQ(at, bead.size()) << "the bead ends where it was planned";
      }
    }
    EXPECT_EQ(p.stats.joined, [&] {
      std::size_t n = 0;
      for (const auto& l : p.toolpath.layers)
        for (const auto& q : l.paths) n += q.joined;
      return n;
    }());
  }
  EXPECT_GT(joined, 100u) << "beads cross colour edges";
}

TEST(FgmOutline, EveryPointIsWithinTheBoundOfItsColour) {
  // A piece lies in one colour's zone (it is cut where it crosses a zone's edge, and a run
  // shorter than fgm.min_segment is merged into its neighbour only within the bound): every point
  // of it, every 0.1 mm, within the palette's bound (α/2; 2α/3 for three materials) of the
  // design, to the zones' edges' 1e-3 of a band; a joined piece changes the mixture by at most one
  // palette step, and the stats agree.
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name + ", " + std::to_string(c.colors) + " colours");
    const Planned p = plan(c);
    const Palette& pal = p.options.palette;
    const double bound = pal.error_bound() + 1e-3 * pal.band();
    Evaluator ev(p.field);
    double worst = 0;
    std::size_t checked = 0;
    for (std::size_t li = 0; li < p.toolpath.layers.size(); ++li) {
      const auto& paths = p.toolpath.layers[li].paths;
      for (std::size_t k = 0; k < paths.size(); ++k) {
        const Path& q = paths[k];
        ASSERT_EQ(q.mixture, pal.mixture(pal.color_of(q.mixture)));
        for (std::size_t i = 0; i + 1 < q.points.size(); ++i) {
          const Vec3 a = q.points[i], b = q.points[i + 1];
          const int n = std::max(1, static_cast<int>(std::ceil(distance(a, b) / 0.1)));
          for (int j = 0; j <= n; ++j) {
            const Vec3 s = a + (b - a) * (static_cast<double>(j) / n);
            const auto f = ev.fractions({s.x, s.y, p.outlines[li].z});
            double e = 0;
            for (std::size_t m = 0; m < f.size(); ++m)
              e = std::max(e, std::abs(std::clamp(f[m], 0.0, 1.0) - q.mixture[m]));
            worst = std::max(worst, e);
            ASSERT_LE(e, bound) << "layer " << li << " at " << s.x << ", " << s.y;
            ++checked;
          }
        }
        if (q.joined && q.mixture != paths[k - 1].mixture) {
          double change = 0;
          for (std::size_t m = 0; m < q.mixture.size(); ++m)
            change = std::max(change, std::abs(paths[k - 1].mixture[m] - q.mixture[m]));
          EXPECT_LE(change, (c.materials == 3 ? 4.0 / 3.0 : 1.0) * pal.band() + 1e-9);
        }
      }
    }
    EXPECT_GT(checked, 1000u);
    std::printf("%-70s %2d colours: worst %.5f (bound %.5f)\n", c.name.c_str(), c.colors, worst,
                pal.error_bound());
  }
}

TEST(FgmOutline, TheIslandIsCoveredOnce) {
  // Inside the rings (the outline inset by fgm.perimeters beads) the fill's beads, each as wide
  // as it extrudes (a line between level lines further apart than a bead extrudes more), cover
  // at least 99 % of the palette plate's fill allowing each bead 5 % of its width more (it
  // squashes), and hardly a pixel lies under three beads of the nominal width (under 0.05 %:
  // where a short connector crosses a line to a bridge or the next loop).
  // Generated fields: at least 95 % — where the iso-lines fold back or pass a saddle inside the
  // island the level lines spread to three beads near the fold or saddle and a bead extrudes at
  // most twice its flow (the face-by-face fill puts gap fill there, a start each).
  const Field plate =
      read_vcad(std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/fgm_palette_plate.vcad").field;
  struct Run {
    std::string name;
    Field field;
    std::vector<LayerOutline> outlines;
    int colors;
  };
  std::vector<Run> runs;
  runs.push_back(
      {"palette plate, middle layer", plate, slice_field(plate, {0.9}, FieldSliceOptions{}), 24});
  std::vector<Case> all = cases();
  // A design clamped flat over most of the plate (f = 0 for x < -4, 1 for x > 4): no level line
  // passes there; the three-material disc is flat where one fraction is clamped at 0.
  all.push_back(
      {"clamped slope", two_materials("0.5 + x/8", "rectprism(30, 20, 0.6);"), 8, 2, 0.5});
  for (const Case& c : all) {
    Field f = parse_vcad(c.vcad, "test.vcad").field;
    const BBox3 e = f.extent();
    auto outlines = slice_field(f, {0.5 * (e.min.z + e.max.z)}, FieldSliceOptions{});
    runs.push_back({c.name, std::move(f), std::move(outlines), c.colors});
  }
  for (const Run& r : runs) {
    SCOPED_TRACE(r.name);
    FgmOptions o;
    o.palette.colors = r.colors;
    o.layer_height = 0.3;
    o.bead_width = 0.4;
    o.material_resolution = r.name.rfind("palette plate", 0) == 0 ? 1.0 : 0.5;
    const Toolpath tp = plan_fgm_strategy2(r.field, r.outlines, o);
    ASSERT_EQ(tp.layers.size(), 1u);
    const Raster wide =
        raster(tp.layers[0], r.outlines[0].regions, o.perimeters * o.bead_width, 1.1);
    const Raster exact =
        raster(tp.layers[0], r.outlines[0].regions, o.perimeters * o.bead_width, 1.0);
    std::printf("%-70s covered %.4f (exact width %.4f), under three %.5f\n", r.name.c_str(),
                wide.coverage, exact.coverage, exact.three);
    EXPECT_GE(wide.coverage, &r == &runs.front() ? 0.99 : 0.95);
    // Designs flat over part of the island (a fraction clamped): the level lines bordering the
    // flat part (g spreads them, and the line put into an odd run there) overlap so that 2-3.5 %
    // lies under three beads — a known fault (docs/limitations.md), bounded here so
    // it cannot grow unseen; elsewhere hardly a pixel.
    const bool flat_part = r.name == "clamped slope" || r.name == "three materials";
    EXPECT_LE(exact.three, flat_part ? 0.04 : 5e-4);
  }
}

TEST(FgmOutline, AConvexIslandWithALinearGradientIsOneBead) {
  // A rectangle, a disc and an octagon graded linearly in random directions: the rings and the
  // fill's loops bridged into one closed bead per layer (two where a run of lines stays odd).
  std::mt19937 rng(39);
  std::uniform_real_distribution<double> angle(0, 2 * M_PI);
  const char* bodies[] = {"rectprism(30, 20, 0.9);", "cylinder(12, 0.9);",
                          "intersection() { rectprism(24, 24, 0.9); rotate(0, 0, 45) { "
                          "rectprism(26, 26, 0.9); } }"};
  std::size_t layers = 0, beads = 0;
  for (int k = 0; k < 9; ++k) {
    const double t = angle(rng);
    char f[128];
    std::snprintf(f, sizeof f, "0.5 + (%.4f*x + %.4f*y)/40", std::cos(t), std::sin(t));
    Case c;
    c.name = f + std::string(", body ") + std::to_string(k % 3);
    c.vcad = two_materials(f, bodies[k % 3]);
    c.colors = 8;
    SCOPED_TRACE(c.name);
    const Planned p = plan(c);
    for (const auto& l : p.toolpath.layers) {
      const std::size_t n = beads_of(l).size();
      EXPECT_LE(n, 2u);
      beads += n;
      ++layers;
    }
  }
  std::printf("%zu beads on %zu layers\n", beads, layers);
  EXPECT_LE(beads, layers + layers / 4);
}
