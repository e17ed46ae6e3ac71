#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "support/machines.hpp"
#include "support/scanline.hpp"
#include "trellis/core/error.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/settings/settings.hpp"
#include "trellis/slice/fgm.hpp"

using namespace trellis;

namespace {

Field design(const std::string& text) {
  return parse_vcad(text, "test.vcad").field;
}

// Slices, plans Strategy 2, writes G-code (M165 per mixture), reads it back and compares the
// commanded mixture of every extruded segment with the design's fraction at its ends and middle.
struct Fidelity {
  double max_error = 0, mean_error = 0;
  std::size_t segments = 0;
  double coverage = 1;  // rasterised bead coverage of the outline, worst layer
};

// layers > 0: only that many slicing planes, spread over the height. px: coverage pixel (mm).
Fidelity run(const Field& f, int colors, double h, bool concentric, double bead = 0.4,
             double material_resolution = 0.2, std::size_t layers = 0, double px = 0.05,
             FgmOrder order = FgmOrder::Paths) {
  FieldSliceOptions so;
  so.resolution = 0.1;
  const BBox3 e = f.extent();
  auto zs = layer_planes(e.min.z, e.max.z, h);
  if (layers > 0 && zs.size() > layers) {
    std::vector<double> some;
    for (std::size_t k = 0; k < layers; ++k)
      some.push_back(zs[(2 * k + 1) * zs.size() / (2 * layers)]);
    zs = some;
  }
  const auto outlines = slice_field(f, zs, so);
  FgmOptions o;
  o.palette.colors = colors;
  o.layer_height = h;
  o.bead_width = bead;
  o.concentric = concentric;
  o.order = order;
  // The wavy iso-lines of the test designs curve on a millimetre scale.
  o.material_resolution = material_resolution;
  o.palette.materials = static_cast<int>(f.materials().size());
  const Toolpath tp = plan_fgm_strategy2(f, outlines, o);
  MachineProfile prof = test::open_bed({}, 0, 2);
  prof.mixing_inputs = 3;
  Diagnostics diag;
  const Toolpath back = read_gcode(write_gcode(tp, prof), {}, diag);
  Evaluator ev(f);
  Fidelity r;
  double sum = 0;
  for (const auto& layer : back.layers)
    for (const auto& p : layer.paths) {
      // Back to design heights: printed layer i (z = (i+1)h) is the outline at zs[i].
      const auto i = static_cast<std::size_t>(std::llround(p.points[0].z / h)) - 1;
      EXPECT_LT(i, zs.size());
      EXPECT_EQ(p.mixture.size(), f.materials().size());
      if (p.mixture.size() != f.materials().size() || i >= zs.size()) continue;
      for (std::size_t k = 0; k + 1 < p.points.size(); ++k)
        for (double t : {0.0, 0.5, 1.0}) {
          const Vec3 q = p.points[k] + (p.points[k + 1] - p.points[k]) * t;
          const auto frac = ev.fractions({q.x, q.y, zs[i]});
          double err = 0;
          for (std::size_t m = 0; m < frac.size(); ++m)
            err = std::max(err, std::abs(std::clamp(frac[m], 0.0, 1.0) - p.mixture[m]));
          r.max_error = std::max(r.max_error, err);
          sum += err;
          ++r.segments;
        }
    }
  r.mean_error = r.segments ? sum / r.segments : 0;
  // Coverage: pixels of the outline within 3/4 of a bead of some path of that layer (beads
  // painted into a pixel grid). Strategy 2 extrudes the face's volume (material balance): a
  // bead nearer than a bead to its neighbour is kept while it overlaps by less than half a bead,
  // else dropped, leaving a gap under half a bead that the overlaps' material flows into; so a
  // pixel counts when a bead's edge is within a quarter bead. Gaps wider than half a bead (a bead
  // missing) show as uncovered. A path wider than the bead (in path order, lines further apart
  // than a bead extrude more: Path::width, flow) counts with its width.
  for (std::size_t li = 0; li < tp.layers.size(); ++li) {
    const Regions& out = outlines[li].regions;
    BBox3 b;
    for (const auto& poly : out)
      for (const Vec2 q : poly.outer) b.add({q.x, q.y, 0});
    const auto nx = static_cast<int>((b.max.x - b.min.x) / px) + 1;
    const auto ny = static_cast<int>((b.max.y - b.min.y) / px) + 1;
    std::vector<char> paint(static_cast<std::size_t>(nx) * ny, 0);
    for (const auto& p : tp.layers[li].paths) {
      const double reach = 0.75 * (p.width > 0 ? p.width : bead);
      for (std::size_t k = 0; k + 1 < p.points.size(); ++k) {
        const Vec3 a{p.points[k].x, p.points[k].y, 0}, c{p.points[k + 1].x, p.points[k + 1].y, 0};
        const int x0 = std::max(0, static_cast<int>((std::min(a.x, c.x) - bead - b.min.x) / px));
        const int x1 =
            std::min(nx - 1, static_cast<int>((std::max(a.x, c.x) + bead - b.min.x) / px));
        const int y0 = std::max(0, static_cast<int>((std::min(a.y, c.y) - bead - b.min.y) / px));
        const int y1 =
            std::min(ny - 1, static_cast<int>((std::max(a.y, c.y) + bead - b.min.y) / px));
        for (int iy = y0; iy <= y1; ++iy)
          for (int ix = x0; ix <= x1; ++ix) {
            const Vec3 q{b.min.x + (ix + 0.5) * px, b.min.y + (iy + 0.5) * px, 0};
            if (distance_to_segment(q, a, c) <= reach + 1e-9)
              paint[static_cast<std::size_t>(iy) * nx + ix] = 1;
          }
      }
    }
    // Pixels inside the outline by scanlines: each row's crossings with every ring, even-odd.
    std::size_t inside = 0, covered = 0;
    test::for_each_pixel_inside(out, {b.min.x, b.min.y}, px, nx, ny, [&](int ix, int iy) {
      ++inside;
      covered += paint[static_cast<std::size_t>(iy) * nx + ix];
    });
    if (inside) r.coverage = std::min(r.coverage, double(covered) / double(inside));
  }
  return r;
}

// Outlines at layer height h and the planar slicer's paths over them.
struct Sliced {
  std::vector<double> zs;
  std::vector<LayerOutline> outlines;
  Toolpath planar;
};
Sliced slice_planar(const Field& f, double h, int solid_layers) {
  Sliced s;
  const BBox3 e = f.extent();
  s.zs = layer_planes(e.min.z, e.max.z, h);
  s.outlines = slice_field(f, s.zs, FieldSliceOptions{});
  PlanarOptions po;
  po.layer_height = h;
  po.top_layers = po.bottom_layers = solid_layers;
  s.planar = plan_planar(s.outlines, po);
  return s;
}

// Palette options matching slice_planar's layers and beads.
FgmOptions fgm_options(int colors, double h) {
  FgmOptions o;
  o.palette.colors = colors;
  o.layer_height = h;
  o.bead_width = PlanarOptions{}.bead_width;
  return o;
}

}  // namespace

TEST(Fgm, PaletteBands) {
  Palette p;
  p.colors = 4;
  EXPECT_DOUBLE_EQ(p.mid(0), 0.125);
  EXPECT_EQ(p.color_of(0.0), 0);
  EXPECT_EQ(p.color_of(0.2499), 0);
  EXPECT_EQ(p.color_of(0.25), 1);
  EXPECT_EQ(p.color_of(1.0), 3);
  EXPECT_EQ(p.color_of(-1), 0);
}

TEST(Fgm, FacesTileTheOutlineWithoutOverlap) {
  const Field f = design(
      "fgrade([\"0.5 + x/20 + 0.2*sin(y)\", \"0.5 - x/20 - 0.2*sin(y)\"], [\"a\", \"b\"]) {\n"
      "  rectprism(20, 16, 2);\n}\n");
  Evaluator ev(f);
  FieldSliceOptions so;
  const Regions outline = contour_at(f, ev, 0.0, so);
  Palette pal;
  pal.colors = 6;
  const auto faces = color_faces(f, ev, 0.0, outline, pal, 0.1);
  EXPECT_EQ(faces.size(), 6u);
  double total = 0;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    total += area(faces[i].region);
    for (std::size_t j = i + 1; j < faces.size(); ++j)
      EXPECT_LT(area(intersection(faces[i].region, faces[j].region)), 1e-6);
  }
  EXPECT_NEAR(total, area(outline), 1e-3 * area(outline));
  EXPECT_THROW(color_faces(design("cube(2);\n"), ev, 0, outline, pal, 0.1), GeometryError);
}

TEST(Fgm, Strategy2GradientFidelityAndCoverage) {
  // An XY gradient with wavy iso-lines, a Z gradient (Appendix B listing 1's form) and a radial
  // one: the mixture commanded for every printed segment (read back from the G-code) is within
  // half a band of the design; the beads cover the outline densely (bands several beads wide).
  struct Case {
    std::string vcad;
    std::vector<int> colors;
  };
  const std::vector<Case> cases = {
      {"fgrade([\"0.5 + x/24 + 0.1*sin(y)\", \"0.5 - x/24 - 0.1*sin(y)\"], [\"a\", \"b\"]) {\n"
       "  rectprism(20, 12, 0.6);\n}\n",
       {4, 8}},
      {"fgrade([\"z/4 + 0.5\", \"0.5 - z/4\"], [\"a\", \"b\"]) {\n  cylinder(5, 4);\n}\n", {4, 16}},
      {"fgrade([\"sqrt(x^2+y^2)/8\", \"1 - sqrt(x^2+y^2)/8\"], [\"a\", \"b\"]) {\n"
       "  cylinder(8, 0.6);\n}\n",
       {4}}};
  for (const auto& c : cases)
    for (int colors : c.colors)
      for (bool concentric : {false, true}) {
        const Fidelity r = run(design(c.vcad), colors, 0.3, concentric);
        const double half_band = 0.5 / colors;
        EXPECT_GT(r.segments, 0u);
        // G-code rounds the mixture to 4 decimals and coordinates to 1 µm: 1e-4 of slack.
        EXPECT_LE(r.max_error, half_band + 1e-4) << c.vcad << colors << concentric;
        EXPECT_LE(r.mean_error, half_band) << c.vcad;
        // Only the tips of acute corners (an iso-line meeting the outline) stay uncovered: a
        // round bead cannot reach them without crossing into the next face.
        EXPECT_GE(r.coverage, 0.98) << c.vcad << colors << concentric;
        std::printf(
            "case %zu colours %d %s: max error %.4f (half band %.4f), mean %.4f, coverage %.4f\n",
            static_cast<std::size_t>(&c - cases.data()), colors,
            concentric ? "concentric" : "rectilinear", r.max_error, half_band, r.mean_error,
            r.coverage);
      }
}

TEST(Fgm, LookAheadIssuesChangesOneDeadVolumeEarly) {
  // A plate graded along x, 8 colours, printed with a dead volume of L = 40 mm of path: with
  // the look-ahead the material that comes out of the nozzle (the command in force L mm of path
  // earlier) matches the design within half a band; without it, it does not.
  const Field f = design(
      "fgrade([\"0.5 + x/30\", \"0.5 - x/30\"], [\"a\", \"b\"]) {\n  rectprism(30, 10, 0.3);\n}\n");
  FieldSliceOptions so;
  const BBox3 e = f.extent();
  const auto zs = layer_planes(e.min.z, e.max.z, 0.3);
  const auto outlines = slice_field(f, zs, so);
  FgmOptions o;
  o.palette.colors = 8;
  o.layer_height = 0.3;
  const Toolpath tp = plan_fgm_strategy2(f, outlines, o);
  Evaluator ev(f);
  const double L = 40;
  auto worst = [&](double lookahead) {
    MachineProfile prof = test::open_bed({}, 0, 2);
    prof.lookahead = lookahead;
    Diagnostics diag;
    GcodeReadOptions commanded;  // the commands as the file issues them (this test undoes them)
    commanded.commanded_mixtures = true;
    const Toolpath back = read_gcode(write_gcode(tp, prof), commanded, diag);
    // Commands in print order with the printed length at which each was issued.
    std::vector<std::pair<double, double>> issued;  // (position, fraction of a)
    std::vector<std::pair<double, Vec3>> mids;      // (position, segment middle)
    double s = 0;
    for (const auto& l : back.layers)
      for (const auto& p : l.paths) {
        if (issued.empty() || issued.back().second != p.mixture[0])
          issued.push_back({s, p.mixture[0]});
        for (std::size_t k = 0; k + 1 < p.points.size(); ++k) {
          const double len = distance(p.points[k], p.points[k + 1]);
          mids.push_back({s + len / 2, (p.points[k] + p.points[k + 1]) * 0.5});
          s += len;
        }
      }
    double w = 0;
    for (const auto& [pos, q] : mids) {
      if (pos < L) continue;  // the first dead volume holds whatever was loaded
      double cmd = issued.front().second;
      for (const auto& [at, m] : issued)
        if (at <= pos - L) cmd = m;
      const double frac = std::clamp(ev.fractions({q.x, q.y, zs[0]})[0], 0.0, 1.0);
      w = std::max(w, std::abs(frac - cmd));
    }
    return w;
  };
  const double half_band = 0.5 / 8;
  EXPECT_LE(worst(L), half_band + 2e-3);
  EXPECT_GT(worst(0), 1.5 * half_band);
}

TEST(Fgm, ToolsAndTemperatureModes) {
  Toolpath tp;
  tp.layers.resize(1);
  for (int i = 0; i < 5; ++i) {
    Path p;
    p.points = {{0.0, 2.0 * i, 0.2}, {10.0, 2.0 * i, 0.2}};
    const double a = 1 - i * 0.25;
    p.mixture = {a, 1 - a};
    tp.layers[0].paths.push_back(p);
  }
  MachineProfile tools = test::open_bed({}, 5);
  tools.gradient_mode = GradientMode::Tools;
  tools.gradient_tools = 5;
  const std::string g = write_gcode(tp, tools);
  for (const char* t : {"\nT0\n", "\nT1\n", "\nT2\n", "\nT3\n", "\nT4\n"})
    EXPECT_NE(g.find(t), std::string::npos) << t;
  MachineProfile foam = test::open_bed();
  foam.gradient_mode = GradientMode::Temperature;
  foam.flow_model = FlowModel::Pla;
  GcodeStats st;
  const std::string h = write_gcode(tp, foam, &st);
  EXPECT_EQ(st.gradient_changes, 5u);
  EXPECT_NE(h.find("M104 S190\n"), std::string::npos);
  EXPECT_NE(h.find("M104 S225\n"), std::string::npos);
  EXPECT_NE(h.find("M104 S207.5\n"), std::string::npos);
  // Eq. 3 at 207.5 °C.
  const double t = 207.5;
  const double flow = 100 * (8.35479e-6 * t * t * t - 5.37075e-3 * t * t + 1.13374 * t - 77.814);
  char expect[64];
  std::snprintf(expect, sizeof expect, "M221 T0 S%.1f", flow);
  std::string e = expect;
  while (e.back() == '0') e.pop_back();
  if (e.back() == '.') e.pop_back();
  EXPECT_NE(h.find(e), std::string::npos) << e << "\n" << h.substr(0, 2000);
  // An unknown mode is refused where profiles are read (the profile holds only known ones).
  EXPECT_THROW(machine_profile_from_toml("[gradient]\nmode = \"heat\"\n", "foam.toml"),
               SettingError);
}

TEST(Fgm, Strategy1KeepsEveryPlanarPathAndPurgesBetweenColours) {
  // The planar slicer's walls, skins and infill cut by colour faces: per layer the pieces add up
  // to the uncut paths (nothing lost, nothing added but purge blocks), every piece's commanded
  // mixture (read back from G-code) is within half a band of the design, and a purge block of
  // at least L = V / A precedes every colour change above the threshold.
  const Field f = design(
      "fgrade([\"0.5 + x/24 + 0.1*sin(y)\", \"0.5 - x/24 - 0.1*sin(y)\"], [\"a\", \"b\"]) {\n"
      "  rectprism(20, 12, 1.2);\n}\n");
  const double h = 0.3;
  const Sliced sl = slice_planar(f, h, 1);
  const auto& zs = sl.zs;
  const auto& outlines = sl.outlines;
  const Toolpath& planar = sl.planar;
  FgmOptions o = fgm_options(6, h);
  o.material_resolution = 0.2;
  o.order = FgmOrder::Faces;  // the paper's colour-by-colour order, a purge between colours
  PurgeOptions purge;
  purge.melt_volume = 20;
  purge.threshold = 0;  // every change
  purge.x = -20;
  FgmStats st;
  const Toolpath tp = plan_fgm_strategy1(f, outlines, planar, o, purge, &st);
  ASSERT_EQ(tp.layers.size(), planar.layers.size());
  const double L = purge_length(20, h, o.bead_width);
  for (std::size_t li = 0; li < tp.layers.size(); ++li) {
    double uncut = 0, pieces = 0;
    for (const auto& p : planar.layers[li].paths) uncut += p.length();
    const auto& paths = tp.layers[li].paths;
    for (std::size_t k = 0; k < paths.size(); ++k) {
      if (paths[k].role == PathRole::Purge) {  // wall, sparse lines and purges beside the part
        if (k + 1 < paths.size() && paths[k + 1].role != PathRole::Purge &&
            paths[k + 1].mixture == paths[k].mixture && k > 0 &&
            paths[k - 1].mixture != paths[k].mixture)
          EXPECT_GE(paths[k].length(), L - 1e-6);
        for (const auto& q : paths[k].points) EXPECT_GT(q.x, 10 + purge.clearance);
        continue;
      }
      pieces += paths[k].length();
    }
    EXPECT_NEAR(pieces, uncut, 1e-6 * uncut) << "layer " << li;
  }
  EXPECT_GT(st.purges, 0u);
  EXPECT_EQ(st.purges, st.colour_changes);
  // Palette order makes every change one band (1/6): a threshold above it needs no purge.
  PurgeOptions lax = purge;
  lax.threshold = 0.2;
  FgmStats st2;
  plan_fgm_strategy1(f, outlines, planar, o, lax, &st2);
  EXPECT_EQ(st2.purges, 0u);
  EXPECT_EQ(st2.colour_changes, st.colour_changes);
  EXPECT_NEAR(st.purge_volume, st.purge_length * (h * (o.bead_width - h) + M_PI * h * h / 4), 1e-6);
  // Fidelity, read back (the tower excluded: it lies off the part).
  Diagnostics diag;
  const Toolpath back = read_gcode(write_gcode(tp, test::open_bed({}, 0, 2)), {}, diag);
  Evaluator ev(f);
  double worst = 0;
  std::size_t n = 0;
  for (const auto& l : back.layers)
    for (const auto& p : l.paths) {
      const auto i = static_cast<std::size_t>(std::llround(p.points[0].z / h)) - 1;
      for (const auto& q : p.points) {
        if (q.x > 10.5 || i >= zs.size()) continue;
        const double frac = std::clamp(ev.fractions({q.x, q.y, zs[i]})[0], 0.0, 1.0);
        worst = std::max(worst, std::abs(frac - p.mixture[0]));
        ++n;
      }
    }
  EXPECT_GT(n, 100u);
  // G-code rounding: the mixture to 4 decimals (5e-5), points to 0.5 µm (|∇f| <= 0.11/mm here).
  EXPECT_LE(worst, 0.5 / 6 + 1.2e-4);
}

TEST(Fgm, ZipperAlternatesInsideTheOverlapBandsOnly) {
  const Field f = design(
      "fgrade([\"0.5 + x/24\", \"0.5 - x/24\"], [\"a\", \"b\"]) {\n  rectprism(20, 12, 0.9);\n}\n");
  const double h = 0.3;
  const Sliced sl = slice_planar(f, h, 4);
  const auto& zs = sl.zs;
  const auto& outlines = sl.outlines;
  const Toolpath& planar = sl.planar;
  FgmOptions o = fgm_options(4, h);
  o.zipper = 0.1;
  const Toolpath tp = plan_fgm_strategy1(f, outlines, planar, o, {}, nullptr);
  Evaluator ev(f);
  std::size_t inside = 0, outside = 0;
  for (std::size_t li = 0; li < tp.layers.size(); ++li) {
    std::map<int, std::array<int, 2>> per_band;  // boundary k -> pieces of colour k-1, k
    for (const auto& p : tp.layers[li].paths) {
      const Vec3 mid = p.points[p.points.size() / 2 - (p.points.size() % 2 == 0 ? 1 : 0)] * 0.5 +
                       p.points[p.points.size() / 2] * 0.5;
      const double frac = ev.fractions({mid.x, mid.y, zs[li]})[0];
      const int color = o.palette.color_of(p.mixture[0]);
      const int k = static_cast<int>(std::lround(frac * 4));  // nearest boundary
      if (k >= 1 && k <= 3 && std::abs(frac - k * 0.25) < 0.05 - 1e-3) {
        ASSERT_TRUE(color == k - 1 || color == k) << frac << " colour " << color;
        ++per_band[k][color - (k - 1)];
        ++inside;
      } else if (std::abs(frac - k * 0.25) > 0.05 + 1e-3) {
        EXPECT_EQ(color, o.palette.color_of(frac)) << frac;
        ++outside;
      }
    }
    for (const auto& [k, c] : per_band) {
      EXPECT_GT(c[0], 0) << "layer " << li << " boundary " << k;
      EXPECT_GT(c[1], 0) << "layer " << li << " boundary " << k;
      EXPECT_LE(std::abs(c[0] - c[1]), std::max(2, (c[0] + c[1]) / 4)) << "layer " << li;
    }
  }
  EXPECT_GT(inside, 20u);
  EXPECT_GT(outside, 20u);
  o.zipper = 0.3;  // wider than a band
  EXPECT_THROW(plan_fgm_strategy1(f, outlines, planar, o, {}, nullptr), SettingError);
}

TEST(Fgm, ThreeMaterialPaletteWalksTheTriangle) {
  // d² triangles numbered along a snake: every colour once, each colour's mixture sums to 1 and
  // maps back to itself, successive colours change any material's share by at most α, and every
  // mixture is printed by a colour within 2α/3 (a triangle's corner against its centroid).
  for (int d : {1, 2, 3, 4, 6}) {
    Palette p;
    p.materials = 3;
    p.colors = d * d;
    EXPECT_NO_THROW(p.check());
    EXPECT_DOUBLE_EQ(p.band(), 1.0 / d);
    std::set<std::tuple<int, int, int, bool>> seen;
    for (int c = 0; c < p.colors; ++c) {
      const auto cell = p.cell(c);
      EXPECT_EQ(cell.i + cell.j + cell.k, cell.up ? d - 1 : d - 2) << d << " " << c;
      seen.insert({cell.i, cell.j, cell.k, cell.up});
      const auto m = p.mixture(c);
      ASSERT_EQ(m.size(), 3u);
      EXPECT_NEAR(m[0] + m[1] + m[2], 1.0, 1e-12);
      EXPECT_EQ(p.color_of(m), c);
      if (c > 0) {
        const auto prev = p.mixture(c - 1);
        for (int k = 0; k < 3; ++k)
          EXPECT_LE(std::abs(m[k] - prev[k]), p.band() + 1e-12) << d << " " << c;
      }
    }
    EXPECT_EQ(seen.size(), static_cast<std::size_t>(p.colors));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    double worst = 0;
    for (int t = 0; t < 20000; ++t) {
      double a = u(rng), b = u(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      const std::vector<double> f{a, b, 1 - a - b};
      const auto m = p.mixture(p.color_of(f));
      for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(f[k] - m[k]));
    }
    EXPECT_LE(worst, p.error_bound() + 1e-12) << d;
    EXPECT_GT(worst, 0.9 * p.error_bound()) << d;
  }
  Palette bad;
  bad.materials = 3;
  bad.colors = 8;
  EXPECT_THROW(bad.check(), SettingError);
  bad.materials = 4;
  bad.colors = 9;
  EXPECT_THROW(bad.check(), SettingError);
}

// A disc graded in three materials (fractions sum to 1 everywhere on it).
const char* kThreeMaterials =
    "fgrade([\"(1 + x/16 + 0.1*sin(y))/3\", \"(1 + y/16)/3\", \"(1 - x/16 - y/16 - "
    "0.1*sin(y))/3\"],"
    " [\"a\", \"b\", \"c\"]) {\n  cylinder(10, 0.6);\n}\n";

TEST(Fgm, ThreeMaterialsStrategy2FidelityAndCoverage) {
  const Field f = design(kThreeMaterials);
  for (int colors : {9, 16}) {
    const Fidelity r = run(f, colors, 0.3, false);
    Palette p;
    p.materials = 3;
    p.colors = colors;
    EXPECT_GT(r.segments, 0u);
    EXPECT_LE(r.max_error, p.error_bound() + 1e-4) << colors;
    EXPECT_GE(r.coverage, 0.98) << colors;
    std::printf(
        "three materials, %d colours: max error %.4f (bound %.4f), mean %.4f, coverage %.4f\n",
        colors, r.max_error, p.error_bound(), r.mean_error, r.coverage);
  }
}

TEST(Fgm, ThreeMaterialsStrategy1AndWriters) {
  // Strategy 1 over three materials: the pieces add up to the planar paths; each piece's M165 A
  // B C read back is its colour's centroid, within 2α/3 of the design; the tool and temperature
  // writers refuse three-material mixtures, and a two-input mixing hotend does too.
  const Field f = design(kThreeMaterials);
  const double h = 0.3;
  const Sliced sl = slice_planar(f, h, 1);
  FgmOptions o = fgm_options(9, h);
  o.palette.materials = 3;
  o.material_resolution = 0.5;
  FgmStats st;
  const Toolpath tp = plan_fgm_strategy1(f, sl.outlines, sl.planar, o, {}, &st);
  ASSERT_EQ(tp.layers.size(), sl.planar.layers.size());
  for (std::size_t li = 0; li < tp.layers.size(); ++li) {
    double uncut = 0, pieces = 0;
    for (const auto& p : sl.planar.layers[li].paths) uncut += p.length();
    for (const auto& p : tp.layers[li].paths) pieces += p.length();
    EXPECT_NEAR(pieces, uncut, 1e-6 * uncut) << "layer " << li;
  }
  EXPECT_GT(st.colour_changes, 3u);
  MachineProfile prof = test::open_bed({}, 0, 2);
  prof.mixing_inputs = 3;
  Diagnostics diag;
  const Toolpath back = read_gcode(write_gcode(tp, prof), {}, diag);
  Evaluator ev(f);
  double worst = 0;
  std::size_t n = 0;
  for (const auto& l : back.layers)
    for (const auto& p : l.paths) {
      ASSERT_EQ(p.mixture.size(), 3u);
      const auto i = static_cast<std::size_t>(std::llround(p.points[0].z / h)) - 1;
      ASSERT_LT(i, sl.zs.size());
      for (const auto& q : p.points) {
        const auto frac = ev.fractions({q.x, q.y, sl.zs[i]});
        for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(frac[k] - p.mixture[k]));
        ++n;
      }
    }
  EXPECT_GT(n, 100u);
  EXPECT_LE(worst, o.palette.error_bound() + 1e-4);
  MachineProfile two = test::open_bed({}, 0, 2);
  EXPECT_THROW(write_gcode(tp, two), MachineError);
  prof.gradient_mode = GradientMode::Tools;
  EXPECT_THROW(write_gcode(tp, prof), MachineError);
  prof.gradient_mode = GradientMode::Temperature;
  EXPECT_THROW(write_gcode(tp, prof), MachineError);
  o.zipper = 0.05;
  EXPECT_THROW(plan_fgm_strategy1(f, sl.outlines, sl.planar, o, {}, nullptr), SettingError);
}

TEST(Fgm, AppendixBDesignsAndRandomFieldsStayWithinTheBand) {
  // The five designs of the FGM paper's Appendix B (three layers of each, the default 1 mm
  // material grid) and random smooth two-material fields: Strategy 2 read back from G-code, the
  // commanded mixture within half a band of the design everywhere, the outline covered >= 98%.
  struct Case {
    Field field;
    std::string name;
    int colors;
    double material_resolution;
  };
  std::vector<Case> cases;
  for (const char* name :
       {"fgm_column1_cylinder.vcad", "fgm_column2_plate.vcad", "fgm_column3_ring_angular.vcad",
        "fgm_column5_ring_radial.vcad", "fgm_column6_vase.vcad"})
    cases.push_back({read_vcad(std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/" + name).field,
                     name, 10, 1.0});
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 8; ++k) {
    // f = 0.5 + a·x/10 + b·sin(c·x + d·y) + e·y/10 on a 16 x 12 mm plate (clamped to [0, 1]),
    // with at most as many colours as keep every band two beads wide where f is steepest (the
    // paper's practical limit of Strategy 2: a face narrower than a bead cannot be filled
    // without crossing into its neighbours).
    const double a = 0.4 * u(rng), b = 0.2 * u(rng), c = 1.2 * u(rng), d = 1.2 * u(rng),
                 e = 0.4 * u(rng);
    char expr[256];
    std::snprintf(expr, sizeof expr, "0.5 + %.3f*x/10 + %.3f*sin(%.3f*x + %.3f*y) + %.3f*y/10", a,
                  b, c, d, e);
    const double steepest = std::hypot(a, e) / 10 + std::abs(b) * std::hypot(c, d);
    const int most = std::clamp(static_cast<int>(1 / (steepest * 0.8)), 2, 12);
    const std::string vcad = std::string("fgrade([\"") + expr + "\", \"1 - (" + expr +
                             ")\"], [\"a\", \"b\"]) {\n  rectprism(16, 12, 0.6);\n}\n";
    cases.push_back(
        {design(vcad), expr, 2 + static_cast<int>(rng() % static_cast<unsigned>(most - 1)), 0.25});
  }
  for (const auto& c : cases)
    for (const FgmOrder order : {FgmOrder::Faces, FgmOrder::Paths}) {
      const double extent = std::max(c.field.extent().max.x - c.field.extent().min.x,
                                     c.field.extent().max.y - c.field.extent().min.y);
      const Fidelity r = run(c.field, c.colors, 0.3, false, 0.4, c.material_resolution, 3,
                             extent > 40 ? 0.1 : 0.05, order);
      const double half_band = 0.5 / c.colors;
      EXPECT_GT(r.segments, 0u) << c.name;
      // Face by face every bead stays half a bead inside its face; in path order a bead is cut
      // where it crosses a face's edge (those edges follow the iso-lines to 1e-4 of a band), and
      // the G-code rounds the cut to 1 µm.
      EXPECT_LE(r.max_error,
                half_band + (order == FgmOrder::Faces ? 1.2e-4 : 1e-3 / c.colors + 2e-4))
          << c.name << " " << to_string(order);
      // In path order the lines are level lines a bead apart: where the iso-lines fold at the
      // scale of a few beads (these random fields: ridges and saddles 5 mm apart on a 16 mm
      // plate) the corners of their folds and the saddles stay partly open (the face-by-face
      // fill puts gap fill there, a bead each); on the palette plate 99 % (test_fgm_outline).
      EXPECT_GE(r.coverage, order == FgmOrder::Faces ? 0.98 : 0.97)
          << c.name << " " << to_string(order);
      std::printf("%s, %d colours, %s: max error %.5f (half band %.5f), coverage %.4f\n",
                  c.name.c_str(), c.colors, to_string(order), r.max_error, half_band, r.coverage);
    }
}

TEST(Fgm, Strategy2LinesRunAlongTheIsoLines) {
  // The paper prints Strategy 2 perpendicular to the gradient: on a plate with the palette
  // plate's curved gradient, at least 90% of the printed length (segments over 1 mm) runs
  // within 20° of the local iso-line; with --fixed-angle it does not.
  const Field f = design(
      "fgrade([\"(1 + sin(0.05*x + 0.08*y)*cos(0.08*x - 0.05*y))/2\","
      " \"1 - (1 + sin(0.05*x + 0.08*y)*cos(0.08*x - 0.05*y))/2\"], [\"a\", \"b\"]) {\n"
      "  rectprism(40, 40, 0.6);\n}\n");
  FieldSliceOptions so;
  const BBox3 e = f.extent();
  const auto zs = layer_planes(e.min.z, e.max.z, 0.3);
  const auto outlines = slice_field(f, zs, so);
  Evaluator ev(f);
  auto along = [&](bool fixed) {
    FgmOptions o;
    o.palette.colors = 6;
    o.layer_height = 0.3;
    o.fixed_angle = fixed;
    const Toolpath tp = plan_fgm_strategy2(f, outlines, o);
    double good = 0, total = 0;
    for (const auto& l : tp.layers)
      for (const auto& p : l.paths)
        for (std::size_t k = 0; k + 1 < p.points.size(); ++k) {
          const Vec3 a = p.points[k], b = p.points[k + 1];
          const double len = distance(a, b);
          if (len < 1) continue;
          const Vec3 m = (a + b) * 0.5;
          const double h = 0.05;
          const double gx =
              (ev.fractions({m.x + h, m.y, zs[0]})[0] - ev.fractions({m.x - h, m.y, zs[0]})[0]) /
              (2 * h);
          const double gy =
              (ev.fractions({m.x, m.y + h, zs[0]})[0] - ev.fractions({m.x, m.y - h, zs[0]})[0]) /
              (2 * h);
          const double g = std::hypot(gx, gy);
          if (g < 1e-6) continue;
          // |cos| of the angle between the segment and the gradient: 0 along the iso-line.
          const double c = std::abs((b.x - a.x) * gx + (b.y - a.y) * gy) / (len * g);
          total += len;
          if (c <= std::sin(20 * M_PI / 180)) good += len;
        }
    return total > 0 ? good / total : 0.0;
  };
  const double oriented = along(false), fixed = along(true);
  std::printf("length within 20 degrees of the iso-line: %.3f oriented, %.3f fixed angle\n",
              oriented, fixed);
  EXPECT_GE(oriented, 0.9);
  EXPECT_LT(fixed, 0.6);
}

TEST(Fgm, Strategy2BeadsStayInsideTheirFace) {
  // The paper's face-by-face fill (fgm.order = faces): no bead crosses into another face: every
  // path point of a colour lies in that colour's face (recomputed) at least half a bead from its
  // edge (1 µm slack), rings, lines and gap fill alike, for rectilinear and concentric fills,
  // two and three materials.
  const std::vector<std::string> designs = {
      "fgrade([\"0.5 + x/24 + 0.1*sin(y)\", \"0.5 - x/24 - 0.1*sin(y)\"], [\"a\", \"b\"]) {\n"
      "  rectprism(20, 12, 0.3);\n}\n",
      kThreeMaterials};
  for (const auto& src : designs)
    for (bool concentric : {false, true}) {
      const Field f = design(src);
      FieldSliceOptions so;
      const auto outlines = slice_field(f, {0.0}, so);
      FgmOptions o;
      o.palette.materials = static_cast<int>(f.materials().size());
      o.palette.colors = o.palette.materials == 3 ? 9 : 6;
      o.layer_height = 0.3;
      o.concentric = concentric;
      o.material_resolution = 0.2;
      o.order = FgmOrder::Faces;
      const Toolpath tp = plan_fgm_strategy2(f, outlines, o);
      Evaluator ev(f);
      // The faces as Strategy 2 cuts them (its edges follow the iso-lines to 1% of a band).
      const auto faces = color_faces(f, ev, 0.0, outlines[0].regions, o.palette, 0.2, 1e-2);
      ASSERT_EQ(tp.layers.size(), 1u);
      std::size_t checked = 0;
      for (const auto& p : tp.layers[0].paths) {
        const int color = o.palette.color_of(p.mixture);
        const auto it = std::find_if(faces.begin(), faces.end(),
                                     [&](const ColorFace& c) { return c.color == color; });
        ASSERT_NE(it, faces.end());
        const auto rings = rings_of(it->region);
        for (std::size_t k = 0; k < p.points.size(); k += 3) {
          const Vec2 q = p.points[k].xy();
          bool inside = false;
          for (const auto& poly : it->region) inside |= contains(poly, q, 0.0);
          double edge = 1e300;
          for (const auto& ring : rings)
            for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
              edge = std::min(edge, distance_to_segment({q.x, q.y, 0}, {ring[j].x, ring[j].y, 0},
                                                        {ring[i].x, ring[i].y, 0}));
          EXPECT_TRUE(inside) << q.x << " " << q.y;
          EXPECT_GE(edge, o.bead_width / 2 - 1e-3) << q.x << " " << q.y << " colour " << color;
          ++checked;
        }
      }
      EXPECT_GT(checked, 100u);
    }
}

namespace {

// Material balance of Strategy 2 by an independent replay of the written G-code: the filament
// each path extrudes (E, read back) as volume against the design's volume (outline area × layer
// height), and a raster of the beads as E deposits them (a rectangle of the bead width along
// each extruding segment, no round caps): the share of the outline's pixels under two or more
// beads. Pixels of 0.04 mm; a pixel counts once per segment.
struct Balance {
  double ratio = 0;     // extruded volume / design volume
  double double_ = 0;   // share of the outline covered by two or more beads
  double shortest = 0;  // shortest printed path (mm)
  double under5 = 0;    // share of paths under 5 mm
};

Balance balance(const Field& f, const std::vector<LayerOutline>& outlines, const FgmOptions& o) {
  const Toolpath tp = plan_fgm_strategy2(f, outlines, o);
  MachineProfile prof = test::open_bed({}, 0, 2);
  prof.mixing_inputs = 2;
  prof.nozzle_diameter = o.bead_width;
  prof.lookahead = 0;
  Diagnostics diag;
  const Toolpath back = read_gcode(write_gcode(tp, prof), {}, diag);
  const double fil_area =
      3.14159265358979323846 * prof.filament_diameter * prof.filament_diameter / 4;
  Balance b;
  double volume = 0, design_volume = 0;
  std::size_t paths = 0, short_paths = 0;
  b.shortest = 1e300;
  for (const auto& l : back.layers)
    for (const auto& p : l.paths) {
      volume += p.filament * fil_area;
      ++paths;
      short_paths += p.length() < 5;
      b.shortest = std::min(b.shortest, p.length());
    }
  b.under5 = paths ? double(short_paths) / double(paths) : 0;
  const double px = 0.04, w_bead = o.bead_width;
  std::size_t inside = 0, twice = 0;
  EXPECT_EQ(back.layers.size(), outlines.size());
  for (std::size_t li = 0; li < outlines.size() && li < back.layers.size(); ++li) {
    const Regions& out = outlines[li].regions;
    design_volume += area(out) * o.layer_height;
    BBox3 bb;
    for (const auto& poly : out)
      for (const Vec2 q : poly.outer) bb.add({q.x, q.y, 0});
    const int nx = static_cast<int>((bb.max.x - bb.min.x) / px) + 1;
    const int ny = static_cast<int>((bb.max.y - bb.min.y) / px) + 1;
    std::vector<unsigned char> count(static_cast<std::size_t>(nx) * ny, 0);
    for (const auto& p : back.layers[li].paths)
      for (std::size_t k = 0; k + 1 < p.points.size(); ++k) {
        // A path wider than the bead (path order: lines further apart extrude more) as wide.
        const double w = p.width > 0 ? p.width : w_bead;
        const Vec2 a = p.points[k].xy(), c = p.points[k + 1].xy();
        const Vec2 d = c - a;
        const double len = std::hypot(d.x, d.y);
        if (len <= 0) continue;
        const Vec2 u{d.x / len, d.y / len};
        const int x0 = std::max(0, static_cast<int>((std::min(a.x, c.x) - w - bb.min.x) / px));
        const int x1 = std::min(nx - 1, static_cast<int>((std::max(a.x, c.x) + w - bb.min.x) / px));
        const int y0 = std::max(0, static_cast<int>((std::min(a.y, c.y) - w - bb.min.y) / px));
        const int y1 = std::min(ny - 1, static_cast<int>((std::max(a.y, c.y) + w - bb.min.y) / px));
        for (int iy = y0; iy <= y1; ++iy)
          for (int ix = x0; ix <= x1; ++ix) {
            const Vec2 q{bb.min.x + (ix + 0.5) * px - a.x, bb.min.y + (iy + 0.5) * px - a.y};
            const double t = q.x * u.x + q.y * u.y, s = q.x * u.y - q.y * u.x;
            if (t >= 0 && t < len && std::abs(s) < w / 2) {
              auto& cnt = count[static_cast<std::size_t>(iy) * nx + ix];
              if (cnt < 255) ++cnt;
            }
          }
      }
    std::vector<double> xs;
    for (int iy = 0; iy < ny; ++iy) {
      const double y = bb.min.y + (iy + 0.5) * px;
      xs.clear();
      for (const auto& ring : rings_of(out))
        for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
          if ((ring[i].y > y) != (ring[j].y > y))
            xs.push_back(ring[j].x +
                         (ring[i].x - ring[j].x) * (y - ring[j].y) / (ring[i].y - ring[j].y));
      std::sort(xs.begin(), xs.end());
      for (std::size_t k = 0; k + 1 < xs.size(); k += 2)
        for (int ix = std::max(0, static_cast<int>(std::ceil((xs[k] - bb.min.x) / px - 0.5)));
             ix < nx && bb.min.x + (ix + 0.5) * px < xs[k + 1]; ++ix) {
          ++inside;
          twice += count[static_cast<std::size_t>(iy) * nx + ix] >= 2;
        }
    }
  }
  b.ratio = design_volume > 0 ? volume / design_volume : 0;
  b.double_ = inside ? double(twice) / double(inside) : 0;
  return b;
}

}  // namespace

TEST(Fgm, Strategy2DepositsThePartsVolumeAtEveryPaletteSize) {
  // The FGM paper: Strategy 2 "incurs no additional material consumption or printing time
  // penalties regardless of palette size". The palette plate (examples/designs, 135 x 175 mm,
  // the gradient of Eq. 1), its middle layer, 4 to 48 colours, rectilinear and concentric fill,
  // read back from G-code: the filament extruded is the plate's volume to ±3 %, and at most 5 %
  // of the plate is under two beads.
  const Field f =
      read_vcad(std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/fgm_palette_plate.vcad").field;
  FieldSliceOptions so;
  const auto outlines = slice_field(f, {0.9}, so);
  // Face by face (fgm.order = faces: rectilinear and concentric) and in path order (each island
  // filled whole, its beads cut at the colour edges; concentric stays face by face).
  struct Fill {
    bool concentric;
    FgmOrder order;
  };
  for (int colors : {4, 12, 24, 48})
    for (const Fill fill : {Fill{false, FgmOrder::Faces}, Fill{true, FgmOrder::Faces},
                            Fill{false, FgmOrder::Paths}}) {
      const bool concentric = fill.concentric;
      FgmOptions o;
      o.palette.colors = colors;
      o.layer_height = 0.2;
      o.bead_width = 0.4;
      o.concentric = concentric;
      o.order = fill.order;
      const Balance b = balance(f, outlines, o);
      const std::string what = std::to_string(colors) +
                               (concentric ? " concentric " : " rectilinear ") +
                               to_string(fill.order);
      std::printf(
          "colours %2d %-11s %-5s volume x%.4f, double coverage %.2f %%, shortest path "
          "%.3f mm, %.1f %% of paths under 5 mm\n",
          colors, concentric ? "concentric" : "rectilinear", to_string(fill.order), b.ratio,
          100 * b.double_, b.shortest, 100 * b.under5);
      EXPECT_NEAR(b.ratio, 1.0, 0.03) << what;
      EXPECT_LE(b.double_, 0.05) << what;
      // Face by face no piece shorter than a bead is printed (trimmed remnants are dropped); in
      // path order a piece is a run of one mixture inside a bead, as short as a crossing makes it.
      if (fill.order == FgmOrder::Faces) EXPECT_GE(b.shortest, o.bead_width - 2e-3) << what;
    }
}

// The layers are planned in parallel: both strategies, in face and path order (zippered, with
// short pieces merged), give the same paths and counts on one thread and on two.
TEST(Fgm, SamePlanOnOneAndTwoThreads) {
  const Field f = design(
      "fgrade([\"0.5 + x/24 + 0.1*sin(y)\", \"0.5 - x/24 - 0.1*sin(y)\"], [\"a\", \"b\"]) {\n"
      "  rectprism(20, 12, 0.9);\n}\n");
  const double h = 0.3;
  const Sliced sl = slice_planar(f, h, 4);
  auto plan = [&](int strategy, FgmOrder order, std::size_t threads, FgmStats& st) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    FgmOptions o = fgm_options(6, h);
    o.order = order;
    o.min_segment = 1;
    if (strategy == 1 && order == FgmOrder::Faces) o.zipper = 0.05;
    return strategy == 1 ? plan_fgm_strategy1(f, sl.outlines, sl.planar, o, {}, &st)
                         : plan_fgm_strategy2(f, sl.outlines, o, &st);
  };
  for (const int strategy : {1, 2})
    for (const FgmOrder order : {FgmOrder::Faces, FgmOrder::Paths}) {
      FgmStats s1, s2;
      const Toolpath a = plan(strategy, order, 1, s1), b = plan(strategy, order, 2, s2);
      const std::string what = "strategy " + std::to_string(strategy) + " " + to_string(order);
      ASSERT_EQ(a.layers.size(), b.layers.size()) << what;
      std::size_t paths = 0;
      for (std::size_t li = 0; li < a.layers.size(); ++li) {
        ASSERT_EQ(a.layers[li].paths.size(), b.layers[li].paths.size()) << what << " layer " << li;
        for (std::size_t k = 0; k < a.layers[li].paths.size(); ++k, ++paths) {
          const Path &p = a.layers[li].paths[k], &q = b.layers[li].paths[k];
          EXPECT_TRUE(p.points == q.points && p.mixture == q.mixture && p.joined == q.joined)
              << what << " layer " << li << " path " << k;
        }
      }
      EXPECT_GT(paths, 20u) << what;
      EXPECT_EQ(s1.paths, s2.paths) << what;
      EXPECT_EQ(s1.faces, s2.faces) << what;
      EXPECT_EQ(s1.colour_changes, s2.colour_changes) << what;
      EXPECT_EQ(s1.short_merged, s2.short_merged) << what;
      EXPECT_EQ(s1.purges, s2.purges) << what;
    }
}
