#include <gtest/gtest.h>

#include "support/random_graphs.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/core/error.hpp"
#include "trellis/lattice/cells3d.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/aero.hpp"

using namespace trellis;

namespace {

AeroResult periodic(const Graph& g, UnitCell cell, int print_path = 1) {
  AeroParams p;
  p.method = AeroMethod::Periodic;
  p.periodic = {cell, 7.0, print_path};
  Diagnostics d;
  return plan_aero(g, p, d);
}

CollisionCheck check(const Graph& g, const AeroResult& r) {
  return check_collisions(g, aero_toolpath(g, r, "test"), CheckOptions{});
}

struct Case {
  UnitCell cell;
  int print_path;
};
const Case kCases[] = {
    {UnitCell::Octet, 1}, {UnitCell::Bcc, 1}, {UnitCell::Bcc, 2}, {UnitCell::Cubic, 1}};

}  // namespace

// One cell prints as its hand-made path says: one trail per step, every strut once, nothing
// joined or lost; the paths are bottom-up wherever the cone asks.
TEST(Periodic, OneCellPrintsStepByStep) {
  for (const Case& c : kCases) {
    const Graph g = cell_lattice({c.cell, 7, 1, 1, 1});
    const AeroResult r = periodic(g, c.cell, c.print_path);
    EXPECT_EQ(validate_paths(g, r.trails), "") << to_string(c.cell) << c.print_path;
    EXPECT_EQ(r.trails.trails.size(), periodic_cell_steps(c.cell, c.print_path))
        << to_string(c.cell) << c.print_path;
    for (const Trail& t : r.trails.trails)
      for (std::size_t k = 0; k < t.edges.size(); ++k) {
        const Vec3 a = g.nodes[t.nodes[k]], b = g.nodes[t.nodes[k + 1]];
        if (is_steep(a, b, NozzleModel{})) {
          EXPECT_LT(a.z, b.z);
        }
      }
  }
}

// Over many cells every strut still prints once (shared faces once), and the octet path and BCC
// Print Path 1 (nodes side by side, arches under V's) never hit a printed strut; Print Path 2's
// second trace through a node passes under the first's upper strut in the same vertical plane,
// which the nozzle model counts.
TEST(Periodic, LatticesPrintEveryStrutOnceAndTheSideBySidePathsAreCollisionFree) {
  for (const Case& c : kCases)
    for (int n = 1; n <= 4; ++n) {
      const Graph g = cell_lattice({c.cell, 7, n, n + 1, n});
      const AeroResult r = periodic(g, c.cell, c.print_path);
      ASSERT_EQ(validate_paths(g, r.trails), "") << to_string(c.cell) << c.print_path << " " << n;
      const CollisionCheck k = check(g, r);
      EXPECT_EQ(k.printed_once, g.edges.size());
      EXPECT_EQ(k.collisions, r.collisions_planned);
      if (c.cell == UnitCell::Bcc && c.print_path == 2)
        EXPECT_GT(k.collisions, 0u) << n;
      else
        EXPECT_EQ(k.collisions, 0u) << to_string(c.cell) << " " << n;
    }
}

// The paper's comparison (Fig. S6): AERO needs fewer travel motions than the semi-manual path on
// the 3 x 3 x 3 octet, which prints in more steps per cell than the cell's AERO plan.
TEST(Periodic, AeroNeedsFewerTravelsThanTheCellPath) {
  Diagnostics d;
  const Graph g =
      read_lattice(std::string(TRELLIS_TEST_DATA) + "/aero/octet_3x3x3_edges.csv", {}, d);
  const AeroResult manual = periodic(g, UnitCell::Octet);
  AeroParams p;
  p.method = AeroMethod::Groups;
  const AeroResult aero = plan_aero(g, p, d);
  EXPECT_LT(aero.travel_moves, manual.travel_moves);
  EXPECT_EQ(manual.travel_moves + 1, manual.trails.trails.size());
}

// The plan follows the geometry: the same lattice listed in another order prints the same.
TEST(Periodic, ThePlanDependsOnTheGeometryNotTheInputOrder) {
  const Graph g = cell_lattice({UnitCell::Bcc, 7, 3, 2, 2});
  const Graph h = test::relisted(g, 7, 3);
  const AeroResult a = periodic(g, UnitCell::Bcc), b = periodic(h, UnitCell::Bcc);
  ASSERT_EQ(a.trails.trails.size(), b.trails.trails.size());
  for (std::size_t t = 0; t < a.trails.trails.size(); ++t) {
    ASSERT_EQ(a.trails.trails[t].nodes.size(), b.trails.trails[t].nodes.size());
    for (std::size_t k = 0; k < a.trails.trails[t].nodes.size(); ++k)
      EXPECT_EQ(g.nodes[a.trails.trails[t].nodes[k]], h.nodes[b.trails.trails[t].nodes[k]]);
  }
}

// A lattice of another cell, or of another size, is refused naming a strut the path misses; a
// cell without a hand-made path is refused as a setting.
TEST(Periodic, RefusesLatticesItsCellPathDoesNotCover) {
  const Graph bcc = cell_lattice({UnitCell::Bcc, 7, 2, 2, 2});
  try {
    periodic(bcc, UnitCell::Octet);
    FAIL() << "a bcc lattice planned with the octet path";
  } catch (const GeometryError& e) {
    EXPECT_NE(std::string(e.what()).find("is not a strut of a 7 mm octet cell"), std::string::npos)
        << e.what();
    EXPECT_EQ(e.where().element.rfind("strut ", 0), 0u);
  }
  AeroParams p;
  p.method = AeroMethod::Periodic;
  p.periodic = {UnitCell::Octet, 3.5, 1};
  Diagnostics d;
  EXPECT_THROW(plan_aero(cell_lattice({UnitCell::Octet, 7, 1, 1, 1}), p, d), GeometryError);
  p.periodic = {UnitCell::Diamond, 7, 1};
  EXPECT_THROW(plan_aero(cell_lattice({UnitCell::Diamond, 7, 1, 1, 1}), p, d), SettingError);
}

// A cell path goes as written: where a wider cone makes its struts steep and the path prints them
// top-down, a warning says so; at the default cone the octet path is bottom-up.
TEST(Periodic, ACellPathAgainstTheConeRuleIsSaid) {
  const Graph g = cell_lattice({UnitCell::Octet, 7, 1, 1, 1});
  AeroParams p;
  p.method = AeroMethod::Periodic;
  Diagnostics quiet;
  plan_aero(g, p, quiet);
  EXPECT_EQ(quiet.counts().count("cell_path_top_down"), 0u);
  p.nozzle.cone_half_angle_deg = 50;
  Diagnostics d;
  plan_aero(g, p, d);
  EXPECT_EQ(d.counts().count("cell_path_top_down"), 1u);
}
