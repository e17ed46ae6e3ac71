// Compiled expressions (src/field/expr_program.cpp) give muparser's bits: random expressions of
// the documented grammar (docs/formats.md: variables, constants, functions, operators), shaped
// so that muparser's optimiser rewrites some of them (a·x + b, x^2, 2·x + 3·x, 4·x/2), evaluated
// at random points one by one and in batches, alone and sharing one program.
#include <gtest/gtest.h>
#include <muParser.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "../../src/field/expr_program.hpp"
#include "../../src/field/node.hpp"
#include "trellis/core/error.hpp"

using namespace trellis;

namespace {

class ExprGen {
 public:
  explicit ExprGen(std::uint64_t seed) : rng_(seed) {}
  std::string expr(int depth) {
    if (depth <= 0 || pick(5) == 0) return leaf();
    switch (pick(9)) {
      case 0:
      case 1:
        return "(" + expr(depth - 1) + op() + expr(depth - 1) + ")";
      case 2:  // muparser's optimiser patterns: a·v + b, v^k, v·v, k·v/k
        return optimisable();
      case 3:
        return "-" + expr(depth - 1);
      case 4:
        return fun1() + "(" + expr(depth - 1) + ")";
      case 5: {
        static const char* f2[] = {"atan2", "mod", "fmod", "pow"};
        return std::string(f2[pick(4)]) + "(" + expr(depth - 1) + "," + expr(depth - 1) + ")";
      }
      case 6: {
        static const char* fn[] = {"min", "max", "sum", "avg"};
        std::string s = std::string(fn[pick(4)]) + "(" + expr(depth - 1);
        for (int k = pick(4); k > 0; --k) s += "," + expr(depth - 1);
        return s + ")";
      }
      case 7:
        return "clamp(" + expr(depth - 1) + "," + expr(depth - 1) + "," + expr(depth - 1) + ")";
      default:
        return "(" + expr(depth - 1) + cmp() + expr(depth - 1) + " ? " + expr(depth - 1) + " : " +
               expr(depth - 1) + ")";
    }
  }

 private:
  std::mt19937_64 rng_;
  int pick(int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng_); }
  std::string var() {
    static const char* v[] = {"x", "y", "z", "rho", "phic", "phi", "r", "theta", "phis", "d"};
    return v[pick(10)];
  }
  std::string number() {
    static const char* c[] = {"0",     "1",      "2",    "3",  "4", "0.5",
                              "0.025", "0.0375", "1e-3", "pi", "e", "1.7"};
    return c[pick(12)];
  }
  std::string leaf() { return pick(3) == 0 ? number() : var(); }
  std::string op() {
    static const char* o[] = {"+", "-", "*", "/", "^", "+", "*"};
    return o[pick(7)];
  }
  std::string cmp() {
    static const char* o[] = {"<", ">", "<=", ">=", "==", "!=", "&&", "||"};
    return o[pick(8)];
  }
  std::string fun1() {
    static const char* f[] = {"sin",  "cos",  "tan",  "asin", "acos",  "atan", "sinh",
                              "cosh", "tanh", "exp",  "ln",   "log",   "log2", "log10",
                              "sqrt", "abs",  "sign", "rint", "floor", "ceil"};
    return f[pick(20)];
  }
  std::string optimisable() {
    const std::string v = var(), a = number(), b = number();
    switch (pick(7)) {
      case 0:
        return "(" + a + "*" + v + "+" + b + ")";
      case 1:
        return "(" + v + "*" + a + "-" + b + ")";
      case 2:
        return v + "^" + std::to_string(pick(5));
      case 3:
        return "(" + v + "*" + v + ")";
      case 4:
        return "(" + a + "*" + v + "+" + b + "*" + v + "-" + v + ")";
      case 5:
        return "((" + a + "*" + v + "+1)*" + b + ")";
      default:
        return "(" + a + "*" + v + "/" + b + ")";
    }
  }
};

std::vector<Vec3> sample_points(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-60, 60);
  // The origin and the axes take the polar variables' special cases (r = 0, theta's clamp).
  std::vector<Vec3> p = {{0, 0, 0}, {0, 0, 5}, {0, 0, -5}, {3, 0, 0}, {0, -2, 0}, {1, 1, 1}};
  while (p.size() < n) p.push_back({u(rng), u(rng), u(rng)});
  return p;
}

bool same_bits(double a, double b) {
  if (std::isnan(a) && std::isnan(b)) return true;
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// muparser's value at each point (its own Eval, the variables set as the evaluator sets them).
std::vector<double> muparser_values(CompiledExpr& c, const std::vector<Vec3>& p,
                                    const std::vector<double>& d) {
  std::vector<double> v(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    c.vars.set(p[i], d[i], true);
    v[i] = c.parser->Eval();
  }
  return v;
}

TEST(ExprProgram, RandomExpressionsGiveMuparsersBits) {
  const std::vector<Vec3> pts = sample_points(150, 3);  // more than one block of lanes
  std::vector<double> dist(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) dist[i] = pts[i].x * 0.3 - 2;
  ExprGen gen(11);
  int compiled = 0, total = 0, folded = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    Expression e{gen.expr(1 + trial % 5)};
    try {
      check_expression(e.text);
    } catch (const ParseError&) {
      continue;  // the generator's rare invalid text (muparser's own limits)
    }
    EvalState s;
    CompiledExpr& c = s.expr(e);
    ++total;
    if (!c.program) continue;
    ++compiled;
    folded += c.program->instructions() == 0;
    const std::vector<double> want = muparser_values(c, pts, dist);
    std::vector<double> batch(pts.size());
    c.eval(pts.data(), dist.data(), pts.size(), batch.data());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      ASSERT_TRUE(same_bits(batch[i], want[i]))
          << e.text << " at (" << pts[i].x << ", " << pts[i].y << ", " << pts[i].z << ", d "
          << dist[i] << "): " << batch[i] << " vs muparser " << want[i];
      ASSERT_TRUE(same_bits(c.eval(pts[i], dist[i]), want[i])) << e.text;
    }
  }
  // Every expression of the grammar compiles (no silent fallback), and some fold to constants.
  EXPECT_GT(total, 2500);
  EXPECT_EQ(compiled, total);
  EXPECT_GT(folded, 0);
}

TEST(ExprProgram, SharedProgramGivesEachExpressionsBits) {
  const std::vector<Vec3> pts = sample_points(100, 5);
  const std::vector<double> dist(pts.size(), 0.0);
  ExprGen gen(29);
  for (int trial = 0; trial < 300; ++trial) {
    // Two expressions that share a subexpression (as an fgrade's 1 − f does) and a third.
    const std::string f = gen.expr(3);
    std::vector<Expression> list = {{f}, {"1-(" + f + ")"}, {gen.expr(2)}};
    bool ok = true;
    for (const auto& e : list) {
      try {
        check_expression(e.text);
      } catch (const ParseError&) {
        ok = false;
      }
    }
    if (!ok) continue;
    EvalState s;
    std::vector<ExprProgram::Source> src;
    for (const auto& e : list) {
      CompiledExpr& c = s.expr(e);
      src.push_back({c.parser.get(), &c.vars});
    }
    auto prog = ExprProgram::compile(src);
    ASSERT_TRUE(prog) << f;
    ASSERT_EQ(prog->outputs(), list.size());
    std::vector<double> out(list.size() * pts.size());
    prog->run(pts.data(), dist.data(), pts.size(), out.data());
    for (std::size_t k = 0; k < list.size(); ++k) {
      const std::vector<double> want = muparser_values(s.expr(list[k]), pts, dist);
      for (std::size_t i = 0; i < pts.size(); ++i)
        ASSERT_TRUE(same_bits(out[k * pts.size() + i], want[i]))
            << list[k].text << " at point " << i;
    }
  }
}

TEST(ExprProgram, SharesSubexpressionsAndFoldsConstants) {
  EvalState s;
  const std::string f = "(1+sin(0.025*x+0.0375*y)*cos(0.0375*x-0.025*y))/2";
  // (The evaluator keys its parsers by the Expression's address: they must outlive it.)
  const std::vector<Expression> list = {{f}, {"1-" + f}, {"sqrt(2)*pi+max(1,2,3)"}};
  std::vector<ExprProgram::Source> src;
  for (const Expression& e : list) {
    CompiledExpr& c = s.expr(e);
    src.push_back({c.parser.get(), &c.vars});
  }
  const std::size_t one = ExprProgram::compile({src[0]})->instructions();
  auto both = ExprProgram::compile({src[0], src[1]});
  // The second expression adds only its subtraction.
  EXPECT_EQ(both->instructions(), one + 1);
  EXPECT_FALSE(both->uses_d());
  EXPECT_FALSE(both->uses_polar());
  CompiledExpr& k = s.expr(list[2]);
  ASSERT_TRUE(k.program);
  EXPECT_EQ(k.program->instructions(), 0u);
  EXPECT_EQ(k.eval({1, 2, 3}), std::sqrt(2.0) * std::numbers::pi + 3);
}

}  // namespace
