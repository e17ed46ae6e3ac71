// Internal: user expressions compiled to a flat register program evaluated over blocks of points.
//
// Why hand-written: muparser stays the parser and validator (its messages, its grammar, its
// optimiser), but its Eval runs a switch per token for every point, and Debian's build of its
// bulk mode uses OpenMP (a thread team per call, which breaks `--threads 1`). The program here is
// translated from muparser's final bytecode, so it performs the same floating-point operations
// in the same order (its optimiser's rewrites, such as a·x + b, included) and gives the same bits;
// on top it folds constant subtrees, shares subexpressions between the expressions of one node
// (an fgrade's fractions are often 1 − each other) and runs each instruction over a block of
// points without a virtual call or a switch per point.
#pragma once
#include <cstddef>
#include <memory>
#include <vector>

#include "trellis/core/vec.hpp"

namespace mu {
class ParserBase;
}

namespace trellis {

struct ExprVars;

class ExprProgram {
 public:
  // A parsed expression: a parser that has evaluated once (so its bytecode exists), bound to
  // the variables of `vars`.
  struct Source {
    const mu::ParserBase* parser;
    const ExprVars* vars;
  };
  // Null when some token has no translation here (assignments, string or bulk functions): the
  // caller keeps evaluating with muparser.
  static std::unique_ptr<ExprProgram> compile(const std::vector<Source>& sources);
  ExprProgram();
  ~ExprProgram();

  std::size_t outputs() const { return outputs_.size(); }
  bool uses_d() const { return uses_d_; }
  bool uses_polar() const { return uses_polar_; }
  std::size_t instructions() const;  // after folding and sharing (for tests)
  // out[k·n + i] = expression k at point p[i] (distance d[i], or 0 when d is null).
  void run(const Vec3* p, const double* d, std::size_t n, double* out);

  struct Instr;  // defined in expr_program.cpp

 private:
  static constexpr std::size_t kBlock = 64;
  void load_vars(const Vec3* p, const double* d, std::size_t n);
  std::vector<Instr> code_;
  std::vector<int> outputs_;   // register of each expression's value
  std::vector<double> regs_;   // register r's lanes at [r·kBlock, (r + 1)·kBlock)
  std::vector<int> var_regs_;  // register of variable v (ExprVar order), −1 when unused
  bool uses_d_ = false, uses_polar_ = false;
};

}  // namespace trellis
