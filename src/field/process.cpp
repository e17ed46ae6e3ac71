// fprocess: process parameters (temperature, speed, flow, fan) as expressions over the design,
// evaluated like material fractions: a point takes the values of the innermost fprocess around
// the part of the design that holds it.
#include <fmt/format.h>

#include <cmath>

#include "node.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

namespace {

constexpr const char* kNames[kProcessParams] = {"temperature", "speed", "flow", "fan"};

struct ProcessNode : PropertyNode {
  std::vector<Expression> exprs;
  std::vector<ProcessParam> params;
  std::string label;
  bool exact_outside() const override { return children[0]->exact_outside(); }
  bool gradient(Vec3 p, Vec3& g, EvalState& s, std::size_t depth) const override {
    return children[0]->gradient(p, g, s, depth + 1);
  }
  void process(Vec3 p, ProcessValues& out, EvalState& s, std::size_t depth) const override {
    // Inner nodes first: the innermost fprocess that sets a parameter wins.
    children[0]->process(p, out, s, depth + 1);
    bool need_d = false;
    for (const auto& e : exprs) need_d |= s.expr(e).uses_d;
    const double d = need_d ? children[0]->value(p, s, depth + 1) : 0.0;
    for (std::size_t i = 0; i < exprs.size(); ++i) {
      const int k = static_cast<int>(params[i]);
      if (!std::isnan(out.value[k])) continue;
      const double v = s.expr(exprs[i]).eval(p, d);
      if (!std::isfinite(v))
        throw GeometryError(fmt::format("{}: {} = {} is {} at ({:g}, {:g}, {:g}): a process value "
                                        "must be a finite number everywhere in the part",
                                        label, kNames[k], exprs[i].text, v, p.x, p.y, p.z),
                            {"", 0, ""});
      out.value[k] = v;
      out.node[k] = &label;
    }
  }
  bool has_process() const override { return true; }
  bool has_expressions() const override { return true; }
};

}  // namespace

const char* to_string(ProcessParam p) {
  return kNames[static_cast<int>(p)];
}

bool process_param_from_string(const std::string& name, ProcessParam* out) {
  for (int k = 0; k < kProcessParams; ++k)
    if (name == kNames[k]) {
      *out = static_cast<ProcessParam>(k);
      return true;
    }
  return false;
}

ProcessValues::ProcessValues() {
  for (int k = 0; k < kProcessParams; ++k) {
    value[k] = std::nan("");
    node[k] = nullptr;
  }
}

void FieldNode::process(Vec3 p, ProcessValues& out, EvalState& s, std::size_t depth) const {
  if (!children.empty()) children.front()->process(p, out, s, depth + 1);
}

bool FieldNode::has_process() const {
  for (const auto& c : children)
    if (c->has_process()) return true;
  return false;
}

Field fprocess(Field child, std::vector<Expression> values, std::vector<std::string> params,
               std::string label) {
  if (child.empty()) throw GeometryError("fprocess needs a child");
  if (values.size() != params.size())
    throw GeometryError(
        fmt::format("fprocess: {} expressions but {} parameters", values.size(), params.size()));
  if (values.empty()) throw GeometryError("fprocess: needs at least one parameter");
  auto n = std::make_shared<ProcessNode>();
  for (std::size_t i = 0; i < params.size(); ++i) {
    ProcessParam p;
    if (!process_param_from_string(params[i], &p))
      throw GeometryError("fprocess: unknown parameter '" + params[i] +
                          "' (temperature, speed, flow or fan)");
    for (ProcessParam q : n->params)
      if (q == p) throw GeometryError("fprocess: '" + params[i] + "' is given twice");
    check_expression(values[i].text);
    n->params.push_back(p);
  }
  n->exprs = std::move(values);
  n->label = std::move(label);
  n->children.push_back(child.ptr());
  return Field(n);
}

}  // namespace trellis
