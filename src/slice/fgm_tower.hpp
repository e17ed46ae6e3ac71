// The prime tower's geometry (slice/fgm.hpp, PurgeOptions): a square of side S whose wall loop
// runs half a bead inside its edge and whose inside is cut into lines one bead apart; a purge
// is a zig-zag over consecutive lines, the sparse fill every kSparse-th of the lines left.
#pragma once
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/slice/fgm.hpp"

namespace trellis::tower {

constexpr int kSparse = 4;  // sparse fill: one line in four (gaps of three beads to bridge)

class Square {
 public:
  Square(Vec2 centre, double side, double bead) : c_(centre), s_(side), w_(bead) {}
  Vec2 centre() const { return c_; }
  double side() const { return s_; }
  int lines() const;            // lines inside the wall
  double line_length() const;   // mm
  int lines_for(double length) const;  // lines a zig-zag of at least `length` needs
  std::vector<Vec2> wall() const;      // closed loop (first point repeated)
  // Lines first … first+count-1 as one zig-zag; `across`: lines along Y instead of X.
  std::vector<Vec2> zigzag(int first, int count, bool across) const;
  // Every kSparse-th line from `first` on, as one zig-zag (empty if none is left).
  std::vector<Vec2> sparse(int first, bool across) const;

 private:
  Vec2 c_;
  double s_, w_;
};

// The smallest side ≥ options.side whose layer holds `most` purges of `length` mm each;
// GeometryError beyond 500 mm.
double side_for(std::size_t most, double length, double bead, double min_side);

// The tower's centre: options.x/y, or automatically the first of right, left, back, front of the
// part's footprint (clearance apart) where part and tower fit the bed. GeometryError naming
// the sizes if the tower overlaps the part (+ clearance) or no side fits.
Vec2 place(const BBox2& part, double side, const PurgeOptions& options);

}  // namespace trellis::tower
