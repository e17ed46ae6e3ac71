// The compiled 3MF implicit function graph as a field node (implicit_graph.hpp).
#include "implicit_graph.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "node.hpp"

namespace trellis::implicit {

const char* to_string(Type t) {
  switch (t) {
    case Type::Scalar:
      return "scalar";
    case Type::Vector:
      return "vector";
    case Type::Matrix:
      return "matrix";
    case Type::Resource:
      return "resource id";
  }
  return "?";
}

namespace {

double unary(Code op, double x) {
  switch (op) {
    case Code::Abs:
      return std::abs(x);
    case Code::Sin:
      return std::sin(x);
    case Code::Cos:
      return std::cos(x);
    case Code::Tan:
      return std::tan(x);
    case Code::Asin:
      return std::asin(x);
    case Code::Acos:
      return std::acos(x);
    case Code::Atan:
      return std::atan(x);
    case Code::Sqrt:
      return std::sqrt(x);
    case Code::Exp:
      return std::exp(x);
    case Code::Log:
      return std::log(x);
    case Code::Log2:
      return std::log2(x);
    case Code::Log10:
      return std::log10(x);
    case Code::Cosh:
      return std::cosh(x);
    case Code::Sinh:
      return std::sinh(x);
    case Code::Tanh:
      return std::tanh(x);
    case Code::Round:
      return std::round(x);
    case Code::Ceil:
      return std::ceil(x);
    case Code::Floor:
      return std::floor(x);
    case Code::Sign:
      return x < 0 ? -1.0 : x > 0 ? 1.0 : 0.0;  // Part II ch. 5, sign
    case Code::Fract:
      return x - std::floor(x);  // fract: A − floor(A)
    default:
      return 0;
  }
}

double binary(Code op, double a, double b) {
  switch (op) {
    case Code::Add:
      return a + b;
    case Code::Sub:
      return a - b;
    case Code::Mul:
      return a * b;
    case Code::Div:
      return a / b;
    case Code::Min:
      return std::min(a, b);
    case Code::Max:
      return std::max(a, b);
    case Code::Fmod:
      return std::fmod(a, b);  // C's: the sign of a
    case Code::Mod:
      return a - b * std::floor(a / b);  // GLSL's mod (Part II ch. 5, mod)
    case Code::Pow:
      return std::pow(a, b);
    case Code::Atan2:
      return std::atan2(a, b);
    default:
      return 0;
  }
}

// 4x4 inverse by Gauss-Jordan with partial pivoting; NaN for a singular matrix (undefined,
// so the levelset's fallback value, Part II §6.2).
void invert(const double* m, double* out) {
  double a[4][8];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 8; ++c) a[r][c] = c < 4 ? m[r * 4 + c] : (c - 4 == r ? 1.0 : 0.0);
  for (int col = 0; col < 4; ++col) {
    int piv = col;
    for (int r = col + 1; r < 4; ++r)
      if (std::abs(a[r][col]) > std::abs(a[piv][col])) piv = r;
    if (a[piv][col] == 0) {
      for (int i = 0; i < 16; ++i) out[i] = std::nan("");
      return;
    }
    if (piv != col)
      for (int c = 0; c < 8; ++c) std::swap(a[piv][c], a[col][c]);
    const double inv = 1 / a[col][col];
    for (int c = 0; c < 8; ++c) a[col][c] *= inv;
    for (int r = 0; r < 4; ++r) {
      if (r == col) continue;
      const double f = a[r][col];
      if (f != 0)
        for (int c = 0; c < 8; ++c) a[r][c] -= f * a[col][c];
    }
  }
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[r * 4 + c] = a[r][c + 4];
}

}  // namespace

void Program::run(double* r, EvalState& s, std::size_t depth) const {
  for (const Instr& in : code) {
    double* d = r + in.dst;
    const double* a = r + in.a;
    const double* b = r + in.b;
    const double* c = r + in.c;
    switch (in.op) {
      case Code::Add:
      case Code::Sub:
      case Code::Mul:
      case Code::Div:
      case Code::Min:
      case Code::Max:
      case Code::Fmod:
      case Code::Mod:
      case Code::Pow:
      case Code::Atan2:
        for (int i = 0; i < in.n; ++i) d[i] = binary(in.op, a[i], b[i]);
        break;
      case Code::Clamp:  // max(min, min(A, max)), Part II ch. 5, clamp
        for (int i = 0; i < in.n; ++i) d[i] = std::max(b[i], std::min(a[i], c[i]));
        break;
      case Code::Select: {  // A < B ? C : D, Part II ch. 5, select
        const double* e = r + in.d;
        for (int i = 0; i < in.n; ++i) d[i] = a[i] < b[i] ? c[i] : e[i];
        break;
      }
      case Code::Copy:
        std::memmove(d, a, sizeof(double) * in.n);
        break;
      case Code::Splat:
        d[0] = d[1] = d[2] = a[0];
        break;
      case Code::Dot:
        d[0] = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        break;
      case Code::Cross: {
        const double x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2],
                     z = a[0] * b[1] - a[1] * b[0];
        d[0] = x, d[1] = y, d[2] = z;
        break;
      }
      case Code::Length:
        d[0] = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        break;
      case Code::MatVec: {
        double v[3];
        for (int i = 0; i < 3; ++i)
          v[i] = a[i * 4] * b[0] + a[i * 4 + 1] * b[1] + a[i * 4 + 2] * b[2] + a[i * 4 + 3];
        std::memcpy(d, v, sizeof v);
        break;
      }
      case Code::Transpose: {
        double t[16];
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) t[j * 4 + i] = a[i * 4 + j];
        std::memcpy(d, t, sizeof t);
        break;
      }
      case Code::Inverse: {
        double t[16];
        invert(a, t);
        std::memcpy(d, t, sizeof t);
        break;
      }
      case Code::FromColumns:
      case Code::FromRows: {
        const double* v[4] = {a, b, c, r + in.d};
        double t[16];
        for (int k = 0; k < 4; ++k)
          for (int i = 0; i < 4; ++i) {
            const double x = i < 3 ? v[k][i] : (k == 3 ? 1.0 : 0.0);
            if (in.op == Code::FromColumns)
              t[i * 4 + k] = x;
            else
              t[k * 4 + i] = x;
          }
        std::memcpy(d, t, sizeof t);
        break;
      }
      case Code::Image:
        images[static_cast<std::size_t>(in.b)].sample(a, d);
        break;
      case Code::Distance:
        d[0] = fields[static_cast<std::size_t>(in.b)].node().value({a[0], a[1], a[2]}, s, depth);
        break;
      default:
        for (int i = 0; i < in.n; ++i) d[i] = unary(in.op, a[i]);
        break;
    }
  }
}

namespace {

struct GraphNode : FieldNode {
  std::shared_ptr<const Program> program;
  Affine to_function;
  double fallback = 0;

  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s,
            std::size_t depth) const override {
    auto& slot = s.caches[this];
    if (!slot) slot = std::make_shared<std::vector<double>>(program->init);
    double* r = static_cast<std::vector<double>*>(slot.get())->data();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 q = to_function.apply(p[i]);
      r[program->pos] = q.x;
      r[program->pos + 1] = q.y;
      r[program->pos + 2] = q.z;
      program->run(r, s, depth + 1);
      const double v = r[program->out];
      out[i] = std::isfinite(v) ? v : fallback;
    }
  }
  Interval bound(const BBox3&, EvalState&, std::size_t) const override { return {-kInf, kInf}; }
  double lipschitz() const override { return kInf; }
  BBox3 extent() const override {
    BBox3 b;
    b.min = {-kInf, -kInf, -kInf};
    b.max = {kInf, kInf, kInf};
    return b;
  }
  bool has_expressions() const override { return true; }
};

}  // namespace

Field graph_field(std::shared_ptr<const Program> program, Affine to_function, double fallback) {
  auto n = std::make_shared<GraphNode>();
  n->program = std::move(program);
  n->to_function = to_function;
  n->fallback = fallback;
  return Field(std::move(n));
}

}  // namespace trellis::implicit
