#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <set>

#include "support/random_graphs.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/cells3d.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/plan/aero.hpp"
#include "trellis/plan/euler.hpp"
#include "trellis/settings/settings.hpp"

using namespace trellis;

namespace {

const std::string kAero = std::string(TRELLIS_SOURCE_DIR) + "/../shared/data/aero/";
const std::string kData = std::string(TRELLIS_TEST_DATA) + "/aero/";

// The AERO example lattices are kept in tests/data/aero (copied from ../shared/data/aero).
Graph aero_lattice(const std::string& name) {
  Diagnostics d;
  return read_lattice(kData + name + "_edges.csv", {}, d);
}

// Every trail walks existing struts, every strut once, one-way struts the right way.
void expect_valid_trails(const Graph& g, const std::vector<Trail>& trails,
                         const std::vector<std::int8_t>& dir) {
  std::vector<int> used(g.edges.size(), 0);
  for (const auto& t : trails) {
    ASSERT_EQ(t.nodes.size(), t.edges.size() + 1);
    for (std::size_t i = 0; i < t.edges.size(); ++i) {
      const Edge& e = g.edges[t.edges[i]];
      const NodeId a = t.nodes[i], b = t.nodes[i + 1];
      ASSERT_TRUE((e.a == a && e.b == b) || (e.a == b && e.b == a));
      if (dir[t.edges[i]] > 0) EXPECT_EQ(a, e.a);
      if (dir[t.edges[i]] < 0) EXPECT_EQ(a, e.b);
      ++used[t.edges[i]];
    }
  }
  for (EdgeId e = 0; e < g.edges.size(); ++e) EXPECT_EQ(used[e], 1) << "strut " << e;
}

CollisionCheck check(const Graph& g, const AeroResult& r, const NozzleModel& m = {}) {
  CheckOptions o;
  o.nozzle = m;
  return check_collisions(g, aero_toolpath(g, r, "test"), o);
}

}  // namespace

TEST(MixedEuler, CoversEveryStrutOnceInTheLowerBoundNumberOfTrails) {
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    const Graph g = test::random_graph(seed, 12 + seed % 9, 10 + 3 * (seed % 11));
    Rng rng(seed);
    std::vector<std::int8_t> dir(g.edges.size(), 0);
    if (seed % 2 == 0)
      for (auto& d : dir) d = static_cast<std::int8_t>(rng.uniform_index(3)) - 1;
    std::vector<EdgeId> all(g.edges.size());
    for (EdgeId e = 0; e < all.size(); ++e) all[e] = e;
    MixedEuler euler(g.nodes.size());
    const auto trails = euler.decompose(g, all, dir);
    expect_valid_trails(g, trails, dir);
    EXPECT_EQ(trails.size(), euler.lower_bound(g, all, dir)) << seed;
    if (seed % 2 == 1) EXPECT_EQ(trails.size(), lower_bound_paths(g)) << seed;  // odd/2
  }
}

TEST(MixedEuler, MixedLowerBoundMatchesExhaustiveOrientations) {
  // Small mixed graphs: try every orientation of the free struts; the best Σ max(1, surplus)
  // per component is the true minimum number of trails.
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    const Graph g = test::random_graph(seed * 7, 7, 9);
    Rng rng(seed);
    std::vector<std::int8_t> dir(g.edges.size());
    std::vector<EdgeId> all, free;
    for (EdgeId e = 0; e < g.edges.size(); ++e) {
      dir[e] = static_cast<std::int8_t>(rng.uniform_index(3)) - 1;
      all.push_back(e);
      if (!dir[e]) free.push_back(e);
    }
    const auto comp = connected_components(g);
    std::size_t best = SIZE_MAX;
    for (std::uint32_t mask = 0; mask < (1u << free.size()); ++mask) {
      std::vector<int> bal(g.nodes.size(), 0);
      for (EdgeId e : all) {
        bool forward = dir[e] > 0;
        if (!dir[e])
          forward = (mask >> (std::find(free.begin(), free.end(), e) - free.begin())) & 1;
        const Edge& ed = g.edges[e];
        bal[forward ? ed.a : ed.b]++;
        bal[forward ? ed.b : ed.a]--;
      }
      std::map<int, std::size_t> surplus;
      for (NodeId v = 0; v < g.nodes.size(); ++v)
        if (comp[v] >= 0) surplus[comp[v]] += std::max(0, bal[v]);
      std::size_t total = 0;
      for (auto [c, s] : surplus) total += std::max<std::size_t>(1, s);
      best = std::min(best, total);
    }
    MixedEuler euler(g.nodes.size());
    EXPECT_EQ(euler.lower_bound(g, all, dir), best) << seed;
  }
}

TEST(MixedEuler, ContinuesTheOpenTrailWhenItCan) {
  // A path 0-1-2-3: continuing from node 1 must give a trail starting at 1.
  Graph g;
  for (int i = 0; i < 4; ++i) g.nodes.push_back({double(i), 0, 0});
  g.edges = {{0, 1}, {1, 2}, {2, 3}};
  std::vector<std::int8_t> dir(3, 0);
  MixedEuler euler(g.nodes.size());
  bool continued = false;
  const auto trails = euler.decompose(g, {1, 2}, dir, 1, &continued);
  ASSERT_TRUE(continued);
  EXPECT_EQ(trails.front().nodes.front(), 1u);
  EXPECT_EQ(trails.size(), 1u);
}

TEST(Aero, EveryUnitCellUpToFiveCubedIsCollisionFree) {
  for (const auto& name : unit_cell_names())
    for (int n = 1; n <= 5; ++n) {
      const Graph g = cell_lattice({unit_cell_from_string(name), 7, n, n, n});
      Diagnostics d;
      AeroParams p;
      p.tries = 2;
      const AeroResult r = plan_aero(g, p, d);
      const CollisionCheck c = check(g, r);
      EXPECT_EQ(c.collisions, 0u) << name << " " << n;
      EXPECT_EQ(r.violations.size(), 0u) << name << " " << n;
      EXPECT_TRUE(c.ok()) << name << " " << n;
      EXPECT_EQ(c.printed_once, g.edges.size());
      EXPECT_GE(r.trails.trails.size(), r.lower_bound_trails);
      if (name == "octet" && n == 1) EXPECT_LE(r.trails.trails.size(), 8u);  // paper: 8 steps
    }
}

TEST(Aero, TheAeroExamplesBeatTheAeroProgramByHalf) {
  // Trails of the AERO program itself on these lattices (run here): at most half, and the
  // independent checker finds exactly the collisions the planner could not avoid.
  const std::map<std::string, std::size_t> aero_trails = {{"octet_3x3x3", 71},
                                                          {"stanford_bunny", 400},
                                                          {"cylindrical", 272},
                                                          {"interpenetrated_spheres", 135},
                                                          {"hollow_sphere", 75}};
  for (const char* name :
       {"octet_3x3x3", "stanford_bunny", "cylindrical", "interpenetrated_spheres", "hollow_sphere",
        "octet_3x3x2", "cubic", "cubic_sphere", "filled_sphere"}) {
    const Graph g = aero_lattice(name);
    Diagnostics d;
    const AeroResult r = plan_aero(g, {}, d);
    const CollisionCheck c = check(g, r);
    EXPECT_EQ(c.printed_once, g.edges.size()) << name;
    EXPECT_TRUE(c.top_down.empty()) << name;
    if (aero_trails.count(name))
      EXPECT_LE(r.trails.trails.size() * 2, aero_trails.at(name)) << name;
    // A strut is forced only when every remaining one obstructs another; the collisions that
    // follow are at most the struts it obstructs.
    std::size_t obstructed = 0;
    for (const auto& v : r.violations) {
      EXPECT_GE(v.obstructs, 1u) << name;
      obstructed += v.obstructs;
    }
    EXPECT_LE(c.collisions, obstructed) << name;
    // Each pair of struts that obstruct each other costs a collision in any order: that many
    // and no more.
    EXPECT_EQ(c.collisions, r.mutual_pairs) << name;
    const std::set<std::string> clean = {"octet_3x3x3", "octet_3x3x2", "cubic",
                                         "interpenetrated_spheres", "hollow_sphere"};
    if (clean.count(name)) EXPECT_EQ(c.collisions, 0u) << name;
  }
}

TEST(Aero, WithoutCollisionsTrailsEqualTheLowerBound) {
  for (const char* name : {"octet_3x3x3", "stanford_bunny", "cubic"}) {
    const Graph g = aero_lattice(name);
    Diagnostics d;
    AeroParams p;
    p.collisions = false;
    const AeroResult r = plan_aero(g, p, d);
    EXPECT_EQ(r.trails.trails.size(), r.lower_bound_trails) << name;
  }
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const Graph g = test::random_lattice3d(seed);
    Diagnostics d;
    AeroParams p;
    p.collisions = false;
    const AeroResult r = plan_aero(g, p, d);
    EXPECT_EQ(r.trails.trails.size(), r.lower_bound_trails) << seed;
    EXPECT_EQ(validate_paths(g, r.trails), "");
  }
}

TEST(Aero, RandomLatticesBothMethodsCollisionFree) {
  for (std::uint64_t seed = 1; seed <= 25; ++seed) {
    const Graph g = test::random_lattice3d(seed, 3 + seed % 3, 0.55, 0.4);
    for (AeroMethod m : {AeroMethod::Dynamic, AeroMethod::Groups}) {
      Diagnostics d;
      AeroParams p;
      p.method = m;
      p.tries = 3;
      const AeroResult r = plan_aero(g, p, d);
      EXPECT_EQ(validate_paths(g, r.trails), "") << seed;
      const CollisionCheck c = check(g, r);
      EXPECT_TRUE(c.top_down.empty()) << seed;
      EXPECT_EQ(c.printed_once, g.edges.size()) << seed;
      EXPECT_EQ(c.collisions, 0u) << "seed " << seed << " " << to_string(m) << " violations "
                                  << r.violations.size();
    }
  }
}

TEST(Aero, MaterialsStaySeparateAndSeedsReproduce) {
  Graph g = cell_lattice({UnitCell::Octet, 7, 2, 2, 2});
  assign_materials(g, MaterialRule::XyPlane);
  Diagnostics d;
  AeroParams p;
  const AeroResult a = plan_aero(g, p, d), b = plan_aero(g, p, d);
  ASSERT_EQ(a.trails.trails.size(), b.trails.trails.size());
  for (std::size_t i = 0; i < a.trails.trails.size(); ++i) {
    EXPECT_EQ(a.trails.trails[i].edges, b.trails.trails[i].edges);
    for (EdgeId e : a.trails.trails[i].edges) EXPECT_EQ(g.edges[e].material, a.trail_material[i]);
  }
  EXPECT_EQ(check(g, a).collisions, 0u);
  EXPECT_THROW(aero_method_from_string("greedy"), SettingError);
  EXPECT_THROW(plan_aero(Graph{}, p, d), GeometryError);
}

TEST(Aero, DeadlockIsPrintedLowestFirstAndReported) {
  // Two struts from one node, 10° apart and 5 mm long: each obstructs the other beyond the node
  // clearance, so one collision is unavoidable; the planner says so.
  Graph g;
  g.nodes = {{0, 0, 0}, {0.3, 0, 5}, {-0.6, 0, 5}};
  g.edges = {{0, 1}, {0, 2}};
  Diagnostics d;
  const AeroResult r = plan_aero(g, {}, d);
  EXPECT_EQ(r.violations.size(), 1u);
  EXPECT_EQ(d.count("collision_unavoidable"), 1u);
  EXPECT_EQ(check(g, r).collisions, 1u);
}

TEST(Aero, ThePlanDependsOnTheGeometryNotTheInputOrder) {
  const Graph g = aero_lattice("octet_3x3x3");
  // The same lattice with nodes and struts listed in another order, struts reversed.
  const Graph h = test::relisted(g, 37, 11);
  Diagnostics d;
  const AeroResult a = plan_aero(g, {}, d), b = plan_aero(h, {}, d);
  ASSERT_EQ(a.trails.trails.size(), b.trails.trails.size());
  for (std::size_t t = 0; t < a.trails.trails.size(); ++t) {
    ASSERT_EQ(a.trails.trails[t].nodes.size(), b.trails.trails[t].nodes.size());
    for (std::size_t k = 0; k < a.trails.trails[t].nodes.size(); ++k)
      EXPECT_EQ(g.nodes[a.trails.trails[t].nodes[k]], h.nodes[b.trails.trails[t].nodes[k]]);
  }
}

namespace {

// Writes the plan as G-code for the single-nozzle embedded machine, reads it back and replays
// it with the independent checker.
CollisionCheck replay_gcode(const Graph& g, const AeroResult& r) {
  const MachineProfile prof =
      load_machine_profile(std::string(TRELLIS_SOURCE_DIR) + "/profiles/embedded_aero_410um.toml");
  const std::string gcode = write_gcode(aero_toolpath(g, r, "test"), prof);
  GcodeReadOptions read;
  read.valve_on = prof.valve_on;
  read.valve_off = prof.valve_off;
  Diagnostics d;
  Toolpath back = read_gcode(gcode, read, d);
  to_design_coordinates(back, gcode);  // the writer centred and lifted it onto the bed
  CheckOptions o;
  o.snap = prof.node_overlap + 0.05;
  return check_collisions(g, back, o);
}

struct Case {
  std::string name;
  Graph graph;
  bool foam = false;
};

std::vector<Case> collision_cases() {
  std::vector<Case> cases;
  for (const char* name :
       {"octet_3x3x3", "stanford_bunny", "cylindrical", "interpenetrated_spheres", "hollow_sphere",
        "octet_3x3x2", "cubic", "cubic_sphere", "filled_sphere"})
    cases.push_back({name, aero_lattice(name)});
  // The three foam densities.
  const double foams[3][2] = {{20, 0.005}, {30, 0.002}, {40, 0.0005}};
  for (const auto& f : foams) {
    FoamParams fp;
    fp.width = fp.depth = fp.height = f[0];
    fp.density = f[1];
    Diagnostics d;
    cases.push_back({"foam " + std::to_string(f[1]), voronoi_foam(fp, d), true});
  }
  // Dense random lattices of about 100 to 500 struts.
  const std::pair<int, double> dense[] = {{4, 0.3}, {4, 0.45}, {5, 0.3}, {5, 0.47}};
  for (std::size_t i = 0; i < 4; ++i)
    cases.push_back({"dense " + std::to_string(i),
                     test::dense_lattice3d(100 + i, dense[i].first, dense[i].second)});
  return cases;
}

}  // namespace

TEST(Aero, ReplayedGcodeFindsExactlyThePlannedCollisions) {
  for (const Case& c : collision_cases()) {
    const Graph& g = c.graph;
    if (c.name.rfind("dense", 0) == 0) {
      EXPECT_GE(g.edges.size(), 100u) << c.name;
      EXPECT_LE(g.edges.size(), 500u) << c.name;
    }
    Diagnostics d;
    AeroParams p;
    const AeroResult r = plan_aero(g, p, d);
    const CollisionCheck replay = replay_gcode(g, r);
    EXPECT_EQ(replay.printed_once, g.edges.size()) << c.name;
    EXPECT_TRUE(replay.top_down.empty()) << c.name;
    EXPECT_EQ(replay.collisions, r.collisions_planned) << c.name;
    EXPECT_LE(r.collisions_lower_bound, r.collisions_planned) << c.name;
    // Each mutually obstructing pair costs one collision in any order: a weaker bound.
    EXPECT_LE(r.mutual_pairs, r.collisions_lower_bound) << c.name;
    if (c.foam) EXPECT_LE(10 * r.collisions_planned, 11 * r.collisions_lower_bound) << c.name;
    // Against the greedy of earlier versions: never more collisions, trails within 10 %.
    AeroParams greedy = p;
    greedy.fewest_collisions = false;
    const AeroResult old = plan_aero(g, greedy, d);
    EXPECT_EQ(check(g, old).collisions, old.collisions_planned) << c.name;
    EXPECT_LE(r.collisions_planned, old.collisions_planned) << c.name;
    EXPECT_LE(10 * r.trails.trails.size(), 11 * old.trails.trails.size()) << c.name;
    std::size_t listed = 0;
    for (const auto& v : r.violations) listed += v.obstructs;
    EXPECT_EQ(listed, r.collisions_planned) << c.name;
    std::cout << c.name << ": " << g.edges.size() << " struts, collisions " << r.collisions_planned
              << " (greedy " << old.collisions_planned << "), lower bound "
              << r.collisions_lower_bound << (r.collisions_proven_minimal() ? " proven" : "")
              << ", trails " << r.trails.trails.size() << " (greedy " << old.trails.trails.size()
              << ")\n";
  }
}
