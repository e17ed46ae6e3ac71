// Internal: the nodes of the field expression tree and the per-thread evaluation state.
#pragma once
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "trellis/field/field.hpp"

namespace mu {
class Parser;
}

namespace trellis {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

// Variables a user expression sees; one block per compiled parser.
struct ExprVars {
  double x = 0, y = 0, z = 0, rho = 0, phic = 0, r = 0, theta = 0, phis = 0, d = 0;
  // polar: also rho, phic, r, theta, phis (an atan2, an acos, two roots: only when used).
  void set(Vec3 p, double distance, bool polar = true);
};

class ExprProgram;

struct CompiledExpr {
  std::unique_ptr<mu::Parser> parser;
  ExprVars vars;
  // The expression compiled from muparser's bytecode (expr_program.hpp): eval() runs it. Null
  // when a token has no translation there; then muparser evaluates.
  std::unique_ptr<ExprProgram> program;
  bool uses_polar = true, uses_d = true;  // from muparser's list of the variables used
  double eval(Vec3 p, double distance = 0);
  // The values at n points (distances d[i], or 0 when d is null): the same numbers as eval()
  // point by point, without a lookup or an allocation per point.
  void eval(const Vec3* p, const double* d, std::size_t n, double* out);
  CompiledExpr();
  ~CompiledExpr();
};

// The nodes (xs[i], ys[j], z) of a grid in a plane of constant z, row by row (index j·w + i).
struct GridPlane {
  const double* xs;
  std::size_t w;
  const double* ys;
  std::size_t rows;
  double z;
  std::size_t size() const { return w * rows; }
};

// Sines and cosines of recent arguments (direct-mapped by the argument's bits): TPMS bounds ask
// for the centres of grid blocks, whose coordinates repeat along a row and a column. 16 k slots
// (384 KB, within a core's L2): a PBF layer asks for a few thousand distinct arguments (its
// grids' columns and rows and its blocks' centres), which thrashed 4 k direct-mapped slots
// (2-3% of the direct route's time on the shipped example).
struct SinCosMemo {
  static constexpr int kBits = 14;
  struct Entry {
    std::uint64_t key = ~std::uint64_t{0};  // the argument's bits (this one is a NaN: never kept)
    double s = 0, c = 0;
  };
  std::vector<Entry> slots;  // allocated on first use (an evaluator made for a few points skips it)
};

struct Evaluator::State {
  // Scratch buffers by tree depth, so batch evaluation allocates once.
  std::vector<std::vector<double>> values;
  std::vector<std::vector<Vec3>> points;
  std::vector<std::vector<Vec3>> grid_points;  // eval_grid's default, by depth
  SinCosMemo sincos;
  std::unordered_map<const Expression*, std::unique_ptr<CompiledExpr>> exprs;
  const std::vector<std::string>* materials = nullptr;
  // Per-node, per-thread caches (e.g. a grid accessor), created on first use.
  std::unordered_map<const void*, std::shared_ptr<void>> caches;
  int material_index(const std::string& name) const;
  std::vector<double>& value_buffer(std::size_t depth, std::size_t n);
  std::vector<Vec3>& point_buffer(std::size_t depth, std::size_t n);
  std::vector<Vec3>& grid_point_buffer(std::size_t depth, std::size_t n);
  CompiledExpr& expr(const Expression& e);
  // The expressions of one node (owner) in one program, their shared subexpressions evaluated
  // once; null when one of them has no translation.
  ExprProgram* program(const void* owner, const std::vector<Expression>& list);
};
using EvalState = Evaluator::State;

class FieldNode {
 public:
  virtual ~FieldNode() = default;
  // Values at n points; `depth` indexes the scratch buffers this node may use (depth and deeper).
  virtual void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
                    std::size_t depth) const = 0;
  // Values at the nodes of a grid in a plane (GridPlane): the same numbers as eval at those
  // points. Default: the points listed, eval; a TPMS combines per-column and per-row sines,
  // sheets, CSG and clip boxes combine their children's grids.
  virtual void eval_grid(const GridPlane& g, double* out, EvalState& s, std::size_t depth) const;
  // The analytic gradient at the grid's nodes (the same numbers as gradients() there); false
  // where the node has no grid path (the caller falls back to points).
  virtual bool gradients_grid(const GridPlane& g, Vec3* out, EvalState& s,
                              std::size_t depth) const {
    return false;
  }
  // Conservative value interval over a box. Default: centre value ± Lipschitz · half diagonal.
  virtual Interval bound(const BBox3& box, EvalState& s, std::size_t depth) const;
  virtual double lipschitz() const { return 1.0; }
  // A period of the field along each axis (f(p + P·e) = f(p)), 0 along axes it does not repeat.
  virtual Vec3 period() const { return {0, 0, 0}; }
  // f(−p) = parity · f(p) everywhere (the origin a centre of symmetry): 1 even, −1 odd, 0 where
  // none is known.
  virtual int inversion_parity() const { return 0; }
  // Whether the value outside the solid is at least the true distance to it (exact distances:
  // primitives, rigid transforms of them, sharp unions of them). Used for cheap bounds.
  virtual bool exact_outside() const { return false; }
  // Analytic gradient if the node has one (TPMS, transforms of it); false → finite differences.
  virtual bool gradient(Vec3 p, Vec3& g, EvalState& s, std::size_t depth) const { return false; }
  // The value and the analytic gradient together (TPMS: from one set of sines); false → the
  // caller evaluates them apart. Must give the same numbers as value() and gradient().
  virtual bool value_gradient(Vec3 p, double& v, Vec3& g, EvalState& s, std::size_t depth) const {
    return false;
  }
  // The same at n points (TPMS reuses sines along grid rows as in eval).
  virtual bool gradients(const Vec3* p, Vec3* g, std::size_t n, EvalState& s,
                         std::size_t depth) const {
    for (std::size_t i = 0; i < n; ++i)
      if (!gradient(p[i], g[i], s, depth)) return false;
    return true;
  }
  virtual BBox3 extent() const = 0;
  // Adds this node's contribution to fractions (indexed by the design's material table).
  virtual void fractions(Vec3 p, double* out, EvalState& s, std::size_t depth) const;
  // The same at n points, out[i·m + k] for material k of m (added to, as above). Default: point
  // by point; fgrade evaluates each expression over the whole row.
  virtual void fractions(const Vec3* p, std::size_t n, std::size_t m, double* out, EvalState& s,
                         std::size_t depth) const;
  virtual bool has_expressions() const;
  // Sets the process values (fprocess) at p that are still NaN; default: the first child's.
  virtual void process(Vec3 p, ProcessValues& out, EvalState& s, std::size_t depth) const;
  virtual bool has_process() const;

  double value(Vec3 p, EvalState& s, std::size_t depth) const {
    double v;
    eval(&p, &v, 1, s, depth);
    return v;
  }

  std::vector<std::shared_ptr<const FieldNode>> children;
  std::string material;  // a leaf's material name, empty if none
  // Names this node itself assigns fractions to (a leaf's material, an fgrade's list), for the
  // table; collect_materials adds those of the whole tree, in order, without recursing (a chain
  // of transforms may be as deep as the caller likes).
  virtual void own_materials(std::vector<std::string>& table) const;
  void collect_materials(std::vector<std::string>& table) const;
};

using NodePtr = std::shared_ptr<const FieldNode>;

// A node that only adds properties to its one child (fgrade's materials, fprocess's process
// values): its values, bound, Lipschitz constant and extent are the child's.
struct PropertyNode : FieldNode {
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    children[0]->eval(p, out, n, s, depth + 1);
  }
  void eval_grid(const GridPlane& g, double* out, EvalState& s, std::size_t depth) const override {
    children[0]->eval_grid(g, out, s, depth + 1);
  }
  Interval bound(const BBox3& b, EvalState& s, std::size_t depth) const override {
    return children[0]->bound(b, s, depth + 1);
  }
  double lipschitz() const override { return children[0]->lipschitz(); }
  Vec3 period() const override { return children[0]->period(); }
  BBox3 extent() const override { return children[0]->extent(); }
};

}  // namespace trellis
