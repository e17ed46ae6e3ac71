// The prime tower's geometry (slice/fgm.hpp, PurgeOptions): a block (a square, or a strip where
// no square fits) whose wall loop runs half a bead inside its edge and whose inside is cut into
// lines one bead apart; a purge is a zig-zag over consecutive lines, the sparse fill every
// kSparse-th of the lines left.
#pragma once
#include <map>
#include <optional>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/slice/fgm.hpp"

namespace trellis::tower {

constexpr int kSparse = 4;  // sparse fill: one line in four (gaps of three beads to bridge)

// The tower block: sx × sy mm around its centre. Lines run along X (`across` false: spaced in
// Y, sy − 2w across) or along Y (`across` true), alternating by layer so each layer's lines
// bridge the one below.
class Block {
 public:
  Block(Vec2 centre, double sx, double sy, double bead) : c_(centre), sx_(sx), sy_(sy), w_(bead) {}
  Vec2 centre() const { return c_; }
  double size_x() const { return sx_; }
  double size_y() const { return sy_; }
  int lines(bool across) const;                     // lines inside the wall
  double line_length(bool across) const;            // mm
  int lines_for(double length, bool across) const;  // lines a zig-zag of at least `length` needs
  // Whether `most` purges of `length` mm fit one layer, in both line directions.
  bool holds(std::size_t most, double length) const;
  std::vector<Vec2> wall() const;  // closed loop (first point repeated)
  // Lines first … first+count-1 as one zig-zag.
  std::vector<Vec2> zigzag(int first, int count, bool across) const;
  // Every kSparse-th line from `first` on, as one zig-zag (empty if none is left).
  std::vector<Vec2> sparse(int first, bool across) const;

 private:
  Vec2 c_;
  double sx_, sy_, w_;
};

// The smallest side ≥ options.side whose layer holds `most` purges of `length` mm each;
// GeometryError beyond 500 mm.
double side_for(std::size_t most, double length, double bead, double min_side);

// The tower's centre: options.x/y, or automatically the first of right, left, back, front of the
// part's footprint (clearance apart) where part and a sx × sy tower fit the bed. GeometryError
// naming the sizes if the tower overlaps the part (+ clearance) or no side fits.
Vec2 place(const BBox2& part, double sx, double sy, const PurgeOptions& options);

// The tower of a print whose busiest layer has `most` purges of `length` mm: the smallest square
// (side_for), placed by `place`; where no square fits beside the part, the smallest-area
// rectangle along one of its sides that holds them (a long strip fits where a square cannot).
// GeometryError when neither fits, with the area the purges need.
Block plan_tower(const BBox2& part, std::size_t most, double length, double bead,
                 const PurgeOptions& options);

// The prime tower of a print built in two passes over its layers in order: observe() every
// layer (which paths purge, the footprint, the busiest layer), plan() the block, then add()
// every layer from index 0 (the tower's wall, sparse lines and purges inserted before the paths
// that change colour) and finish() the statistics. add_prime_tower runs both passes on a whole
// toolpath; streamed slicing observes layers as they are planned and adds the tower as it reads
// them back, so neither holds the print.
class PrimeTower {
 public:
  PrimeTower(const FgmOptions& options, const PurgeOptions& purge);
  void observe(const Layer& layer);
  // Places and sizes the block into stats.tower (GeometryError where no bed space fits); false
  // when nothing purges (no tower).
  bool plan(FgmStats& stats);
  void add(std::size_t index, Layer& layer);
  // stats.purges, purge_length, purge_volume and the tower's per-colour table.
  void finish(FgmStats& stats) const;

 private:
  int colour_of(const Path& p) const {
    return p.mixture.empty() ? -1 : o_.palette.color_of(p.mixture);
  }
  bool purges(int before, int after) const;  // a change above the purge threshold
  Path tower_path(std::vector<Vec2> points, int colour, double z);

  FgmOptions o_;
  PurgeOptions purge_;
  double length_ = 0;  // of one purge
  // observe()
  BBox2 part_;
  std::size_t most_ = 0, observed_ = 0;
  long last_purge_layer_ = -1;
  int seen_ = -1, first_colour_ = -1;
  // add()
  std::optional<Block> block_;
  int last_ = -1;
  std::map<int, TowerColour> colours_;
  double purge_length_ = 0;
  std::size_t purges_ = 0;
};

}  // namespace trellis::tower
