// Graded slicing's steps shared by its files (src/slice/fgm*.cpp): colour faces
// (fgm_faces.cpp), the material balance on a bead raster (fgm_balance.cpp), path order's zones
// and cutting (fgm_path_zones.cpp), Strategy 2 face by face (fgm_face_layer.cpp) and Strategy 1
// face by face (fgm_bands.cpp); plan_fgm_strategy1 and plan_fgm_strategy2 (fgm.cpp) run them.
#pragma once
#include <cstddef>
#include <memory>
#include <vector>

#include "fgm_order.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/fgm.hpp"

namespace trellis::fgm {

// --- colour faces (fgm_faces.cpp) ---

// A palette needs a design with as many materials (an fgrade node).
void require_materials(const Field& field, const Palette& palette);
// The box of the regions' outer rings, padded by `pad`.
void padded_box(const Regions& r, double pad, Vec2& lo, Vec2& hi);
// {f <= levels[k]} over the rectangle, one region per level, for one material's fraction.
std::vector<Regions> below_sets(Evaluator& ev, double z, Vec2 lo, Vec2 hi, std::size_t material,
                                const std::vector<double>& levels, double resolution,
                                double chord_tolerance);

// --- material balance (fgm_balance.cpp) ---

// The layer's bead raster for Strategy 2: pixels an eighth of a bead wide over the faces' box
// (a bead of margin); null for a layer over 5 m².
std::unique_ptr<BeadRaster> layer_raster(const std::vector<ColorFace>& faces, double bead);
// The parts of `line` whose bead mostly adds area not yet printed, painted into the raster.
std::vector<std::vector<Vec2>> keep_uncovered(const std::vector<Vec2>& line, BeadRaster& raster,
                                              double bead, double min_len);
// Gap fill: lines a bead apart over the groups of each face's uncovered pixels, clipped to
// where a bead stays inside the face (`inners`).
std::vector<std::vector<std::vector<Vec2>>> gap_lines(const std::vector<ColorFace>& faces,
                                                      const std::vector<Regions>& inners,
                                                      const BeadRaster& raster, double bead);

// --- path order (fgm_path_zones.cpp) ---

// Strategy 1's zones: a colour's band, or with zippering the overlap band around a colour
// boundary, where pieces alternate between the two neighbouring colours.
struct Zone {
  int a = 0, b = 0;       // colours (a == b: a plain face)
  std::size_t count = 0;  // pieces so far (for alternating)
};

// The zones a path order cuts paths at, over [zlo, zhi] at z: zone k lies between level k-1
// and level k (two materials: of the first fraction, with zippering β > 0 the overlap bands
// around each band edge as zones of their own; three: the palette's triangles, found by
// splitting on the first, second and third fractions), below[m][k] = {fraction m <= level k}.
struct PathZones {
  std::vector<double> levels;
  std::vector<Zone> zones;
  std::vector<Regions> below[3];
};
PathZones path_zones(Evaluator& ev, double z, Vec2 zlo, Vec2 zhi, const FgmOptions& o, double beta);

// One layer in path order: the planar paths cut where they cross the zones' edges, each run
// coloured by the design at its middle, short runs merged, a tool changer's pieces grouped.
std::vector<Piece> path_order_layer(const Layer& planar, const std::vector<Regions> (&below)[3],
                                    const std::vector<double>& levels, std::vector<Zone>& zones,
                                    Evaluator& ev, double z, std::size_t g, const FgmOptions& o,
                                    Vec2 zlo, Vec2 zhi, FgmStats& shorts);
// Strategy 2 in path order, one layer: each island filled whole, the beads cut at the zones.
void outline_layer(Evaluator& ev, const LayerOutline& lo, std::size_t g, const FgmOptions& o,
                   Layer& layer, std::vector<int>& colours, std::size_t& faces, FgmStats& shorts);

// --- face by face ---

// Strategy 2 face by face (the paper's), one layer (fgm_face_layer.cpp): the layer's colour
// faces each ringed and filled along the iso-lines, the material balanced, chained into beads.
void face_layer(const Field& field, Evaluator& ev, const LayerOutline& lo, std::size_t g,
                const FgmOptions& o, Layer& layer, std::vector<int>& colours, std::size_t& faces,
                FgmStats& shorts);
// Strategy 1 face by face, one layer (fgm_bands.cpp): the planar paths split among the zones,
// coloured, short pieces merged, colour by colour in palette order. Counts the zones some path
// crosses into `faces`.
std::vector<Piece> band_layer(const Layer& planar, PathZones& pz, Evaluator& ev, double z,
                              std::size_t g, const FgmOptions& o, std::size_t& faces,
                              FgmStats& shorts);

}  // namespace trellis::fgm
