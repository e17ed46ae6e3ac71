// Internal (implicit3mf module): a function graph of the 3MF Implicit Extension (Part II ch. 5)
// compiled into straight-line code over a register file of doubles, and the field node that runs
// it. The graph's scalars, vectors (3) and 4x4 matrices (16, row-major) are runs of registers;
// constants are registers set once. Evaluation state (the register file) is per thread.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "implicit_image.hpp"
#include "trellis/field/field.hpp"

namespace trellis::implicit {

enum class Type : std::uint8_t { Scalar, Vector, Matrix, Resource };
inline int width(Type t) {
  return t == Type::Scalar ? 1 : t == Type::Vector ? 3 : t == Type::Matrix ? 16 : 0;
}
const char* to_string(Type t);

enum class Code : std::uint8_t {
  // componentwise over n registers (binary: a, b; clamp: a, b = min, c = max; select: a<b ? c : d)
  Add,
  Sub,
  Mul,
  Div,
  Min,
  Max,
  Fmod,
  Mod,
  Pow,
  Atan2,
  Abs,
  Sin,
  Cos,
  Tan,
  Asin,
  Acos,
  Atan,
  Sqrt,
  Exp,
  Log,
  Log2,
  Log10,
  Cosh,
  Sinh,
  Tanh,
  Round,
  Ceil,
  Floor,
  Sign,
  Fract,
  Clamp,
  Select,
  Copy,   // dst[0..n) = a[0..n)
  Splat,  // dst[0..3) = a[0]
  Dot,
  Cross,
  Length,
  MatVec,  // dst = (a · (b, 1)) without the fourth row
  Transpose,
  Inverse,
  FromColumns,
  FromRows,  // a, b, c, d: vectors; the fourth row (column) is 0 0 0 1
  Image,     // dst[0..4) = red, green, blue, alpha of images[b] at uvw a[0..3) (Part I §2.2)
  Distance   // dst[0] = fields[b] at a[0..3) (Part II ch. 5, mesh and unsignedmesh)
};

struct Instr {
  Code op;
  std::uint8_t n = 1;
  std::int32_t dst = 0, a = 0, b = 0, c = 0, d = 0;
};

struct Program {
  std::vector<double> init;  // the register file with its constants
  std::vector<Instr> code;
  std::vector<ImageFunction> images;  // what Code::Image samples
  std::vector<Field> fields;          // what Code::Distance evaluates (a mesh's distance)
  int pos = 0;                        // where the position goes (3 registers)
  int out = 0;                        // the scalar result
  int alloc(int n) {
    const int o = static_cast<int>(init.size());
    init.resize(init.size() + static_cast<std::size_t>(n), 0.0);
    return o;
  }
  // Runs the code on `regs` (a copy of init; the position already in place); `s` and `depth`
  // are the evaluation state and scratch depth the fields use.
  void run(double* regs, Evaluator::State& s, std::size_t depth) const;
};

// p_function = l · p + t (p in the design's millimetres).
struct Affine {
  double l[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  double t[3] = {0, 0, 0};
  Vec3 apply(Vec3 p) const {
    return {l[0][0] * p.x + l[0][1] * p.y + l[0][2] * p.z + t[0],
            l[1][0] * p.x + l[1][1] * p.y + l[1][2] * p.z + t[1],
            l[2][0] * p.x + l[2][1] * p.y + l[2][2] * p.z + t[2]};
  }
};

// The field whose value at p is the program's output at to_function(p), `fallback` where that
// is not a finite number (Part II §6.2). Unbounded: no interval rule, no Lipschitz constant.
Field graph_field(std::shared_ptr<const Program> program, Affine to_function, double fallback);

}  // namespace trellis::implicit
