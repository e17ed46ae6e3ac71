// User expressions through muparser. One compiled parser per expression per evaluator, because a
// muparser Parser binds its variables by address and is not thread-safe. muparser parses and
// checks; the values come from its bytecode compiled once (expr_program.hpp), the same bits.
#include <muParser.h>

#include <cmath>
#include <numbers>

#include "expr_program.hpp"
#include "node.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

void ExprVars::set(Vec3 p, double distance, bool polar) {
  x = p.x;
  y = p.y;
  z = p.z;
  d = distance;
  if (!polar) return;
  rho = std::hypot(p.x, p.y);
  phic = std::atan2(p.y, p.x);
  r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
  theta = r > 0 ? std::acos(std::clamp(p.z / r, -1.0, 1.0)) : 0.0;
  phis = phic;
}

namespace {

double fn_floor(double v) {
  return std::floor(v);
}
double fn_ceil(double v) {
  return std::ceil(v);
}
double fn_mod(double a, double b) {
  return std::fmod(a, b);
}
double fn_pow(double a, double b) {
  return std::pow(a, b);
}
double fn_clamp(double v, double lo, double hi) {
  return std::clamp(v, lo, hi);
}

void setup(mu::Parser& parser, ExprVars& v) {
  parser.DefineConst("pi", std::numbers::pi);
  parser.DefineConst("e", std::numbers::e);
  parser.DefineVar("x", &v.x);
  parser.DefineVar("y", &v.y);
  parser.DefineVar("z", &v.z);
  parser.DefineVar("rho", &v.rho);
  parser.DefineVar("phic", &v.phic);
  parser.DefineVar("phi", &v.phic);  // the FGM paper's listings write phi for phic
  parser.DefineVar("r", &v.r);
  parser.DefineVar("theta", &v.theta);
  parser.DefineVar("phis", &v.phis);
  parser.DefineVar("d", &v.d);
  parser.DefineFun("floor", fn_floor);
  parser.DefineFun("ceil", fn_ceil);
  parser.DefineFun("mod", fn_mod);
  parser.DefineFun("fmod", fn_mod);
  parser.DefineFun("pow", fn_pow);
  parser.DefineFun("clamp", fn_clamp);
}

}  // namespace

CompiledExpr::CompiledExpr() : parser(std::make_unique<mu::Parser>()) {
  setup(*parser, vars);
}
CompiledExpr::~CompiledExpr() = default;

double CompiledExpr::eval(Vec3 p, double distance) {
  if (program) {
    double v;
    program->run(&p, &distance, 1, &v);
    return v;
  }
  vars.set(p, distance, uses_polar);
  try {
    return parser->Eval();
  } catch (const mu::Parser::exception_type& e) {
    // Checked at construction; only evaluation-time failures reach here.
    return std::numeric_limits<double>::quiet_NaN();
  }
}

void CompiledExpr::eval(const Vec3* p, const double* d, std::size_t n, double* out) {
  if (program) return program->run(p, d, n, out);
  for (std::size_t i = 0; i < n; ++i) {
    vars.set(p[i], d ? d[i] : 0.0, uses_polar);
    try {
      out[i] = parser->Eval();
    } catch (const mu::Parser::exception_type&) {
      out[i] = std::numeric_limits<double>::quiet_NaN();
    }
  }
}

void check_expression(const std::string& text, long* error_column) {
  CompiledExpr c;
  try {
    c.parser->SetExpr(text);
    c.vars.set({1, 1, 1}, 0);
    c.parser->Eval();
  } catch (const mu::Parser::exception_type& e) {
    const long pos = static_cast<long>(e.GetPos());
    const long col = pos >= 0 ? pos + 1 : 1;
    if (error_column) *error_column = col;
    throw ParseError("bad expression \"" + text + "\": " + e.GetMsg());
  }
}

bool constant_expression(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  while (end && (*end == ' ' || *end == '\t')) ++end;
  if (!end || *end != '\0' || end == text.c_str()) return false;
  if (value) *value = v;
  return true;
}

CompiledExpr& EvalState::expr(const Expression& e) {
  auto it = exprs.find(&e);
  if (it != exprs.end()) return *it->second;
  auto c = std::make_unique<CompiledExpr>();
  try {
    c->parser->SetExpr(e.text);
  } catch (const mu::Parser::exception_type& err) {
    throw ParseError("bad expression \"" + e.text + "\": " + err.GetMsg());
  }
  try {
    const auto used = c->parser->GetUsedVar();
    c->uses_d = used.count("d") > 0;
    c->uses_polar = false;
    for (const char* v : {"rho", "phic", "phi", "r", "theta", "phis"})
      c->uses_polar |= used.count(v) > 0;
  } catch (const mu::Parser::exception_type&) {
    // Keep computing every variable.
  }
  try {
    c->vars.set({1, 1, 1}, 0);
    c->parser->Eval();  // muparser makes its bytecode on the first evaluation
    c->program = ExprProgram::compile({{c->parser.get(), &c->vars}});
  } catch (const mu::Parser::exception_type&) {
    // muparser evaluates it (and says what is wrong where it is evaluated).
  }
  if (c->program) {
    c->uses_d = c->program->uses_d();
    c->uses_polar = c->program->uses_polar();
  }
  auto& ref = *c;
  exprs.emplace(&e, std::move(c));
  return ref;
}

ExprProgram* EvalState::program(const void* owner, const std::vector<Expression>& list) {
  struct Holder {
    std::unique_ptr<ExprProgram> program;
  };
  auto& slot = caches[owner];
  if (!slot) {
    auto h = std::make_shared<Holder>();
    std::vector<ExprProgram::Source> sources;
    bool all = true;
    for (const auto& e : list) {
      CompiledExpr& c = expr(e);
      all = all && c.program;
      sources.push_back({c.parser.get(), &c.vars});
    }
    if (all) h->program = ExprProgram::compile(sources);
    slot = std::move(h);
  }
  return static_cast<Holder*>(slot.get())->program.get();
}

}  // namespace trellis
