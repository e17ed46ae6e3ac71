#include "trellis/plan/periodic.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <unordered_map>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

// A cell path's points are on the half-cell grid: 0, 1, 2 per axis (corner, centre, corner).
using Half = std::array<int, 3>;

struct CellStep {
  std::vector<Half> points;
  bool mirror_odd_x = false;  // z -> 2 - z in cells of odd x index (a trace zigzags by cells)
};

// Octet (14 nodes, 36 struts), 18 steps of two struts each, bottom-up in three tiers, as a path
// must be for the nozzle: whatever touches a bottom corner goes before whatever touches the top
// corner above it. Lower tier: the two bottom face diagonals, the octahedron's lower V's through
// the bottom face centre, an arch on each side face (bottom corner, face centre, bottom corner).
// Middle: the octahedron's square as two arcs from the x- to the x+ face centre. Upper tier: a V
// on each side face, the octahedron's top arches through the top face centre, the two top face
// diagonals. The steps are oriented so that no step starts where the one before ends.
const std::vector<CellStep>& octet_path() {
  static const std::vector<CellStep> steps = {
      {{{0, 0, 0}, {1, 1, 0}, {2, 2, 0}}}, {{{2, 0, 0}, {1, 1, 0}, {0, 2, 0}}},
      {{{0, 1, 1}, {1, 1, 0}, {2, 1, 1}}}, {{{1, 0, 1}, {1, 1, 0}, {1, 2, 1}}},
      {{{0, 0, 0}, {1, 0, 1}, {2, 0, 0}}}, {{{0, 2, 0}, {1, 2, 1}, {2, 2, 0}}},
      {{{0, 0, 0}, {0, 1, 1}, {0, 2, 0}}}, {{{2, 0, 0}, {2, 1, 1}, {2, 2, 0}}},
      {{{0, 1, 1}, {1, 0, 1}, {2, 1, 1}}}, {{{0, 1, 1}, {1, 2, 1}, {2, 1, 1}}},
      {{{0, 0, 2}, {1, 0, 1}, {2, 0, 2}}}, {{{0, 2, 2}, {1, 2, 1}, {2, 2, 2}}},
      {{{0, 0, 2}, {0, 1, 1}, {0, 2, 2}}}, {{{2, 0, 2}, {2, 1, 1}, {2, 2, 2}}},
      {{{0, 1, 1}, {1, 1, 2}, {2, 1, 1}}}, {{{1, 0, 1}, {1, 1, 2}, {1, 2, 1}}},
      {{{0, 0, 2}, {1, 1, 2}, {2, 2, 2}}}, {{{2, 0, 2}, {1, 1, 2}, {0, 2, 2}}},
  };
  return steps;
}

// BCC Print Path 1: nodes formed side by side. In each diagonal plane an arch (corner, centre,
// corner at the bottom) and then a V above it (top corners): arch and V meet tip to tip at the
// centre; along a row of cells the arches chain into one zigzag, the V's into another.
const std::vector<CellStep>& bcc_path_1() {
  static const std::vector<CellStep> steps = {
      {{{0, 0, 0}, {1, 1, 1}, {2, 2, 0}}},
      {{{2, 0, 0}, {1, 1, 1}, {0, 2, 0}}},
      {{{0, 0, 2}, {1, 1, 1}, {2, 2, 2}}},
      {{{2, 0, 2}, {1, 1, 1}, {0, 2, 2}}},
  };
  return steps;
}

// BCC Print Path 2: nodes formed by diagonally crossing traces. In each diagonal plane a trace
// runs straight through the centre, bottom to top, and down through the next cell (a zigzag two
// cells long), then a second trace crosses it at every centre.
const std::vector<CellStep>& bcc_path_2() {
  static const std::vector<CellStep> steps = {
      {{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}, true},
      {{{0, 0, 2}, {1, 1, 1}, {2, 2, 0}}, true},
      {{{2, 0, 0}, {1, 1, 1}, {0, 2, 2}}, true},
      {{{2, 0, 2}, {1, 1, 1}, {0, 2, 0}}, true},
  };
  return steps;
}

// Cubic: straight lines, the bottom edges along x then y, the verticals bottom-up, the top edges;
// lines continue through the row of cells.
const std::vector<CellStep>& cubic_path() {
  static const std::vector<CellStep> steps = {
      {{{0, 0, 0}, {2, 0, 0}}}, {{{0, 2, 0}, {2, 2, 0}}}, {{{0, 0, 0}, {0, 2, 0}}},
      {{{2, 0, 0}, {2, 2, 0}}}, {{{0, 0, 0}, {0, 0, 2}}}, {{{2, 0, 0}, {2, 0, 2}}},
      {{{0, 2, 0}, {0, 2, 2}}}, {{{2, 2, 0}, {2, 2, 2}}}, {{{0, 0, 2}, {2, 0, 2}}},
      {{{0, 2, 2}, {2, 2, 2}}}, {{{0, 0, 2}, {0, 2, 2}}}, {{{2, 0, 2}, {2, 2, 2}}},
  };
  return steps;
}

const std::vector<CellStep>& cell_path(UnitCell cell, int print_path) {
  if (print_path != 1 && print_path != 2)
    throw SettingError(fmt::format("print path {} (expected 1 or 2)", print_path),
                       {"", 0, "aero.print_path"});
  if (print_path == 2 && cell != UnitCell::Bcc)
    throw SettingError(
        "print path 2 is one of the BCC cell's two; the " + to_string(cell) + " cell has one path",
        {"", 0, "aero.print_path"});
  switch (cell) {
    case UnitCell::Octet:
      return octet_path();
    case UnitCell::Bcc:
      return print_path == 1 ? bcc_path_1() : bcc_path_2();
    case UnitCell::Cubic:
      return cubic_path();
    default:
      throw SettingError("no hand-made cell path for the " + to_string(cell) +
                             " cell (periodic has octet, bcc and cubic): plan it with "
                             "aero.method = dynamic or groups",
                         {"", 0, "aero.cell_type"});
  }
}

// The lattice's nodes on the half-cell grid and its struts by their end nodes.
class CellGrid {
 public:
  CellGrid(const Graph& g, double size) : half_(size / 2), origin_(g.bbox().min) {
    for (NodeId n = 0; n < g.nodes.size(); ++n) {
      Half h;
      bool on_grid = true;
      for (int a = 0; a < 3; ++a) {
        const double v = (axis(g.nodes[n], a) - axis(origin_, a)) / half_;
        h[a] = static_cast<int>(std::lround(v));
        on_grid &= std::abs(v - h[a]) < 1e-6 * std::max(1.0, std::abs(v));
      }
      if (on_grid) nodes_.emplace(h, n);
    }
    for (EdgeId e = 0; e < g.edges.size(); ++e) edges_.emplace(key(g.edges[e].a, g.edges[e].b), e);
    const BBox3 b = g.bbox();
    for (int a = 0; a < 3; ++a)
      cells_[a] = std::max(
          1, static_cast<int>(std::ceil((axis(b.max, a) - axis(origin_, a)) / (2 * half_) - 1e-6)));
  }
  int cells(int a) const { return cells_[a]; }
  Vec3 origin() const { return origin_; }
  // The strut between two grid points, or -1.
  long long strut(const Half& p, const Half& q, NodeId& a, NodeId& b) const {
    const auto i = nodes_.find(p), j = nodes_.find(q);
    if (i == nodes_.end() || j == nodes_.end()) return -1;
    a = i->second, b = j->second;
    const auto e = edges_.find(key(a, b));
    return e == edges_.end() ? -1 : static_cast<long long>(e->second);
  }

 private:
  static double axis(Vec3 v, int a) { return a == 0 ? v.x : a == 1 ? v.y : v.z; }
  static std::uint64_t key(NodeId a, NodeId b) {
    if (b < a) std::swap(a, b);
    return (static_cast<std::uint64_t>(a) << 32) | b;
  }
  double half_;
  Vec3 origin_;
  std::map<Half, NodeId> nodes_;
  std::unordered_map<std::uint64_t, EdgeId> edges_;
  std::array<int, 3> cells_{};
};

// One step of the cell path in cell (i, j, k): its struts not printed yet, as pieces (a piece
// ends where a strut is missing, printed or of another material).
void step_pieces(const Graph& g, const CellGrid& grid, const CellStep& s, int i, int j, int k,
                 std::vector<char>& printed, std::vector<Trail>& out) {
  Trail cur;
  auto flush = [&] {
    if (!cur.edges.empty()) out.push_back(std::move(cur));
    cur = Trail{};
  };
  for (std::size_t p = 0; p + 1 < s.points.size(); ++p) {
    auto at = [&](const Half& h) {
      const int z = s.mirror_odd_x && (i % 2) ? 2 - h[2] : h[2];
      return Half{2 * i + h[0], 2 * j + h[1], 2 * k + z};
    };
    NodeId a = 0, b = 0;
    const long long e = grid.strut(at(s.points[p]), at(s.points[p + 1]), a, b);
    if (e < 0 || printed[static_cast<std::size_t>(e)] ||
        (!cur.edges.empty() && g.edges[cur.edges.back()].material != g.edges[e].material)) {
      flush();
      if (e < 0 || printed[static_cast<std::size_t>(e)]) continue;
    }
    const auto edge = static_cast<EdgeId>(e);
    printed[edge] = 1;
    if (cur.nodes.empty()) cur.nodes.push_back(a);
    cur.nodes.push_back(b);
    cur.edges.push_back(edge);
    cur.length += g.edge_length(edge);
  }
  flush();
}

// t followed by u, which starts where t ends.
void append(Trail& t, const Trail& u) {
  t.nodes.insert(t.nodes.end(), u.nodes.begin() + 1, u.nodes.end());
  t.edges.insert(t.edges.end(), u.edges.begin(), u.edges.end());
  t.length += u.length;
}

// Pieces of one step over a layer joined end to start into traces: each trace starts at a piece
// no other piece leads to (then any left, for closed chains), and takes the first unused piece
// that starts where it ends.
std::vector<Trail> chain(const Graph& g, std::vector<Trail> pieces) {
  std::unordered_map<NodeId, std::vector<std::size_t>> starts;
  std::unordered_map<NodeId, int> ends;
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    starts[pieces[p].nodes.front()].push_back(p);
    ++ends[pieces[p].nodes.back()];
  }
  std::vector<char> used(pieces.size(), 0);
  std::vector<Trail> traces;
  auto follow = [&](std::size_t p) {
    used[p] = 1;
    Trail t = std::move(pieces[p]);
    for (bool more = true; more;) {
      more = false;
      for (std::size_t q : starts[t.nodes.back()])
        if (!used[q] &&
            g.edges[pieces[q].edges.front()].material == g.edges[t.edges.back()].material) {
          used[q] = 1;
          append(t, pieces[q]);
          more = true;
          break;
        }
    }
    traces.push_back(std::move(t));
  };
  for (std::size_t p = 0; p < pieces.size(); ++p)
    if (!used[p] && !ends.count(pieces[p].nodes.front())) follow(p);
  for (std::size_t p = 0; p < pieces.size(); ++p)
    if (!used[p]) follow(p);
  return traces;
}

}  // namespace

std::size_t periodic_cell_steps(UnitCell cell, int print_path) {
  return cell_path(cell, print_path).size();
}

PeriodicTrails periodic_trails(const Graph& g, const PeriodicParams& params) {
  const std::vector<CellStep>& path = cell_path(params.cell, params.print_path);
  if (!(params.size > 0)) throw SettingError("cell size must be positive", {"", 0, "aero.cell"});
  if (g.edges.empty()) throw GeometryError("the lattice has no struts to plan");
  const CellGrid grid(g, params.size);
  PeriodicTrails out;
  std::vector<char> printed(g.edges.size(), 0);
  for (int k = 0; k < grid.cells(2); ++k)
    for (const CellStep& s : path) {
      std::vector<Trail> pieces;
      for (int j = 0; j < grid.cells(1); ++j)
        for (int i = 0; i < grid.cells(0); ++i) step_pieces(g, grid, s, i, j, k, printed, pieces);
      for (Trail& t : chain(g, std::move(pieces))) {
        const int mat = g.edges[t.edges.front()].material;
        auto& ts = out.trails.trails;
        if (!ts.empty() && out.material.back() == mat &&
            ts.back().nodes.back() == t.nodes.front()) {
          append(ts.back(), t);
        } else {
          ts.push_back(std::move(t));
          out.material.push_back(mat);
        }
      }
    }
  for (EdgeId e = 0; e < g.edges.size(); ++e)
    if (!printed[e]) {
      const Vec3 a = g.nodes[g.edges[e].a], b = g.nodes[g.edges[e].b], o = grid.origin();
      throw GeometryError(
          fmt::format("({:g},{:g},{:g} - {:g},{:g},{:g}) is not a strut of a {:g} mm {} "
                      "cell with a corner at the lattice's lowest corner ({:g},{:g},{:g}): the "
                      "periodic method repeats one cell's hand-made path, so it plans only a "
                      "lattice of that cell (set aero.cell_type and aero.cell, or plan with "
                      "aero.method = dynamic)",
                      a.x, a.y, a.z, b.x, b.y, b.z, params.size, to_string(params.cell), o.x, o.y,
                      o.z),
          {"", 0, "strut " + std::to_string(e)});
    }
  return out;
}

}  // namespace trellis
