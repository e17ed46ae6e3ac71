// Graded slicing in path order (FgmOptions::order = Paths, issue 39): Strategy 1 keeps the
// planar slicer's paths and cuts each at the colour faces' edges into joined pieces, and the
// writer issues each mixture change the look-ahead before the crossing. Properties over many
// generated fields and palettes; every G-code check parses what was written.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>

#include "support/machines.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/slice/fgm.hpp"

using namespace trellis;

namespace {

struct Case {
  std::string name, vcad;
  int colors = 4, materials = 2;
  double zipper = 0;
};

// Random smooth two-material fields on a small plate (f clamped to [0, 1] by the palette), a
// three-material disc, and zippered palettes.
std::vector<Case> cases() {
  std::vector<Case> out;
  std::mt19937 rng(39);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 10; ++k) {
    const double a = 0.5 * u(rng), b = 0.25 * u(rng), c = 1.2 * u(rng), d = 1.2 * u(rng),
                 e = 0.5 * u(rng);
    char expr[256];
    std::snprintf(expr, sizeof expr, "0.5 + %.3f*x/10 + %.3f*sin(%.3f*x + %.3f*y) + %.3f*y/10", a,
                  b, c, d, e);
    Case cs;
    cs.name = expr;
    cs.vcad = std::string("fgrade([\"") + expr + "\", \"1 - (" + expr +
              ")\"], [\"a\", \"b\"]) {\n  rectprism(16, 12, 0.6);\n}\n";
    cs.colors = 2 + static_cast<int>(rng() % 15u);
    if (k % 4 == 3) cs.zipper = 0.3 / cs.colors;
    out.push_back(cs);
  }
  Case three;
  three.name = "three materials";
  three.vcad =
      "fgrade([\"(1 + x/16 + 0.1*sin(y))/3\", \"(1 + y/16)/3\", \"(1 - x/16 - y/16 - "
      "0.1*sin(y))/3\"],"
      " [\"a\", \"b\", \"c\"]) {\n  cylinder(10, 0.6);\n}\n";
  three.colors = 9;
  three.materials = 3;
  out.push_back(three);
  return out;
}

struct Planned {
  Field field;
  std::vector<double> zs;
  std::vector<LayerOutline> outlines;
  Toolpath planar, graded;
  FgmOptions options;
  FgmStats stats;
};

Planned plan(const Case& c, double min_segment) {
  Planned p;
  p.field = parse_vcad(c.vcad, "test.vcad").field;
  const double h = 0.3;
  const BBox3 e = p.field.extent();
  p.zs = layer_planes(e.min.z, e.max.z, h);
  p.outlines = slice_field(p.field, p.zs, FieldSliceOptions{});
  PlanarOptions po;
  po.layer_height = h;
  po.top_layers = po.bottom_layers = 1;
  po.infill_density = 0.3;
  p.planar = plan_planar(p.outlines, po);
  p.options.palette.colors = c.colors;
  p.options.palette.materials = c.materials;
  p.options.layer_height = h;
  p.options.bead_width = po.bead_width;
  p.options.material_resolution = 0.25;
  p.options.zipper = c.zipper;
  p.options.min_segment = min_segment;
  p.graded = plan_fgm_strategy1(p.field, p.outlines, p.planar, p.options, PurgeOptions{}, &p.stats);
  return p;
}

double distance_to(const Vec3& q, const Vec3& a, const Vec3& b) {
  return distance_to_segment(q, a, b);
}

}  // namespace

TEST(FgmPaths, EachPathsPiecesAreThePathInItsPlace) {
  // Every planar path is printed as one bead in its planar place: its pieces (a first one and
  // the joined ones after it) together are the path, every point of it in order and the cut
  // points on its segments, the same length; no bead added or lost.
  for (const Case& c : cases())
    for (const double min_segment : {0.0, 5.0}) {
      SCOPED_TRACE(c.name + ", " + std::to_string(c.colors) + " colours, min " +
                   std::to_string(min_segment));
      const Planned p = plan(c, min_segment);
      ASSERT_EQ(p.graded.layers.size(), p.planar.layers.size());
      std::size_t joined = 0;
      for (std::size_t li = 0; li < p.planar.layers.size(); ++li) {
        const auto& paths = p.graded.layers[li].paths;
        std::vector<std::vector<Vec3>> beads;
        for (const Path& q : paths) {
          if (!q.joined) beads.emplace_back();
          ASSERT_FALSE(beads.empty()) << "a layer starts with a joined piece";
          auto& b = beads.back();
          if (!b.empty()) {
            ASSERT_LT(distance(b.back(), q.points.front()), 1e-12) << "joined pieces meet";
            b.insert(b.end(), q.points.begin() + 1, q.points.end());
          } else {
            b = q.points;
          }
          joined += q.joined;
        }
        const auto& planar = p.planar.layers[li].paths;
        ASSERT_EQ(beads.size(), planar.size()) << "layer " << li;
        for (std::size_t k = 0; k < planar.size(); ++k) {
          const auto& orig = planar[k].points;
          const auto& bead = beads[k];
          // The path's points, in order, each found in the bead; between two of them only
          // points on the segment joining them.
          std::size_t at = 0;
          for (std::size_t i = 0; i < orig.size(); ++i) {
            while (at < bead.size() && distance(bead[at], orig[i]) > 1e-9) {
              ASSERT_GT(i, 0u) << "the bead starts where the path starts";
              EXPECT_LT(distance_to(bead[at], orig[i - 1], orig[i]), 1e-9)
                  << "a cut point off the path";
              ++at;
            }
            ASSERT_LT(at, bead.size())
                << "layer " << li << " path " << k << ": point " << i << " missing";
            ++at;
          }
          EXPECT_EQ(at, bead.size()) << "the bead ends where the path ends";
          double a = 0, b = 0;
          for (std::size_t i = 1; i < orig.size(); ++i) a += distance(orig[i - 1], orig[i]);
          for (std::size_t i = 1; i < bead.size(); ++i) b += distance(bead[i - 1], bead[i]);
          EXPECT_NEAR(a, b, 1e-9 * std::max(1.0, a));
        }
      }
      EXPECT_GT(joined, 0u) << "paths cross colour edges";
      EXPECT_EQ(joined, p.stats.joined);
      EXPECT_FALSE(p.stats.tower.built) << "path order on a mixing hotend prints no tower";
    }
}

TEST(FgmPaths, EveryPieceHasItsColoursMixtureWithinTheBound) {
  // Each piece's mixture is a palette colour's, the design along it within that colour's band
  // (α/2, 2α/3 for three materials, + β/2 with zippering; the zones' edges are contour chords
  // refined onto the iso-lines to about 1e-4 of a band, 1e-3 allowed); without zippering a joined
  // piece's colour is a neighbour of the one before (a bead crosses one edge at a time).
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name + ", " + std::to_string(c.colors) + " colours");
    const Planned p = plan(c, 0);
    const Palette& pal = p.options.palette;
    const double bound = pal.error_bound() + c.zipper / 2 + 1e-3 * pal.band();
    Evaluator ev(p.field);
    std::size_t checked = 0;
    for (std::size_t li = 0; li < p.graded.layers.size(); ++li) {
      const auto& paths = p.graded.layers[li].paths;
      for (std::size_t k = 0; k < paths.size(); ++k) {
        const Path& q = paths[k];
        const int colour = pal.color_of(q.mixture);
        ASSERT_EQ(q.mixture, pal.mixture(colour));
        for (std::size_t i = 0; i + 1 < q.points.size(); ++i) {
          const Vec3 a = q.points[i], b = q.points[i + 1];
          const int n = std::max(1, static_cast<int>(std::ceil(distance(a, b) / 0.1)));
          for (int j = 0; j <= n; ++j) {
            const Vec3 s = a + (b - a) * (static_cast<double>(j) / n);
            const auto f = ev.fractions({s.x, s.y, p.zs[li]});
            double e = 0;
            for (std::size_t m = 0; m < f.size(); ++m)
              e = std::max(e, std::abs(std::clamp(f[m], 0.0, 1.0) - q.mixture[m]));
            ASSERT_LE(e, bound) << "layer " << li << " at " << s.x << ", " << s.y;
            ++checked;
          }
        }
        if (q.joined && c.zipper == 0) {
          const auto& before = paths[k - 1].mixture;
          double change = 0;
          for (std::size_t m = 0; m < before.size(); ++m)
            change = std::max(change, std::abs(before[m] - q.mixture[m]));
          EXPECT_GT(change, 0) << "a joined piece changes colour";
          // One palette step along a bead: a band, or for three materials a triangle beside
          // this one (4α/3 where the bead passes through a corner the triangles share).
          EXPECT_LE(change, (c.materials == 3 ? 4.0 / 3.0 : 1.0) * pal.band() + 1e-9);
        }
      }
    }
    EXPECT_GT(checked, 1000u);
  }
}

namespace {

// The G-code replayed: each extruding move's end point with the printed length (XY of
// extruding moves) up to it, the printed length at which each mixing command is written, and
// the extrusion starts (an extruding move after a travel, or the first).
struct Replayed {
  std::vector<std::pair<Vec2, double>> ends;
  std::vector<double> commands;
  std::size_t starts = 0;
};

Replayed replay(const std::string& gcode, const char* command = "M165") {
  Replayed r;
  std::istringstream in(gcode);
  std::string line;
  double x = 0, y = 0, s = 0;
  bool extruding = false;
  while (std::getline(in, line)) {
    if (line.rfind(command, 0) == 0) {
      r.commands.push_back(s);
      continue;
    }
    const bool g0 = line.rfind("G0 ", 0) == 0, g1 = line.rfind("G1 ", 0) == 0;
    if (!g0 && !g1) continue;
    double nx = x, ny = y;
    bool e = false;
    std::istringstream w(line.substr(3));
    std::string word;
    while (w >> word) {
      if (word[0] == 'X') nx = std::stod(word.substr(1));
      if (word[0] == 'Y') ny = std::stod(word.substr(1));
      if (word[0] == 'E') e = std::stod(word.substr(1)) > 0;
    }
    const bool moves = nx != x || ny != y;
    if (g1 && e && moves) {
      if (!extruding) ++r.starts;
      extruding = true;
      s += std::hypot(nx - x, ny - y);
      r.ends.push_back({{nx, ny}, s});
    } else if (moves) {
      extruding = false;
    }
    x = nx, y = ny;
  }
  return r;
}

// Beads that begin where the one before ended (no travel: one extrusion in the G-code).
std::size_t beads_without_travel(const Toolpath& tp) {
  std::size_t n = 0;
  const Path* before = nullptr;
  for (const auto& l : tp.layers)
    for (const auto& q : l.paths) {
      if (!q.joined && before && distance_xy(before->points.back(), q.points.front()) < 1e-9) ++n;
      before = &q;
    }
  return n;
}

}  // namespace

TEST(FgmPaths, TheWriterIssuesEachChangeTheLookAheadBeforeItsCrossing) {
  // The G-code's M165 commands, at the printed length where each is written, are the toolpath's
  // colour changes (where a piece of a new mixture begins: its first point, found among the
  // G-code's extruding moves) moved the look-ahead earlier along the printed path, across pieces
  // and earlier paths (to the print's start where that is before it). And a bead is one
  // extrusion: the G-code starts one for every bead (but beads that begin where the last ended).
  std::size_t compared = 0;
  for (const Case& c : cases()) {
    if (c.materials != 2) continue;
    SCOPED_TRACE(c.name + ", " + std::to_string(c.colors) + " colours");
    const Planned p = plan(c, 5);
    for (const double lookahead : {0.0, 7.5, 60.0}) {
      MachineProfile prof = test::open_bed({}, 0, 2);
      prof.relative_e = true;
      prof.lookahead = lookahead;
      const Replayed g = replay(write_gcode(p.graded, prof));
      // Where each piece begins in the G-code: the printed length at the end of the extruding
      // move onto its first point (the previous piece's last), the toolpath's points found in
      // order among the moves' ends (the look-ahead adds ends of its own).
      std::vector<double> want;
      std::size_t at = 0, beads = 0;
      double s = 0;
      std::vector<double> last;
      auto find = [&](Vec3 q) {
        while (at < g.ends.size() &&
               std::hypot(g.ends[at].first.x - q.x, g.ends[at].first.y - q.y) > 2e-3)
          ++at;
        EXPECT_LT(at, g.ends.size())
            << "a toolpath point the G-code does not print: " << q.x << ", " << q.y;
        if (at < g.ends.size()) s = g.ends[at].second;
      };
      for (const auto& l : p.graded.layers)
        for (const auto& q : l.paths) {
          beads += !q.joined;
          if (q.mixture != last) want.push_back(std::max(0.0, s - lookahead));
          last = q.mixture;
          for (std::size_t i = 1; i < q.points.size(); ++i) find(q.points[i]);
        }
      ASSERT_EQ(g.commands.size(), want.size()) << "look-ahead " << lookahead;
      for (std::size_t k = 0; k < want.size(); ++k)
        EXPECT_NEAR(g.commands[k], want[k], 1e-2) << "change " << k << ", look-ahead " << lookahead;
      EXPECT_EQ(g.starts, beads - beads_without_travel(p.graded)) << "look-ahead " << lookahead;
      compared += want.size();
    }
  }
  EXPECT_GT(compared, 200u);
}

TEST(FgmPaths, TemperatureChangesAlongABeadAddNoTravel) {
  // Temperature-graded (foaming) printing in path order: the M104 of each colour is written
  // inside the bead where it crosses the edge (no travel, no restart: as many extrusion starts as
  // beads), none is followed by a dwell.
  const Case c = cases().front();
  const Planned p = plan(c, 5);
  MachineProfile prof = test::open_bed();
  prof.gradient_mode = GradientMode::Temperature;
  prof.relative_e = true;
  prof.retract_length = 0;
  const std::string g = write_gcode(p.graded, prof);
  std::size_t beads = 0, changes = 0;
  for (const auto& l : p.graded.layers)
    for (const auto& q : l.paths) beads += !q.joined, changes += q.joined;
  ASSERT_GT(changes, 10u);
  EXPECT_EQ(replay(g, "M104").starts, beads - beads_without_travel(p.graded));
  std::istringstream in(g);
  std::string line, prev;
  std::size_t inside = 0;
  bool printing = false;
  while (std::getline(in, line)) {
    if (line.rfind("G4", 0) == 0) EXPECT_NE(prev.rfind("M104", 0), 0u) << "a dwell after " << prev;
    if (line.rfind("M104", 0) == 0 && printing) ++inside;
    if (line.rfind("G1 ", 0) == 0 && line.find(" E") != std::string::npos) printing = true;
    if (line.rfind("G0 ", 0) == 0) printing = false;
    prev = line;
  }
  EXPECT_GT(inside, changes / 2) << "temperature changes are written inside beads";
}
