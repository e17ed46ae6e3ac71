// The linking stage of every sliced route: a layer's walls, skins and infill, planned as separate
// pieces, become as few continuous paths as the geometry allows, with short travel that stays
// inside the part.
// - Fill lines (open polylines whose cut ends lie on their region's boundary) are joined end to
//   end by pieces of that boundary between neighbouring ends (serpentines, as PrusaSlicer's
//   connected rectilinear infill): connect_fill.
// - Walls are closed loops started at a seam (aligned, nearest, rear or random): seam_vertex.
// - Islands, and each island's chains, are ordered by nearest neighbour + 2-opt
//   (toolpath/order.hpp, the lattice planners' order).
// - Travel inside an island is routed inside its outer wall (Comb) and marked Path::inside, so
//   the writer retracts only for travel that leaves the part (or is longer than
//   retraction.inside_max).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "trellis/geom/regions.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

enum class Seam { Aligned, Nearest, Rear, Random };
Seam seam_from_string(const std::string& name);  // aligned|nearest|rear|random; SettingError
const char* to_string(Seam seam);

struct LinkOptions {
  Seam seam = Seam::Aligned;
  // Fill lines joined along their region's boundary; a connector is at most this many line
  // spacings long (longer gaps along the edge start a new chain).
  bool connect = true;
  double connect_max = 8;
  // Travel routed inside the part: a route inside is taken when it is at most comb_detour times
  // the straight distance (plus one bead); otherwise the travel goes straight and leaves it.
  bool comb = true;
  double comb_detour = 1.2;
  std::uint64_t seed = 1;  // random seams: the same seams for the same seed
};

struct ConnectStats {
  std::size_t lines = 0, chains = 0;
  // Polygons of the region holding a line end: no chain passes from one to another, so at
  // least this many chains (1 when lines exist but no end lies on the boundary).
  std::size_t regions = 0;
  double connector_length = 0;  // mm of boundary added as connectors
};

// Open polylines of one region's fill (their cut ends on the region's boundary, within
// `tolerance`) joined into chains: from a line's end the chain goes along the boundary to the
// neighbouring end on that boundary ring (the next or the previous one, whichever is shorter and
// belongs to an unused line) when that piece of boundary is at most `max_connector` long, then
// along that line, and so on; a chain starts at a line whose ends have the fewest connections
// (the zig-zag of a convex region is one chain). Lines are taken in the order given (sweep
// order), ends not on the boundary are never connected. Every input point is kept; connectors
// lie on the boundary, so chains never leave the region.
std::vector<std::vector<Vec2>> connect_fill(const std::vector<std::vector<Vec2>>& lines,
                                            const Regions& region, double max_connector,
                                            ConnectStats* stats = nullptr, double tolerance = 1e-4);

// Lines of one region's fill (as connect_fill takes them) paired into closed loops: two lines
// side by side whose ends neighbour each other along the boundary on both sides (each piece of
// boundary at most `max_connector`) make a loop (one line, the boundary to the other, back
// along it, the boundary to the start: a racetrack); a run of such lines is paired from one end,
// so a run of k lines makes k/2 loops (an odd run leaves the shorter of its end lines). Returns
// the loops (first == last); the lines left over go to *rest in the order given, and the runs of
// an odd number of lines (their lines' indices in order, side by side) to *odd_runs. Loops lying
// side by side can be joined into one by a bridge (two short cross connectors for two short
// spans), which no serpentine's ends allow.
std::vector<std::vector<Vec2>> pair_fill(const std::vector<std::vector<Vec2>>& lines,
                                         const Regions& region, double max_connector,
                                         std::vector<std::vector<Vec2>>* rest,
                                         std::vector<std::vector<std::size_t>>* odd_runs = nullptr,
                                         double tolerance = 1e-4);

// The vertex a closed ring (first point not repeated) starts at. Aligned: the sharpest concave
// corner sharper than 30° (a seam hides there), else the sharpest convex corner sharper than
// 60°, else the rear-most vertex (largest y, then smallest x), so similar layers put their
// seams in the same place without knowing each other. Nearest: the vertex nearest `from`.
// Rear: the rear-most vertex. Random: a vertex drawn from (seed, key).
std::size_t seam_vertex(const std::vector<Vec2>& ring, Seam seam, Vec2 from, std::uint64_t seed,
                        std::uint64_t key);

// Travel inside a region (an island's outline): straight where the straight line stays inside,
// else along the boundary of `route` (a region inside `inside`, e.g. the outer wall's centre
// line) around what is in the way, shortened where it can be.
class Comb {
 public:
  Comb(Regions inside, Regions route);
  // Whether the straight travel a-b stays inside.
  bool straight(Vec2 a, Vec2 b) const;
  // A route from a to b inside (the points between a and b, empty when straight); false when
  // there is none or it is longer than max_length.
  bool route(Vec2 a, Vec2 b, double max_length, std::vector<Vec2>& via) const;
  bool contains(Vec2 p) const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

// One island of a layer as the slicer planned it, for link_layer: wall loops in print order by
// level (index 0 printed first; each level a set of closed rings), fill lines per region.
struct IslandPieces {
  Polygon2 outline;  // travel within it is inside the part
  // The outer wall's centre line (the outline offset by -bead_width / 2), which travel inside is
  // routed along; empty: made here from the outline.
  Regions route;
  double bead_width = 0.4;
  std::vector<std::vector<std::vector<Vec2>>> walls;  // [level][ring] closed rings
  struct Fill {
    PathRole role = PathRole::Infill;
    Regions region;                        // the lines' region (their ends on its edge)
    std::vector<std::vector<Vec2>> lines;  // open polylines, sweep order
    std::vector<std::vector<Vec2>> loops;  // closed rings printed as loops (concentric)
    double spacing = 0.4;                  // line spacing (connectors up to connect_max of it)
  };
  std::vector<Fill> fills;
};

struct LinkStats {
  std::size_t starts = 0;       // paths (each an extrusion start)
  std::size_t lower_bound = 0;  // wall loops + fill regions: the fewest starts with every wall
                                // a loop of its own
  std::size_t travels = 0, inside_travels = 0;     // travel moves, those kept inside the part
  double travel_length = 0, connector_length = 0;  // mm
  std::size_t fill_lines = 0, fill_chains = 0;
  void add(const LinkStats& o);
};

// The islands linked into paths appended to `paths` (z for every point; role, width and height
// from the pieces), starting from `cursor` (where the nozzle is: updated to the last end).
// `from_inside`: the cursor lies inside the part on this layer too (a layer change inside it).
// `key` seeds random seams (e.g. the layer index).
void link_layer(const std::vector<IslandPieces>& islands, const LinkOptions& options, double z,
                double layer_height, std::uint64_t key, Vec2& cursor, bool cursor_known,
                std::vector<Path>& paths, LinkStats& stats);

}  // namespace trellis
