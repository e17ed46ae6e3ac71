// Gradient-informed slicing of functionally graded designs (FGM paper, §3.2.3 and §3.5): the
// first material's volume fraction f ∈ [0, 1] is cut into a palette of N colours (bands of
// width α = 1/N, each printed at its mid value); every layer's outline is cut into colour faces
// along iso-contours of f; Strategy 2 either (the paper's, face order and tool changers) offsets
// each face inward by half a bead and fills it completely (rings, then 100 % rectilinear inside
// them along the iso-lines, or concentric rings), each face's pieces chained into few beads, face
// by face in palette order (reversed every other layer), or (path order on a machine that changes
// the mixture along a bead) fills each island whole — rings around its outline, lines along the
// iso-lines inside them, joined into few beads — and cuts the beads at the faces' edges as
// Strategy 1 does; each path carries its mixture (written as M165 by the G-code writer).
//
// Two- and three-material designs (`fgrade` with two or three fractions).
#pragma once
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/slice/slice.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// Two materials: N bands of the first material's fraction (width α = 1/N), each printed at its
// mid value. Three materials (FGM paper Fig. 12): the mixture triangle cut into d² triangles
// (colours = d²: 4, 9, 16, …; α = 1/d), each printed at its centroid. Colours are numbered in
// print order: along the bands, or along a snake through the triangle's rows whose neighbours
// share an edge, so successive colours change the mixture least.
struct Palette {
  int colors = 8;
  int materials = 2;  // 2 or 3
  // Two materials, a tool changer's palette: colour k printed at k/(N-1) (tool k of N holds
  // that fixed mix, from pure B to pure A), its band reaching halfway to its neighbours, so the
  // end colours are the pure materials and every colour is exactly what a tool prints.
  bool ends = false;
  // Throws SettingError naming the problem (colour count, material count).
  void check() const;
  int divisions() const;      // three materials: d (colors = d²)
  double band() const;        // α
  double level(int k) const;  // two materials: edge between bands k-1 and k (k = 1 … N-1)
  double mid(int k) const { return mixture(k)[0]; }
  // Colour k's commanded mixture (one fraction per material, summing to 1).
  std::vector<double> mixture(int k) const;
  int color_of(double f) const;                              // two materials
  int color_of(const std::vector<double>& fractions) const;  // two or three
  // The largest |design fraction − commanded fraction| of any material inside one colour:
  // α/2 for bands, 2α/3 for triangles (a corner against the centroid).
  double error_bound() const;
  // Three materials: colour k's triangle as band indices of the three fractions (i ≤ a·d < i+1,
  // …), pointing up (i + j + k = d − 1) or down (= d − 2).
  struct Cell {
    int i = 0, j = 0, k = 0;
    bool up = true;
  };
  Cell cell(int k) const;
  int color_of_cell(int i, int j, bool up) const;  // the colour of triangle (i, j, up)
};

// One colour's part of a layer: where the first material's fraction lies in band `color`.
struct ColorFace {
  int color = 0;
  Regions region;
};

// The faces of the outline at z: face k = {outline, colour k}, from the contours of
// max(f - level, distance outside the box) at the band edges of each material's fraction f
// (closed by construction, whatever the iso-lines of f do), their chords refined onto the
// iso-lines until a chord's middle is within chord_tolerance × (the band) of its level. Throws
// GeometryError if the design has fewer materials than the palette.
std::vector<ColorFace> color_faces(const Field& field, Evaluator& evaluator, double z,
                                   const Regions& outline, const Palette& palette,
                                   double resolution, double chord_tolerance = 1e-4);
// The same zones over the rectangle [lo, hi], not cut by any outline (Strategy 1 cuts paths
// that already lie inside the outline).
std::vector<ColorFace> palette_zones(const Field& field, Evaluator& evaluator, double z, Vec2 lo,
                                     Vec2 hi, const Palette& palette, double resolution,
                                     double chord_tolerance = 1e-4);

// The rectangle [lo, hi] cut at increasing levels of the first material's fraction: slab k =
// {levels[k-1] < f <= levels[k]} (slab 0 below the first level, the last above the last level).
std::vector<Regions> level_slabs(const Field& field, Evaluator& evaluator, double z, Vec2 lo,
                                 Vec2 hi, const std::vector<double>& levels, double resolution,
                                 double chord_tolerance = 1e-4);

// Strategy 1's print order (fgm.order). Paths: the planar slicer's order kept, each path cut
// where it crosses a colour face's edge into pieces that continue one bead (Path::joined), each
// with its colour's mixture; the writer issues every change the look-ahead earlier along the
// printed path, and no prime tower is printed (a change along a bead is one band, the gradient's
// own; the paper's purge is for the abrupt changes between faces). A tool changer cannot change
// inside a bead: its pieces are grouped by tool (palette order) and chained nearest first within
// a tool, the tower priming each tool. Faces: the paper's Algorithm 2, colour by colour in
// palette order, the planar order within a colour, a purge before each colour change.
// Strategy 2 in path order (not on a tool changer, not concentric): see plan_fgm_strategy2.
enum class FgmOrder { Paths, Faces };
const char* to_string(FgmOrder order);

struct FgmOptions {
  Palette palette;
  FgmOrder order = FgmOrder::Paths;
  bool tool_changer = false;  // the colours are tools (FgmOrder::Paths groups pieces by tool)
  double bead_width = 0.4;
  double layer_height = 0.2;
  double resolution = 0.1;  // XY grid of the outline contours (mm), for reference
  // XY grid of the material iso-contours (mm): crossings are refined on the field, so the grid
  // only has to be finer than the features of the gradient (contour chords between grid cells
  // deviate by c²/8ρ: 6 µm for 1 mm cells on a 20 mm curvature radius); at least half a bead.
  double material_resolution = 1.0;
  bool concentric = false;  // concentric fill instead of 100 % rectilinear (face by face)
  // Strategy 2 face by face: rectilinear lines reach this share of a bead into the ring (in path
  // order the lines reach the innermost ring's bead)
  double fill_overlap = 0.25;
  // Strategy 2, rectilinear: rings around each colour face (face order) or each island's
  // outline (path order) before its lines (the paper's palette plates: 3 perimeters, §7.5)
  int perimeters = 3;
  bool gap_fill = true;  // Strategy 2 face by face: lines through what the beads leave uncovered
  // Strategy 2's rectilinear lines run along the local iso-line (perpendicular to the gradient,
  // as the paper prints), directions sampled on the material grid: a polygon of a face's fill
  // whose directions agree (the mean resultant length of the doubled angles at least
  // orient_agree, i.e. within about ±13° at 0.9) is hatched at their mean; a curved one is cut
  // into sectors of orient_sector degrees, each part hatched at its sector's direction (within
  // half a sector of the iso-line) and the lines continued across the sectors' edges into lanes;
  // fixed_angle: at angle_deg instead, +90° every layer.
  bool fixed_angle = false;
  double angle_deg = 45;
  double orient_sector = 15;
  double orient_agree = 0.9;
  double zipper = 0;  // Strategy 1: overlap band width β (fraction 0..1 of the gradient)
  // Pieces (Strategy 1) and paths (Strategy 2) shorter than this (mm; FGM paper §3.4.3: ~5 mm
  // on desktop FFF) are joined to a piece of another colour they touch end to end, printed in
  // its colour (one colour change fewer), only where the design along the piece stays within the
  // palette's error bound (α/2) of that colour; the others are kept and counted. 0 = off.
  double min_segment = 5;
  // Sharding (job/plate.hpp): the outlines given are the part's printed layers first_layer,
  // first_layer + 1, … (Strategy 1: the planar layers carry their own z); each layer is planned
  // as in the whole part (z, the order reversed every other layer, the fixed angle).
  std::size_t first_layer = 0;
};

// The prime (purge) tower of Strategy 1 and tool changers: one square tower per print, beside
// the part, printed on every layer from the first up to the last layer with a purge so each
// tower layer stands on the one below. Per layer: a wall loop and sparse lines in the colour
// already loaded, then before each colour change whose mixture differs from the previous by
// more than `threshold` a dense zig-zag of at least L = V_melt / A (Appendix A.1, A = h(w-h) +
// πh²/4) in the new colour, lines one bead apart (alternating direction layer by layer). The
// side is the smallest (≥ `side`) whose layer holds its layer's purges.
struct PurgeOptions {
  double melt_volume = 0;  // V_melt (mm³); 0 = no tower
  double threshold = 0;    // mixture change (0..1) that needs a purge; 0 = every change
  bool automatic = true;   // place beside the part on free bed space; false: centre at (x, y)
  double x = -20, y = 0;   // tower centre when not automatic (design coordinates, mm)
  double side = 10;        // smallest tower side (mm)
  double clearance = 5;    // gap between the tower and the part's footprint (mm)
  // The bed, as the writer places the toolpath on it: centred (the box of part and tower on
  // the bed centre) or design coordinates + offset; bed_x = 0: no bed check.
  double bed_x = 0, bed_y = 0;
  bool circular = false;       // round bed of diameter bed_x
  bool origin_centre = false;  // design (0, 0) + offset is the bed's centre, not its corner
  bool centred = true;
  double offset_x = 0, offset_y = 0;
  double speed = 0;  // print speed (mm/s) for the per-colour time estimate; 0 = none
  std::vector<double> density{1.24, 1.24, 1.24};  // g/cm³ per material, for masses
};

// One colour's share of the tower (§4.1 reports material and time per colour).
struct TowerColour {
  int color = 0;
  std::vector<double> mixture;
  std::size_t purges = 0;
  double length = 0;  // mm of tower path printed in this colour (purges, walls, sparse lines)
  double volume = 0;  // mm³ (capsule bead)
  double mass = 0;    // g (mixture-weighted density)
  double time = 0;    // s at the print speed
};

struct TowerStats {
  bool built = false;
  double x = 0, y = 0,
         side = 0;  // centre and side (design coordinates, mm; a strip: its long side)
  double size_x = 0, size_y = 0;  // X and Y extent (a square: both = side)
  std::size_t layers = 0;         // tower layers (first layer up to the last purge)
  double purge_path = 0;          // L of one purge (mm, Eq. A.1)
  double length = 0, volume = 0, mass = 0, time = 0;
  std::vector<TowerColour> colours;  // palette order, colours with tower path only
};

struct FgmStats {
  std::size_t faces = 0, paths = 0, colour_changes = 0;
  // FgmOrder::Paths: pieces that continue the previous piece's bead (paths - joined = beads), and
  // bead starts whose mixture differs from the previous bead's end by more than one palette step
  // (after a travel; where the face order would purge, the look-ahead places them too).
  std::size_t joined = 0, abrupt_changes = 0;
  double shortest_path = 0;  // mm
  // FgmOptions::min_segment: pieces under it joined to a neighbour (short_merged); pieces printed
  // under it (short_kept, after joining); short pieces whose merge the error bound refused (a
  // touching neighbour exists but its colour is further than α/2 from the design somewhere
  // along the piece; counted before pieces of one colour are joined, so it may exceed
  // short_kept); the others touch no piece of another colour end to end.
  double min_segment = 0;
  std::size_t short_merged = 0, short_kept = 0, short_kept_bound = 0;
  // Of short_kept, those that are a whole bead (a start and a stop, the paper's concern); the
  // others, in path order, are runs of one mixture inside a longer bead.
  std::size_t short_beads = 0;
  std::size_t purges = 0;   // Strategy 1: purges printed into the tower
  double purge_length = 0;  // mm of purge path (the dense part of the tower)
  double purge_volume = 0;  // mm³ (capsule bead, Appendix A.1)
  TowerStats tower;         // the whole tower: purges, walls and sparse lines
  // Gradient error: the largest |design fraction - commanded fraction| over the materials, at
  // every point of every graded path (purge blocks excluded), the design sampled at the layer's
  // slicing plane; error_bound is the palette's (α/2, or 2α/3 for three materials). The mean is
  // weighted by length (each point stands for half of each segment it ends), so finely divided
  // stretches do not outweigh long ones; error_length is the printed length it covers (mm).
  double error_mean = 0, error_max = 0, error_bound = 0;
  std::size_t error_samples = 0;
  double error_length = 0;
  // > 0: the errors are of the mixtures as deposited with the writer's mixing look-ahead of
  // this many mm (deposit_start_mixtures), not as planned.
  double error_lookahead = 0;
  int materials = 2;
  double band = 0;                          // α
  int colours_used = 0, colours_total = 0;  // palette colours some part path prints
  int quantized_from = 0;  // tool changers: the colours asked for, when more than the tools
};

// The minimum segment length (FgmOptions::min_segment) on one layer's graded pieces (colours[i]
// is paths[i]'s palette colour; design sampled at z_design): each piece shorter than `min`
// whose end coincides with an end of a piece of another colour and the same role is joined to
// the touching piece whose colour is nearest the design mixture along it, if the design along
// the piece (sampled every 0.1 mm) stays within palette.error_bound() of that colour; merged
// pieces are removed. Adds to stats.short_merged / short_kept / short_kept_bound.
void merge_short_pieces(std::vector<Path>& paths, std::vector<int>& colours, Evaluator& evaluator,
                        double z_design, const Palette& palette, double min, FgmStats& stats);

// The shortest piece of one mixture in a layer: a path and the paths joined to it in the same
// mixture count as one (Strategy 2 in path order splits a piece where its flow changes); the
// report's shortest segment. Infinity for a layer without paths.
double shortest_piece(const Layer& layer);

// The mixtures a mixing hotend deposits when the writer issues each change `lookahead` mm of
// printed path early (machine/mixing_lag.hpp: what the G-code reads back as): the changes planned
// within the first `lookahead` mm are all issued at the start, so every graded path starting
// there is deposited in the mixture the last of them plans; later paths as planned. Returns
// whether any mixture changed.
bool deposit_start_mixtures(Toolpath& toolpath, double lookahead);

// Fills stats.error_* for a graded toolpath (layer i planned from outline zs[i]).
void measure_gradient_error(const Field& field, const Toolpath& toolpath,
                            const std::vector<LayerOutline>& layers, double layer_height,
                            FgmStats& stats);
// The same sums layer by layer (streamed slicing adds them in layer order, as the whole
// measurement does): toolpath layer i at z is the part's layer round(z / h) - 1, read from
// layers[that - first_layer].
struct GradientErrorSum {
  double sum = 0, max = 0;  // sum: Σ error × length (mm)
  std::size_t n = 0;
  double length = 0;  // Σ length (mm)
};
// One layer's sums, the design sampled at z_design (gradient_error_sums' step per layer).
GradientErrorSum layer_gradient_error(Evaluator& evaluator, const Layer& layer, double z_design);
std::vector<GradientErrorSum> gradient_error_sums(const Field& field, const Toolpath& toolpath,
                                                  const std::vector<LayerOutline>& layers,
                                                  double layer_height, std::size_t first_layer = 0);

// Whether `path` starts a bead (is not joined) with a mixture more than one palette step (α) from
// `before`, the mixture of the part path printed before it (FgmStats::abrupt_changes).
bool abrupt_start(const std::vector<double>& before, const Path& path, const Palette& palette);

// L of Appendix A.1: path length that extrudes `volume` at layer height h and bead width w.
double purge_length(double volume, double layer_height, double bead_width);

// Strategy 1: the planar slicer's walls, skins and infill (`planar`, one layer per outline) cut
// by the colour faces; each piece keeps its role and gets its colour's mixture. In face order
// (FgmOptions::order) pieces are printed colour by colour in palette order (reversed every other
// layer), a purge into the prime tower before each colour change above the threshold
// (PathRole::Purge; GeometryError if the tower fits nowhere on the bed beside the part). In path
// order the planar order stays, each path's pieces joined into its bead (no tower, `purge`
// unused), or on a tool changer grouped by tool, chained nearest first, with the tower. With
// `zipper` β > 0, pieces in the band |f - k/N| < β/2 around each colour boundary alternate (in
// planar order) between the two colours, so the materials interlock across the boundary (the
// paper's zippering, Fig. 8-9).
Toolpath plan_fgm_strategy1(const Field& field, const std::vector<LayerOutline>& layers,
                            const Toolpath& planar, const FgmOptions& options,
                            const PurgeOptions& purge, FgmStats* stats = nullptr);

// The prime tower for a graded toolpath whose paths are in print order, each with its palette
// colour's mixture (Strategy 1, or Strategy 2 on a tool changer): a purge before every change
// above the threshold, walls and sparse lines below the last one (PurgeOptions). Fills
// stats.purges, purge_length, purge_volume and tower; GeometryError if no bed space fits.
void add_prime_tower(Toolpath& toolpath, const FgmOptions& options, const PurgeOptions& purge,
                     FgmStats& stats);

// Strategy 2 over the layer outlines (from slice_field). Paths carry mixture {m, 1-m} with m the
// band's mid value of the first material.
// Face order, a tool changer, or concentric: the paper's fill, each face on its own: its rings,
// lines and gap fill chained into few beads (rings whole, ring to ring; lines into
// serpentines), the faces colour by colour in palette order (reversed every other layer), or on
// a tool changer in path order island by island nearest first.
// Path order otherwise (a mixing hotend or a temperature-graded filament: the mixture changes
// along a bead): each island filled whole (src/slice/fgm_outline.hpp): fgm.perimeters rings
// around its outline, inside them level lines a bead apart of a potential whose gradient follows
// the material iso-lines (perpendicular to the gradient, wider or narrower where they spread or
// bunch: Path::flow), paired into loops and bridged with the inner rings into few beads (one per
// island where every run of lines pairs); the beads cut where they cross a colour zone's edge
// into joined pieces with their colour's mixture (Strategy 1's cutter, short runs merged within
// the bound), so every point's mixture is within the palette's bound by construction and the
// outline is filled once.
// Travel between beads is routed inside the part where it can be (Path::via, inside).
Toolpath plan_fgm_strategy2(const Field& field, const std::vector<LayerOutline>& layers,
                            const FgmOptions& options, FgmStats* stats = nullptr);

}  // namespace trellis
