#include "expr_program.hpp"

#include <muParser.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <tuple>

#include "node.hpp"

namespace trellis {

namespace {

enum class Op : std::uint8_t {
  Var,
  Const,
  VarMul,
  Pow2,
  Pow3,
  Pow4,
  Le,
  Ge,
  Neq,
  Eq,
  Lt,
  Gt,
  Add,
  Sub,
  Mul,
  Div,
  Pow,
  And,
  Or,
  Select,
  Fun,
  MultiFun
};

// The variables in the order of var_regs_; `phi` is muparser's second name for phic.
enum Var : int { kX, kY, kZ, kD, kRho, kPhic, kR, kTheta, kPhis, kVars };

std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

int var_of(const double* ptr, const ExprVars& v) {
  const double* const all[kVars] = {&v.x,    &v.y, &v.z,     &v.d,   &v.rho,
                                    &v.phic, &v.r, &v.theta, &v.phis};
  for (int i = 0; i < kVars; ++i)
    if (ptr == all[i]) return i;
  return -1;
}

}  // namespace

struct ExprProgram::Instr {
  Op op;
  int dst = -1;
  std::vector<int> args;  // registers of the arguments, in muparser's order
  double k0 = 0, k1 = 0;  // Const: the value in k1; VarMul: x·k0 + k1 (muparser's data, data2)
  int var = -1;           // Var: which (enum Var)
  mu::generic_callable_type fn{};
  int argc = 0;  // Fun: muparser's count (fixed); MultiFun: the number of arguments
};

namespace {

using Instr = ExprProgram::Instr;

template <class F>
void lanes(double* o, std::size_t n, F f) {
  for (std::size_t i = 0; i < n; ++i) o[i] = f(i);
}

// One instruction over n lanes: the same expression muparser's ParseCmdCodeBulk evaluates per
// token (muParserBase.cpp), so the same bits.
void apply(const Instr& ins, double* o, const double* const* a, std::size_t n) {
  const double *x = a[0], *y = a[1], *z = a[2];
  switch (ins.op) {
    case Op::Var:
    case Op::Const:
      return;
    case Op::VarMul:
      return lanes(o, n, [&](std::size_t i) { return x[i] * ins.k0 + ins.k1; });
    case Op::Pow2:
      return lanes(o, n, [&](std::size_t i) { return x[i] * x[i]; });
    case Op::Pow3:
      return lanes(o, n, [&](std::size_t i) { return x[i] * x[i] * x[i]; });
    case Op::Pow4:
      return lanes(o, n, [&](std::size_t i) { return x[i] * x[i] * x[i] * x[i]; });
    case Op::Le:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] <= y[i]; });
    case Op::Ge:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] >= y[i]; });
    case Op::Neq:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] != y[i]; });
    case Op::Eq:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] == y[i]; });
    case Op::Lt:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] < y[i]; });
    case Op::Gt:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] > y[i]; });
    case Op::Add:
      return lanes(o, n, [&](std::size_t i) { return x[i] + y[i]; });
    case Op::Sub:
      return lanes(o, n, [&](std::size_t i) { return x[i] - y[i]; });
    case Op::Mul:
      return lanes(o, n, [&](std::size_t i) { return x[i] * y[i]; });
    case Op::Div:
      return lanes(o, n, [&](std::size_t i) { return x[i] / y[i]; });
    case Op::Pow:
      return lanes(o, n, [&](std::size_t i) { return std::pow(x[i], y[i]); });
    case Op::And:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] && y[i]; });
    case Op::Or:
      return lanes(o, n, [&](std::size_t i) -> double { return x[i] || y[i]; });
    case Op::Select:  // muparser jumps to the else branch when the condition == 0
      return lanes(o, n, [&](std::size_t i) { return x[i] == 0 ? z[i] : y[i]; });
    case Op::Fun:
      switch (ins.argc) {
        case 0:
          return lanes(o, n, [&](std::size_t) { return ins.fn.call_fun<0>(); });
        case 1:
          return lanes(o, n, [&](std::size_t i) { return ins.fn.call_fun<1>(x[i]); });
        case 2:
          return lanes(o, n, [&](std::size_t i) { return ins.fn.call_fun<2>(x[i], y[i]); });
        case 3:
          return lanes(o, n, [&](std::size_t i) { return ins.fn.call_fun<3>(x[i], y[i], z[i]); });
        case 4:
          return lanes(
              o, n, [&](std::size_t i) { return ins.fn.call_fun<4>(x[i], y[i], z[i], a[3][i]); });
      }
      return;
    case Op::MultiFun: {
      double arg[64];
      for (std::size_t i = 0; i < n; ++i) {
        for (int k = 0; k < ins.argc; ++k) arg[k] = a[k][i];
        o[i] = ins.fn.call_multfun(arg, ins.argc);
      }
      return;
    }
  }
}

// Builds the program's graph from muparser's RPN: one node per distinct operation (shared
// between expressions), constants folded, nodes in evaluation order (arguments first).
class Builder {
 public:
  std::vector<Instr> nodes;

  explicit Builder(const std::vector<ExprProgram::Source>& sources) {
    // Functions muparser may not fold (none of the built-in ones) are not folded or shared here.
    for (const auto& s : sources)
      for (const auto& [name, cb] : s.parser->GetFunDef())
        if (!cb.IsOptimizable()) impure_.push_back(cb.GetAddr());
  }

  // The expression's value node, or −1 when a token has no translation.
  int translate(const mu::ParserBase& parser, const ExprVars& vars) {
    const mu::ParserByteCode& code = parser.GetByteCode();
    std::vector<int> stack;
    struct If {
      int cond, then = -1;
      std::size_t depth;
    };
    std::vector<If> ifs;
    auto pop = [&] {
      const int v = stack.back();
      stack.pop_back();
      return v;
    };
    auto binary = [&](Op op) {
      if (stack.size() < 2) return false;
      const int b = pop(), a = pop();
      stack.push_back(make({op, -1, {a, b}}));
      return true;
    };
    for (const mu::SToken* t = code.GetBase(); t->Cmd != mu::cmEND; ++t) {
      switch (t->Cmd) {
        case mu::cmLE:
          if (!binary(Op::Le)) return -1;
          break;
        case mu::cmGE:
          if (!binary(Op::Ge)) return -1;
          break;
        case mu::cmNEQ:
          if (!binary(Op::Neq)) return -1;
          break;
        case mu::cmEQ:
          if (!binary(Op::Eq)) return -1;
          break;
        case mu::cmLT:
          if (!binary(Op::Lt)) return -1;
          break;
        case mu::cmGT:
          if (!binary(Op::Gt)) return -1;
          break;
        case mu::cmADD:
          if (!binary(Op::Add)) return -1;
          break;
        case mu::cmSUB:
          if (!binary(Op::Sub)) return -1;
          break;
        case mu::cmMUL:
          if (!binary(Op::Mul)) return -1;
          break;
        case mu::cmDIV:
          if (!binary(Op::Div)) return -1;
          break;
        case mu::cmPOW:
          if (!binary(Op::Pow)) return -1;
          break;
        case mu::cmLAND:
          if (!binary(Op::And)) return -1;
          break;
        case mu::cmLOR:
          if (!binary(Op::Or)) return -1;
          break;
        case mu::cmVAL:
          stack.push_back(constant(t->Val.data2));
          break;
        case mu::cmVAR:
        case mu::cmVARPOW2:
        case mu::cmVARPOW3:
        case mu::cmVARPOW4:
        case mu::cmVARMUL: {
          const int v = var_of(t->Val.ptr, vars);
          if (v < 0) return -1;
          Instr var{Op::Var};
          var.var = v;
          const int x = make(var);
          if (t->Cmd == mu::cmVAR) {
            stack.push_back(x);
          } else if (t->Cmd == mu::cmVARMUL) {
            Instr m{Op::VarMul, -1, {x}};
            m.k0 = t->Val.data;
            m.k1 = t->Val.data2;
            stack.push_back(make(m));
          } else {
            const Op op = t->Cmd == mu::cmVARPOW2   ? Op::Pow2
                          : t->Cmd == mu::cmVARPOW3 ? Op::Pow3
                                                    : Op::Pow4;
            stack.push_back(make({op, -1, {x}}));
          }
          break;
        }
        case mu::cmFUNC: {
          const int argc = t->Fun.argc;
          const std::size_t k = static_cast<std::size_t>(argc < 0 ? -argc : argc);
          if (argc > 4 || k > 64 || stack.size() < k) return -1;
          Instr f{argc < 0 ? Op::MultiFun : Op::Fun};
          f.fn = t->Fun.cb;
          f.argc = static_cast<int>(k);
          f.args.assign(stack.end() - static_cast<std::ptrdiff_t>(k), stack.end());
          stack.resize(stack.size() - k);
          stack.push_back(make(f));
          break;
        }
        case mu::cmIF:
          if (stack.empty()) return -1;
          ifs.push_back({pop(), -1, stack.size()});
          break;
        case mu::cmELSE:
          if (ifs.empty() || stack.size() != ifs.back().depth + 1) return -1;
          ifs.back().then = pop();
          break;
        case mu::cmENDIF: {
          if (ifs.empty() || ifs.back().then < 0 || stack.size() != ifs.back().depth + 1) return -1;
          const If f = ifs.back();
          ifs.pop_back();
          stack.push_back(make({Op::Select, -1, {f.cond, f.then, pop()}}));
          break;
        }
        default:  // assignment, string and bulk functions
          return -1;
      }
    }
    // Comma-separated expressions: muparser's Eval() returns the last one.
    if (stack.empty() || !ifs.empty()) return -1;
    return stack.back();
  }

 private:
  using Key =
      std::tuple<Op, std::vector<int>, std::uint64_t, std::uint64_t, int, void*, void*, int>;
  std::map<Key, int> seen_;
  std::vector<void*> impure_;

  bool pure(const Instr& n) const {
    if (n.op != Op::Fun && n.op != Op::MultiFun) return true;
    return std::find(impure_.begin(), impure_.end(), reinterpret_cast<void*>(n.fn._pRawFun)) ==
           impure_.end();
  }
  bool is_const(int i) const { return nodes[static_cast<std::size_t>(i)].op == Op::Const; }

  int constant(double v) {
    Instr c{Op::Const};
    c.k1 = v;
    return make(c);
  }

  int make(Instr n) {
    if (n.op == Op::Select && is_const(n.args[0]))
      return nodes[static_cast<std::size_t>(n.args[0])].k1 == 0 ? n.args[2] : n.args[1];
    const bool p = pure(n);
    if (p && n.op != Op::Var && n.op != Op::Const && !n.args.empty() &&
        std::all_of(n.args.begin(), n.args.end(), [&](int a) { return is_const(a); })) {
      const double* in[64] = {};
      for (std::size_t k = 0; k < n.args.size(); ++k)
        in[k] = &nodes[static_cast<std::size_t>(n.args[k])].k1;
      double v;
      apply(n, &v, in, 1);
      return constant(v);
    }
    Key key{n.op,
            n.args,
            bits(n.k0),
            bits(n.k1),
            n.var,
            reinterpret_cast<void*>(n.fn._pRawFun),
            n.fn._pUserData,
            n.argc};
    if (p) {
      auto it = seen_.find(key);
      if (it != seen_.end()) return it->second;
    }
    n.dst = static_cast<int>(nodes.size());
    nodes.push_back(std::move(n));
    if (p) seen_.emplace(std::move(key), nodes.back().dst);
    return nodes.back().dst;
  }
};

}  // namespace

ExprProgram::ExprProgram() = default;
ExprProgram::~ExprProgram() = default;
std::size_t ExprProgram::instructions() const {
  return code_.size();
}

std::unique_ptr<ExprProgram> ExprProgram::compile(const std::vector<Source>& sources) {
  Builder b(sources);
  auto prog = std::unique_ptr<ExprProgram>(new ExprProgram);
  try {
    for (const auto& s : sources) {
      const int out = b.translate(*s.parser, *s.vars);
      if (out < 0) return nullptr;
      prog->outputs_.push_back(out);
    }
  } catch (const mu::ParserError&) {
    return nullptr;
  }
  // Only what the outputs read, in order (arguments come before their users).
  std::vector<char> live(b.nodes.size(), 0);
  for (int o : prog->outputs_) live[static_cast<std::size_t>(o)] = 1;
  for (std::size_t i = b.nodes.size(); i-- > 0;)
    if (live[i])
      for (int a : b.nodes[i].args) live[static_cast<std::size_t>(a)] = 1;
  prog->regs_.assign(b.nodes.size() * kBlock, 0.0);
  prog->var_regs_.assign(kVars, -1);
  for (std::size_t i = 0; i < b.nodes.size(); ++i) {
    if (!live[i]) continue;
    const Instr& n = b.nodes[i];
    if (n.op == Op::Const)
      std::fill_n(prog->regs_.begin() + static_cast<std::ptrdiff_t>(i * kBlock), kBlock, n.k1);
    else if (n.op == Op::Var)
      prog->var_regs_[static_cast<std::size_t>(n.var)] = n.dst;
    else
      prog->code_.push_back(n);
  }
  prog->uses_d_ = prog->var_regs_[kD] >= 0;
  for (int v = kRho; v < kVars; ++v)
    prog->uses_polar_ |= prog->var_regs_[static_cast<std::size_t>(v)] >= 0;
  return prog;
}

// The variables of n ≤ kBlock points, as ExprVars::set computes them.
void ExprProgram::load_vars(const Vec3* p, const double* d, std::size_t n) {
  auto reg = [&](int v) -> double* {
    const int r = var_regs_[static_cast<std::size_t>(v)];
    return r < 0 ? nullptr : regs_.data() + static_cast<std::size_t>(r) * kBlock;
  };
  if (double* o = reg(kX)) lanes(o, n, [&](std::size_t i) { return p[i].x; });
  if (double* o = reg(kY)) lanes(o, n, [&](std::size_t i) { return p[i].y; });
  if (double* o = reg(kZ)) lanes(o, n, [&](std::size_t i) { return p[i].z; });
  if (double* o = reg(kD)) lanes(o, n, [&](std::size_t i) { return d ? d[i] : 0.0; });
  if (!uses_polar_) return;
  if (double* o = reg(kRho)) lanes(o, n, [&](std::size_t i) { return std::hypot(p[i].x, p[i].y); });
  if (double* o = reg(kPhic))
    lanes(o, n, [&](std::size_t i) { return std::atan2(p[i].y, p[i].x); });
  if (double* o = reg(kPhis))
    lanes(o, n, [&](std::size_t i) { return std::atan2(p[i].y, p[i].x); });
  double* r = reg(kR);
  double* theta = reg(kTheta);
  if (!r && !theta) return;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 q = p[i];
    const double len = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    if (r) r[i] = len;
    if (theta) theta[i] = len > 0 ? std::acos(std::clamp(q.z / len, -1.0, 1.0)) : 0.0;
  }
}

void ExprProgram::run(const Vec3* p, const double* d, std::size_t n, double* out) {
  const double* args[64];
  for (std::size_t s = 0; s < n; s += kBlock) {
    const std::size_t m = std::min(kBlock, n - s);
    load_vars(p + s, d ? d + s : nullptr, m);
    for (const Instr& ins : code_) {
      for (std::size_t k = 0; k < ins.args.size(); ++k)
        args[k] = regs_.data() + static_cast<std::size_t>(ins.args[k]) * kBlock;
      apply(ins, regs_.data() + static_cast<std::size_t>(ins.dst) * kBlock, args, m);
    }
    for (std::size_t k = 0; k < outputs_.size(); ++k) {
      const double* v = regs_.data() + static_cast<std::size_t>(outputs_[k]) * kBlock;
      std::copy(v, v + m, out + k * n + s);
    }
  }
}

}  // namespace trellis
