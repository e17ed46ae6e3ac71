// The linking stage as properties over seeded random polygons with holes: connected fill keeps
// every line and adds only connectors along the region's edge (so it never leaves the region,
// and the area it covers grows by no more than the connectors' beads), chains never fewer than
// their lower bound, a convex region's zig-zag is one chain; the planar slicer linked covers
// what it covered unlinked, its fill stays in the infill region and every travel marked inside
// stays inside the outline (checked with Clipper, not with the linker's own test); the writer
// retracts only for travel that leaves the part; seams; the shared order against a brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "support/random_regions.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/slice/link.hpp"
#include "trellis/slice/slice.hpp"
#include "trellis/toolpath/json.hpp"
#include "trellis/toolpath/order.hpp"

using namespace trellis;
using test::random_region;

namespace {

constexpr double kPi = std::numbers::pi;

bool inside_any(const Regions& r, Vec2 p, double tol) {
  return std::any_of(r.begin(), r.end(),
                     [&](const Polygon2& poly) { return contains(poly, p, tol); });
}

BBox2 box_of(const Regions& r, double margin) {
  BBox2 b{{1e300, 1e300}, {-1e300, -1e300}};
  for (const auto& p : r)
    for (const Vec2 v : p.outer)
      b.min = {std::min(b.min.x, v.x), std::min(b.min.y, v.y)},
      b.max = {std::max(b.max.x, v.x), std::max(b.max.y, v.y)};
  b.min = b.min - Vec2{margin, margin};
  b.max = b.max + Vec2{margin, margin};
  return b;
}

std::size_t painted(const BeadRaster& r) {
  std::size_t n = 0;
  for (long j = 0; j < r.ny(); ++j)
    for (long i = 0; i < r.nx(); ++i) n += r.covered(i, j);
  return n;
}

double polyline_length(const std::vector<Vec2>& l) {
  double s = 0;
  for (std::size_t k = 1; k < l.size(); ++k) s += std::sqrt(dist2(l[k - 1], l[k]));
  return s;
}

// Whether `line` appears in `chain` as consecutive points (either way).
bool holds(const std::vector<Vec2>& chain, const std::vector<Vec2>& line) {
  for (int dir = 0; dir < 2; ++dir) {
    std::vector<Vec2> l = line;
    if (dir) std::reverse(l.begin(), l.end());
    for (std::size_t s = 0; s + l.size() <= chain.size(); ++s)
      if (std::equal(l.begin(), l.end(), chain.begin() + static_cast<long>(s))) return true;
  }
  return false;
}

std::vector<std::vector<Vec2>> hatch_lines(const Regions& r, double angle, double spacing) {
  std::vector<std::vector<Vec2>> lines;
  for (const auto& s : hatch(r, angle, spacing))
    if (dist2(s.a, s.b) > 1e-6) lines.push_back({s.a, s.b});
  return lines;
}

}  // namespace

TEST(ConnectFill, KeepsEveryLineAddsOnlyBoundaryConnectorsAndStaysInTheRegion) {
  Rng rng(39);
  std::size_t lines_total = 0, chains_total = 0;
  for (int trial = 0; trial < 60; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Regions region = random_region(rng, 5 + 10 * rng.uniform01());
    const double w = 0.4, spacing = trial % 2 ? w : w / (0.1 + 0.5 * rng.uniform01());
    const auto lines = hatch_lines(region, 180 * rng.uniform01(), spacing);
    if (lines.empty()) continue;
    ConnectStats st;
    const auto chains = connect_fill(lines, region, 8 * spacing, &st);
    // Every line in exactly one chain; the chains' length is the lines' plus the connectors'.
    double in_len = 0, out_len = 0;
    for (const auto& l : lines) {
      in_len += polyline_length(l);
      EXPECT_EQ(
          std::count_if(chains.begin(), chains.end(), [&](const auto& c) { return holds(c, l); }),
          1);
    }
    for (const auto& c : chains) out_len += polyline_length(c);
    EXPECT_NEAR(out_len, in_len + st.connector_length, 1e-6 * (1 + out_len));
    // Connectors run along the boundary: every point and segment middle of a chain lies in
    // the region (within 1 µm).
    for (const auto& c : chains)
      for (std::size_t k = 0; k < c.size(); ++k) {
        ASSERT_TRUE(inside_any(region, c[k], 1e-6));
        if (k) ASSERT_TRUE(inside_any(region, (c[k - 1] + c[k]) * 0.5, 1e-6));
      }
    EXPECT_GE(chains.size(), st.regions);
    EXPECT_EQ(st.chains, chains.size());
    // Covered area: what the lines covered is still covered; the growth is within the
    // connectors' beads.
    BeadRaster before(box_of(region, 1), 0.05), after(box_of(region, 1), 0.05);
    for (const auto& l : lines) before.paint(l[0], l[1], w / 2);
    for (const auto& c : chains)
      for (std::size_t k = 1; k < c.size(); ++k) after.paint(c[k - 1], c[k], w / 2);
    std::size_t lost = 0;
    for (long j = 0; j < before.ny(); ++j)
      for (long i = 0; i < before.nx(); ++i) lost += before.covered(i, j) && !after.covered(i, j);
    EXPECT_EQ(lost, 0u);
    const double grown =
        (static_cast<double>(painted(after)) - static_cast<double>(painted(before))) * 0.05 * 0.05;
    EXPECT_LE(grown, st.connector_length * w + 0.01 * (1 + in_len * w));
    lines_total += lines.size();
    chains_total += chains.size();
  }
  // Connecting is worth it: far fewer chains than lines.
  EXPECT_LT(static_cast<double>(chains_total), 0.2 * static_cast<double>(lines_total));
}

TEST(ConnectFill, AConvexRegionIsOneZigZag) {
  for (double angle : {0.0, 17.0, 45.0, 90.0, 133.0}) {
    const Regions disc{make_circle({3, -2}, 30, 1e-3)};
    const auto lines = hatch_lines(disc, angle, 0.4);
    ConnectStats st;
    const auto chains = connect_fill(lines, disc, 1e9, &st);
    EXPECT_EQ(chains.size(), 1u) << angle;
    EXPECT_EQ(st.regions, 1u);
    // Without connectors every line is its own chain.
    EXPECT_EQ(connect_fill(lines, disc, 0).size(), lines.size());
  }
}

TEST(ConnectFill, LinesNotEndingOnTheBoundaryAreLeftAlone) {
  const Regions square{make_rectangle({0, 0}, 10, 10)};
  const std::vector<std::vector<Vec2>> lines{{{-1, 0}, {1, 0}}, {{-1, 1}, {1, 1}}};
  const auto chains = connect_fill(lines, square, 100);
  EXPECT_EQ(chains.size(), 2u);
}

TEST(Seam, PlacementsFollowTheirRules) {
  // A square with one notch (a concave corner): aligned takes the notch.
  const std::vector<Vec2> ring{{0, 0}, {10, 0}, {10, 10}, {6, 10}, {5, 6}, {4, 10}, {0, 10}};
  EXPECT_EQ(seam_vertex(ring, Seam::Aligned, {0, 0}, 1, 0), 4u);
  EXPECT_EQ(seam_vertex(ring, Seam::Rear, {0, 0}, 1, 0), 6u);  // largest y, then smallest x
  EXPECT_EQ(seam_vertex(ring, Seam::Nearest, {9.9, 0.2}, 1, 0), 1u);
  const std::size_t r1 = seam_vertex(ring, Seam::Random, {0, 0}, 7, 3);
  EXPECT_EQ(seam_vertex(ring, Seam::Random, {0, 0}, 7, 3), r1);  // reproducible for a seed
  std::vector<char> seen(ring.size(), 0);
  for (std::uint64_t key = 0; key < 200; ++key)
    seen[seam_vertex(ring, Seam::Random, {0, 0}, 7, key)] = 1;
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), static_cast<long>(ring.size()));
  // A convex square: the sharpest corner, the rear one of the equals (rear-most, then left).
  const std::vector<Vec2> sq{{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  EXPECT_EQ(seam_vertex(sq, Seam::Aligned, {5, 5}, 1, 0), 3u);
  // The same shape shifted and sampled from another start: the same place.
  std::vector<Vec2> moved;
  for (std::size_t k = 0; k < ring.size(); ++k)
    moved.push_back(ring[(k + 3) % ring.size()] + Vec2{0.5, 0});
  const Vec2 seam = moved[seam_vertex(moved, Seam::Aligned, {0, 0}, 1, 0)];
  EXPECT_EQ(seam, ring[4] + Vec2({0.5, 0}));
}

TEST(Order, SharedOrderVisitsEachOnceAndIsNoLongerThanABruteForceNearestNeighbour) {
  Rng rng(5);
  for (int trial = 0; trial < 40; ++trial) {
    const std::size_t n = 1 + rng.uniform_index(trial < 30 ? 60 : 600);
    std::vector<OrderItem> items(n);
    for (auto& it : items) {
      it.start = {100 * rng.uniform01(), 100 * rng.uniform01(), 0};
      it.end = it.start + Vec3{10 * rng.uniform01() - 5, 10 * rng.uniform01() - 5, 0};
      if (trial % 4 == 0) it.start = {std::round(it.start.x), std::round(it.start.y), 0};  // ties
    }
    const Vec3 from{-5, 50, 0};
    // Brute force: the nearest end, ties to the lower index and its start.
    std::vector<char> taken(n, 0);
    std::vector<OrderStep> nn;
    Vec3 at = from;
    for (std::size_t s = 0; s < n; ++s) {
      double best = 1e300;
      OrderStep pick;
      for (std::size_t i = 0; i < n; ++i) {
        if (taken[i]) continue;
        if (distance(at, items[i].start) < best)
          best = distance(at, items[i].start), pick = {i, false};
        if (distance(at, items[i].end) < best) best = distance(at, items[i].end), pick = {i, true};
      }
      taken[pick.item] = 1;
      nn.push_back(pick);
      at = pick.reversed ? items[pick.item].start : items[pick.item].end;
    }
    const auto got = order_by_travel(items, from);
    ASSERT_EQ(got.size(), n);
    std::vector<char> once(n, 0);
    for (const auto& s : got) once[s.item]++;
    EXPECT_EQ(std::count(once.begin(), once.end(), 1), static_cast<long>(n));
    // 2-opt only improves on the nearest neighbour.
    EXPECT_LE(order_travel(items, got, from), order_travel(items, nn, from) + 1e-9);
  }
}

namespace {

// A few layers of a random outline (the same each layer: skins below and above, infill in
// between), planned with the given linking.
Toolpath plan_random(const Regions& region, const LinkOptions& link, PlanarStats* st = nullptr) {
  std::vector<LayerOutline> layers(7);
  for (std::size_t i = 0; i < layers.size(); ++i) layers[i] = {0.2 * (i + 0.5), region};
  PlanarOptions o;
  o.top_layers = o.bottom_layers = 2;
  o.link = link;
  return plan_planar(layers, o, st);
}

}  // namespace

TEST(PlanarLinking, CoversWhatItCoveredAndKeepsFillAndInsideTravelInside) {
  Rng rng(390);
  for (int trial = 0; trial < 12; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Regions region = random_region(rng, 8 + 8 * rng.uniform01());
    LinkOptions off;
    off.connect = false;
    off.comb = false;
    LinkOptions on;
    on.seam = static_cast<Seam>(trial % 4);
    PlanarStats st;
    const Toolpath a = plan_random(region, off), b = plan_random(region, on, &st);
    ASSERT_EQ(a.layers.size(), b.layers.size());
    EXPECT_EQ(toolpath_to_json(plan_random(region, on)), toolpath_to_json(b));  // reproducible
    const double w = 0.4;
    // The slicer offsets the outline simplified to within 5 µm: 6 µm of slack.
    const Regions infill_region = offset(region, -(2 * w + 0.5 * w - 0.15 * w) + 0.006);
    for (std::size_t li = 0; li < a.layers.size(); ++li) {
      BeadRaster ra(box_of(region, 1), 0.05), rb(box_of(region, 1), 0.05);
      for (const Path& p : a.layers[li].paths)
        for (std::size_t k = 1; k < p.points.size(); ++k)
          ra.paint(p.points[k - 1].xy(), p.points[k].xy(), w / 2);
      std::size_t walls = 0;
      for (const Path& p : b.layers[li].paths) {
        for (std::size_t k = 1; k < p.points.size(); ++k)
          rb.paint(p.points[k - 1].xy(), p.points[k].xy(), w / 2);
        walls += p.role == PathRole::Perimeter;
        // Linked fill never runs outside the infill region.
        if (p.role == PathRole::Infill || p.role == PathRole::Skin)
          for (std::size_t k = 0; k < p.points.size(); ++k) {
            ASSERT_TRUE(inside_any(infill_region, p.points[k].xy(), 1e-6));
            if (k)
              ASSERT_TRUE(
                  inside_any(infill_region, ((p.points[k - 1] + p.points[k]) * 0.5).xy(), 1e-6));
          }
      }
      std::size_t lost = 0;
      for (long j = 0; j < ra.ny(); ++j)
        for (long i = 0; i < ra.nx(); ++i) lost += ra.covered(i, j) && !rb.covered(i, j);
      EXPECT_EQ(lost, 0u) << "layer " << li;
      const double grown =
          (static_cast<double>(painted(rb)) - static_cast<double>(painted(ra))) * 0.0025;
      EXPECT_LE(grown, st.layer_link[li].connector_length * w + 0.5) << "layer " << li;
      // Same walls; starts no fewer than their bound, and fewer than unlinked.
      std::size_t walls_a = 0;
      for (const Path& p : a.layers[li].paths) walls_a += p.role == PathRole::Perimeter;
      EXPECT_EQ(walls, walls_a);
      EXPECT_GE(b.layers[li].paths.size(), st.layer_link[li].lower_bound);
      EXPECT_EQ(b.layers[li].paths.size(), st.layer_link[li].starts);
      EXPECT_LE(b.layers[li].paths.size(), a.layers[li].paths.size());
      // Every travel marked inside stays inside the outline: Clipper finds no piece of it
      // outside (longer than a micrometre).
      const auto& paths = b.layers[li].paths;
      for (std::size_t k = 1; k < paths.size(); ++k) {
        if (!paths[k].inside) continue;
        std::vector<Vec2> travel{paths[k - 1].points.back().xy()};
        for (const Vec3& v : paths[k].via) travel.push_back(v.xy());
        travel.push_back(paths[k].points.front().xy());
        double outside = 0;
        for (const auto& piece : clip_polylines({travel}, region, false))
          outside += polyline_length(piece);
        EXPECT_LT(outside, 1e-3) << "layer " << li << " path " << k;
      }
    }
    EXPECT_LT(st.link.starts, st.link.fill_lines + st.walls);
  }
}

TEST(PlanarLinking, TheWriterRetractsOnlyForTravelLeavingThePart) {
  // Two islands: travel between them leaves the part, travel within each stays inside.
  Regions two{make_circle({0, 0}, 20), make_circle({40, 0}, 20)};
  PlanarStats st;
  const Toolpath tp = plan_random(two, LinkOptions{}, &st);
  MachineProfile prof;
  prof.retract_length = 0.5;
  prof.min_travel = 0.1;
  const std::string gcode = write_gcode(tp, prof);
  std::size_t leaving = 0;
  Vec3 last{};
  bool first = true;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) {
      if (!first && !p.inside && travel_into(last, p) >= prof.min_travel) ++leaving;
      first = false;
      last = p.points.back();
    }
  Diagnostics diag;
  auto count = [&](const std::string& g) {
    CountingSink c;
    GcodeScanner scanner(c, {}, diag, "t.gcode");
    scanner.feed(g);
    scanner.finish();
    return c.counts;
  };
  const GcodeCounts counts = count(gcode);
  EXPECT_GT(st.link.inside_travels, 10u);
  EXPECT_GT(leaving, 0u);
  // The writer's retractions: one per travel leaving the part (and its last, at the end).
  EXPECT_EQ(counts.retractions, leaving + 1);
  // With retraction.inside_max below every inside travel, each of them retracts too.
  prof.inside_max = 1e-6;
  EXPECT_GT(count(write_gcode(tp, prof)).retractions, counts.retractions + 10);
}
