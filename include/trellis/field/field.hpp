// The implicit geometry kernel: a design is an immutable expression tree whose value at a point is
// negative inside the solid, zero on its surface and positive outside (a signed distance for the
// primitives, a bound for the rest), plus material volume fractions.
//
// A Field is cheap to copy and may be shared between threads. It is evaluated through an
// Evaluator, which owns the per-thread state (compiled user expressions, scratch buffers): make
// one Evaluator per thread. Primitives are centred at the origin like OpenVCAD's.
//
// Bounds: every node gives a conservative interval of its values over a box (from exact interval
// rules or a Lipschitz constant), so slicers skip boxes that are wholly inside or outside without
// sampling them. A node that cannot bound itself (a user expression) reports (-inf, +inf).
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "trellis/core/vec.hpp"

namespace trellis {

class FieldNode;
class Evaluator;

// User expression over x, y, z, rho, phic (alias phi), r, theta, phis and d (the signed distance
// of the node's geometry), with pi and e. Compiled (and checked) by muparser.
struct Expression {
  std::string text;
};
// Checks an expression; throws ParseError with the muparser message and the 1-based column
// within the expression text of the first problem.
void check_expression(const std::string& text, long* error_column = nullptr);

// Whether the expression is just a number (then *value is it).
bool constant_expression(const std::string& text, double* value);

enum class TpmsKind { Gyroid, SchwarzP, SchwarzD, Neovius, Iwp };

// Process parameters a design may set as fields (fprocess): nozzle temperature (°C), feed
// (mm/s), flow (extrusion multiplier on top of the machine's) and part-cooling fan (%).
enum class ProcessParam { Temperature, Speed, Flow, Fan };
inline constexpr int kProcessParams = 4;
const char* to_string(ProcessParam p);
// "temperature", "speed", "flow", "fan"; false for any other name.
bool process_param_from_string(const std::string& name, ProcessParam* out);
// The process values at a point: NaN where no fprocess node sets the parameter; `node` names the
// fprocess node that set it (its label, e.g. "fprocess at design.vcad:3").
struct ProcessValues {
  double value[kProcessParams];
  const std::string* node[kProcessParams];
  ProcessValues();
};
const char* to_string(TpmsKind kind);

class Field {
 public:
  Field() = default;
  explicit Field(std::shared_ptr<const FieldNode> node);
  const FieldNode& node() const { return *node_; }
  const std::shared_ptr<const FieldNode>& ptr() const { return node_; }
  bool empty() const { return !node_; }

  // Bounding box of the solid; infinite boxes (TPMS, half spaces) have infinite coordinates.
  BBox3 extent() const;
  // Material names in order of first appearance ("" when a primitive has none).
  const std::vector<std::string>& materials() const;
  // Whether some node is a user expression (no interval bounds there).
  bool has_expressions() const;
  // Whether some fprocess node sets process parameters.
  bool has_process() const;
  // Nodes of the expression tree, a subtree counted each time it is used (what an evaluation
  // may visit): the estimates' measure of a design's size (a union of 10^5 spheres).
  double nodes() const;
  // The smallest period along any axis of the periodic parts of the design (a TPMS cell inside
  // a CSG box: the cell), infinity when none repeats. What a sampling grid must resolve.
  double smallest_period() const;
  // A bound on |∇f| over all space (per mm); infinite where the field has none (expressions,
  // blends, CSG of such).
  double lipschitz() const;
  // A period along each axis, f(p + P·e) = f(p) (a TPMS: its cell; translations of it keep it),
  // 0 along axes where none is known.
  Vec3 period() const;
  // f(−p) = parity · f(p) for every p, the origin a centre of symmetry: 1 (even, e.g. Schwarz
  // P), −1 (odd, e.g. the gyroid), 0 where none is known (translated fields, CSG, expressions).
  int inversion_parity() const;

 private:
  std::shared_ptr<const FieldNode> node_;
  std::shared_ptr<const std::vector<std::string>> materials_;
};

// --- primitives (centred at the origin) ---
Field sphere(double radius, std::string material = {});
Field cube(double side, std::string material = {});
Field rectprism(Vec3 size, std::string material = {});                    // full side lengths
Field cylinder(double radius, double height, std::string material = {});  // along Z
Field cone(double radius, double height,
           std::string material = {});  // base radius at z=-h/2, tip at +h/2
Field torus(double major_radius, double minor_radius, std::string material = {});  // in XY
// f(x,y,z) <= 0 inside, cut to the box [min, max].
Field function(Vec3 min, Vec3 max, Expression expr, std::string material = {});
// TPMS level set φ scaled so a unit cell is `cell` mm. Network solid φ <= 0 when `c` is empty;
// with `c` a sheet Φ = φ² − c² (c a number or an expression of the coordinates).
Field tpms(TpmsKind kind, Vec3 cell, Expression c = {}, std::string material = {});

// Sheet around the zero set of any mid-surface field φ: Φ = φ² − c², c a number or an expression
// (PBF paper Eq. 5). With `uniform_thickness` > 0 instead, c = t·|∇φ|/2, so the sheet is t thick
// everywhere to first order.
Field sheet(Field phi, Expression c, double uniform_thickness = 0);
// (1 − w)·a + w·b with w an expression clamped to [0, 1]: graded cell size (sigmoid w) or a
// hierarchical lattice (constant w).
Field blend(Field a, Field b, Expression w);
// Any expression as a field, unbounded (e.g. "y" for a plane mid-surface).
Field expression_field(Expression e);

// --- CSG ---
Field unite(std::vector<Field> children);
Field intersect(std::vector<Field> children);
Field subtract(std::vector<Field> children);  // first minus the others
// Polynomial smooth min/max with blend radius k (mm).
Field smooth_unite(std::vector<Field> children, double k);
Field smooth_intersect(std::vector<Field> children, double k);
Field smooth_subtract(std::vector<Field> children, double k);

// --- transforms ---
Field translate(Field child, Vec3 offset);
Field scale(Field child, Vec3 factors);   // positive factors
Field rotate(Field child, Vec3 degrees);  // about X, then Y, then Z
// Material volume fractions of the child as expressions, one per material name.
Field fgrade(Field child, std::vector<Expression> fractions, std::vector<std::string> materials);
// Process parameters of the child as expressions, one per parameter name (temperature, speed,
// flow, fan). A point takes the values of the innermost fprocess around the part of the design
// that holds it (the child a union picks, as for materials); `label` names the node in errors.
Field fprocess(Field child, std::vector<Expression> values, std::vector<std::string> params,
               std::string label = "fprocess");
// Hands the child the box of a .vcad root(): the solid is clipped to the box.
Field clip_box(Field child, Vec3 min, Vec3 max);

// A design made of one TPMS sheet cut by root boxes and sharp intersections (a .vcad such as
// `root(...) { gyroid(5, 0.3); }`), split for the laser route: the sheet's mid-surface φ, its c
// (or uniform thickness), the other intersected solids (empty when none) and the root boxes.
// nullopt for any other design: no sheet, more than one, or a sheet under a union, difference,
// blend, transform or smooth intersection.
struct SheetSplit {
  Field phi;
  Expression c;
  double thickness = 0;
  Field envelope;
  std::vector<BBox3> boxes;
};
std::optional<SheetSplit> split_sheet(const Field& design);
// Whether the design has a TPMS anywhere (a network solid or a sheet).
bool has_tpms(const Field& design);

// --- meshes ---
struct TriangleMesh;
struct MeshSdfOptions {
  double voxel = 0.1;        // mm
  double band_voxels = 3.0;  // narrow band half-width
};
// Signed distance field of a closed mesh (OpenVDB). Throws GeometryError for open meshes.
Field mesh_field(const TriangleMesh& mesh, const MeshSdfOptions& options, std::string name);

// Marching cubes of the field (OpenVDB volumeToMesh) over `box` at `voxel`: the STL route of
// the PBF paper, kept for comparison.
struct MeshingStats {
  std::size_t samples = 0, grid_bytes = 0, mesh_bytes = 0;
};
TriangleMesh field_to_mesh(const Field& field, const BBox3& box, double voxel,
                           MeshingStats* stats = nullptr);

// Per-thread evaluation. Not thread-safe itself; cheap enough to make one per task.
class Evaluator {
 public:
  explicit Evaluator(const Field& field);
  ~Evaluator();
  Evaluator(Evaluator&&) noexcept;
  Evaluator& operator=(Evaluator&&) noexcept;

  const Field& field() const { return field_; }
  double value(Vec3 p);
  void values(const Vec3* points, double* out, std::size_t n);
  // The values at the grid nodes (xs[i], ys[j], z), row by row (out[j·w + i]): the same numbers
  // as values() at those points, cheaper for a TPMS (sines per column and per row, not per node)
  // and for CSG (children whose bound over the grid shows they change nothing are skipped).
  void values_grid(const double* xs, std::size_t w, const double* ys, std::size_t rows, double z,
                   double* out);
  // The analytic gradient at those nodes (TPMS); false (out untouched) where the field has no
  // grid path for it.
  bool gradients_grid(const double* xs, std::size_t w, const double* ys, std::size_t rows, double z,
                      Vec3* out);
  // Central differences with step h (mm).
  Vec3 gradient(Vec3 p, double h = 1e-5);
  void gradients(const Vec3* points, Vec3* out, std::size_t n, double h = 1e-5);
  // value(p), and gradient(p, h) into *g: the same numbers, from one evaluation where the field
  // has an analytic gradient (TPMS).
  double value_gradient(Vec3 p, Vec3* g, double h = 1e-5);
  Interval bound(const BBox3& box);
  // Volume fractions (sum 1 when any material is set) per Field::materials().
  std::vector<double> fractions(Vec3 p);
  // The fractions at n points, out[i·m + k] for the m = Field::materials().size() materials:
  // the same numbers as fractions() point by point, each expression evaluated over the row.
  void fractions(const Vec3* points, std::size_t n, double* out);
  // Process parameters set by fprocess nodes (NaN where none).
  ProcessValues process(Vec3 p);

  struct State;

 private:
  Field field_;
  std::unique_ptr<State> state_;
};

}  // namespace trellis
