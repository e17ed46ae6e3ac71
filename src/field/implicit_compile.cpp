// Function graphs of the 3MF Implicit Extension compiled into straight-line code
// (implicit_compile.hpp). Section numbers: 3MF Volumetric & Implicit Extension v1.0, Part II.
#include "implicit_compile.hpp"

#include <algorithm>
#include <initializer_list>
#include <set>
#include <vector>

namespace trellis::implicit {

namespace {

// ---------------------------------------------------------------- function graphs (Part II)

struct Slot {
  Type type = Type::Scalar;
  int off = 0;
  long long resource = 0;
};

std::optional<Type> type_of(std::string_view element) {
  if (element == "scalar" || element == "scalarref") return Type::Scalar;
  if (element == "vector" || element == "vectorref") return Type::Vector;
  if (element == "matrix" || element == "matrixref") return Type::Matrix;
  if (element == "resourceid" || element == "resourceref") return Type::Resource;
  return std::nullopt;
}

const std::map<std::string, Code>& unary_nodes() {
  static const std::map<std::string, Code> m = {
      {"abs", Code::Abs},     {"sin", Code::Sin},     {"sinus", Code::Sin},
      {"cos", Code::Cos},     {"cosinus", Code::Cos}, {"tan", Code::Tan},
      {"arcsin", Code::Asin}, {"arccos", Code::Acos}, {"arctan", Code::Atan},
      {"sqrt", Code::Sqrt},   {"exp", Code::Exp},     {"log", Code::Log},
      {"log2", Code::Log2},   {"log10", Code::Log10}, {"cosh", Code::Cosh},
      {"sinh", Code::Sinh},   {"tanh", Code::Tanh},   {"round", Code::Round},
      {"ceil", Code::Ceil},   {"floor", Code::Floor}, {"sign", Code::Sign},
      {"fract", Code::Fract}};
  return m;
}

const std::map<std::string, Code>& binary_nodes() {
  static const std::map<std::string, Code> m = {
      {"addition", Code::Add}, {"subtraction", Code::Sub}, {"multiplication", Code::Mul},
      {"division", Code::Div}, {"min", Code::Min},         {"max", Code::Max},
      {"fmod", Code::Fmod},    {"mod", Code::Mod},         {"pow", Code::Pow},
      {"arctan2", Code::Atan2}};
  return m;
}

class Compiler {
 public:
  Compiler(const Ctx& ctx, const Resources& res, Program& prog)
      : ctx_(ctx), res_(res), prog_(prog) {}

  // The function resource `id` (a levelset's or a functioncall's), or a refusal at `where`.
  const El& function(long long id, const El& where) const {
    auto it = res_.functions.find(id);
    if (it == res_.functions.end())
      ctx_.fail(where, fmt::format("there is no function with id {}", id));
    const El& f = *it->second;
    if (f.name == "function" && f.kids.empty())
      ctx_.fail(f, fmt::format("function {} has no nodes", id));
    return f;
  }

  // The declared inputs of a function: name → type (Part II ch. 3, <i:in>; a
  // <functionfromimage3d> takes the vector "pos", Part I §2.2).
  std::map<std::string, std::pair<Type, const El*>> inputs_of(const El& fn) const {
    std::map<std::string, std::pair<Type, const El*>> out;
    if (is_image(fn)) out["pos"] = {Type::Vector, &fn};
    if (const El* in = child(fn, "in"))
      for (const auto& k : in->kids) {
        const auto t = type_of(k->name);
        const char* id = k->attr("identifier");
        if (!t || !id)
          ctx_.fail(*k,
                    "a function input must be a <scalar>, <vector>, <matrix> or "
                    "<resourceid> with an identifier");
        out[id] = {*t, k.get()};
      }
    return out;
  }

  static bool is_image(const El& fn) { return fn.name == "functionfromimage3d"; }

  // Compiles function `fn` (resource `id`) with its inputs bound: its outputs by name.
  std::map<std::string, Slot> instantiate(const El& fn, long long id,
                                          const std::map<std::string, Slot>& inputs) {
    if (std::find(stack_.begin(), stack_.end(), id) != stack_.end())
      ctx_.fail(fn, fmt::format("function {} calls itself (through functioncall nodes): the "
                                "graph must be acyclic (Part II §6.1)",
                                id));
    if (is_image(fn)) return image_outputs(fn, inputs.at("pos"));
    stack_.push_back(id);
    Scope sc{&fn, id, &inputs, {}, {}, {}};
    for (const auto& k : fn.kids) {
      if (k->name == "in" || k->name == "out") continue;
      const char* nid = k->attr("identifier");
      if (!nid) ctx_.fail(*k, fmt::format("node <{}> has no identifier", k->name));
      if (std::string(nid) == "inputs" || std::string(nid) == "outputs")
        ctx_.fail(*k, fmt::format("a node may not be called \"{}\" (Part II ch. 4)", nid));
      if (!sc.nodes.emplace(nid, k.get()).second)
        ctx_.fail(*k, fmt::format("two nodes are called \"{}\" in function {}", nid, id));
    }
    std::map<std::string, Slot> out;
    const El* o = child(fn, "out");
    if (!o) ctx_.fail(fn, fmt::format("function {} has no <out>", id));
    for (const auto& k : o->kids) {
      const auto t = type_of(k->name);
      const char* name = k->attr("identifier");
      if (!t || !name)
        ctx_.fail(*k,
                  "a function output must be a <scalarref>, <vectorref> or <matrixref> "
                  "with an identifier and a ref");
      out[name] = resolve(sc, *k, *t);
    }
    stack_.pop_back();
    return out;
  }

 private:
  // A <functionfromimage3d> sampled at `uvw`: its outputs (Part I §2.2) red, green, blue, alpha
  // and the vector color (red, green, blue).
  std::map<std::string, Slot> image_outputs(const El& fn, const Slot& uvw) {
    Instr in;
    in.op = Code::Image;
    in.n = 4;
    in.dst = prog_.alloc(4);
    in.a = uvw.off;
    in.b = static_cast<std::int32_t>(prog_.images.size());
    prog_.images.push_back(res_.image(fn));
    prog_.code.push_back(in);
    std::map<std::string, Slot> out;
    const char* names[4] = {"red", "green", "blue", "alpha"};
    for (int i = 0; i < 4; ++i) out[names[i]] = Slot{Type::Scalar, in.dst + i, 0};
    out["color"] = Slot{Type::Vector, in.dst, 0};
    return out;
  }

  struct Scope {
    const El* fn;
    long long id;
    const std::map<std::string, Slot>* inputs;
    std::map<std::string, const El*> nodes;
    std::map<std::string, std::map<std::string, Slot>> done;
    std::set<std::string> visiting;
  };

  std::string where(const Scope& sc, const El& node) const {
    const char* nid = node.attr("identifier");
    return fmt::format("function {}, node \"{}\" (<{}>)", sc.id, nid ? nid : "", node.name);
  }

  // The slot a reference element (<scalarref ref="node.output"> …) names, of type `want`.
  Slot resolve(Scope& sc, const El& ref, Type want) {
    const char* r = ref.attr("ref");
    if (!r) ctx_.fail(ref, fmt::format("<{}> has no ref", ref.name));
    const std::string s = r;
    const auto dot = s.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == s.size())
      ctx_.fail(ref, fmt::format("ref=\"{}\" is not \"node.output\" (Part II §2.1)", s));
    const std::string node = s.substr(0, dot), output = s.substr(dot + 1);
    Slot got;
    if (node == "inputs") {
      auto it = sc.inputs->find(output);
      if (it == sc.inputs->end())
        ctx_.fail(ref,
                  fmt::format("ref=\"{}\": function {} has no input \"{}\"", s, sc.id, output));
      got = it->second;
    } else {
      auto n = sc.nodes.find(node);
      if (n == sc.nodes.end())
        ctx_.fail(ref, fmt::format("ref=\"{}\": function {} has no node \"{}\"", s, sc.id, node));
      const auto& outs = compile(sc, *n->second);
      auto it = outs.find(output);
      if (it == outs.end())
        ctx_.fail(ref,
                  fmt::format("ref=\"{}\": node \"{}\" has no output \"{}\"", s, node, output));
      got = it->second;
    }
    if (got.type != want)
      ctx_.fail(ref, fmt::format("<{}> ref=\"{}\" names a {}, not a {} (Part II §6.1: inputs "
                                 "reference outputs of the same type)",
                                 ref.name, s, to_string(got.type), to_string(want)));
    return got;
  }

  int constant(std::initializer_list<double> v) {
    const int o = prog_.alloc(static_cast<int>(v.size()));
    std::copy(v.begin(), v.end(), prog_.init.begin() + o);
    return o;
  }

  const std::map<std::string, Slot>& compile(Scope& sc, const El& node) {
    const std::string nid = node.attr("identifier");
    if (auto it = sc.done.find(nid); it != sc.done.end()) return it->second;
    // Limits that keep a hostile graph from exhausting the stack (references are followed
    // recursively) or memory (functioncall compiles the callee in place at every call).
    if (++depth_ > kMaxChain)
      ctx_.fail(node, fmt::format("{}: references chain deeper than {} nodes; not read",
                                  where(sc, node), kMaxChain));
    if (prog_.code.size() > kMaxOps)
      ctx_.fail(node, fmt::format("{}: the graph expands to more than {} operations (nested "
                                  "function calls); not read",
                                  where(sc, node), kMaxOps));
    if (!sc.visiting.insert(nid).second)
      ctx_.fail(node, where(sc, node) +
                          " depends on itself: the graph must be acyclic (Part II "
                          "§6.1)");
    auto outs = compile_node(sc, node);
    --depth_;
    sc.visiting.erase(nid);
    return sc.done[nid] = std::move(outs);
  }

  std::map<std::string, Slot> compile_node(Scope& sc, const El& node) {
    const std::string kind = lower(node.name);
    // Inputs, in order, resolved (and type-checked against their reference element).
    std::vector<std::pair<std::string, Slot>> ins;
    if (const El* in = child(node, "in"))
      for (const auto& k : in->kids) {
        const auto t = type_of(k->name);
        const char* id = k->attr("identifier");
        if (!t || !id)
          ctx_.fail(*k, where(sc, node) +
                            ": an input must be a <scalarref>, <vectorref>, "
                            "<matrixref> or <resourceref> with an identifier");
        ins.emplace_back(id, resolve(sc, *k, *t));
      }
    std::vector<std::pair<std::string, std::pair<Type, const El*>>> decl;
    if (const El* out = child(node, "out"))
      for (const auto& k : out->kids) {
        const auto t = type_of(k->name);
        const char* id = k->attr("identifier");
        if (!t || !id)
          ctx_.fail(*k, where(sc, node) +
                            ": an output must be a <scalar>, "
                            "<vector>, <matrix> or <resourceid> "
                            "with an identifier");
        decl.push_back({id, {*t, k.get()}});
      }
    auto get = [&](const char* name, std::optional<Type> type = {}) -> Slot {
      for (const auto& [k, v] : ins)
        if (k == name) {
          if (type && v.type != *type)
            ctx_.fail(node, fmt::format("{}: input \"{}\" is a {}, not a {}", where(sc, node), name,
                                        to_string(v.type), to_string(*type)));
          return v;
        }
      ctx_.fail(node, fmt::format("{} has no input \"{}\"", where(sc, node), name));
    };
    // The one operand of a unary node: "A" (the 2022 draft names some otherwise).
    auto only = [&]() -> Slot {
      if (ins.size() == 1) return ins[0].second;
      return get("A");
    };
    auto result = [&](Type t) {
      Slot s;
      s.type = t;
      s.off = prog_.alloc(width(t));
      return s;
    };
    auto numeric = [&](const Slot& s, const char* what) {
      if (s.type == Type::Resource)
        ctx_.fail(node,
                  fmt::format("{}: {} is a resource id, not a number", where(sc, node), what));
    };
    auto emit = [&](Code op, const Slot& dst, int a, int b = 0, int c = 0, int d = 0) {
      Instr in;
      in.op = op;
      in.n = static_cast<std::uint8_t>(std::max(width(dst.type), 1));
      in.dst = dst.off, in.a = a, in.b = b, in.c = c, in.d = d;
      prog_.code.push_back(in);
    };
    // One result: every declared output names it (its declared type must match).
    auto single = [&](const Slot& r) {
      std::map<std::string, Slot> m;
      for (const auto& [name, td] : decl) {
        if (td.first != r.type)
          ctx_.fail(*td.second,
                    fmt::format("{}: output \"{}\" is declared a {} but is a {}", where(sc, node),
                                name, to_string(td.first), to_string(r.type)));
        m[name] = r;
      }
      if (decl.empty()) m["result"] = r;
      return m;
    };
    auto same_type = [&](std::initializer_list<std::pair<const char*, Slot>> ops) {
      const Slot& first = ops.begin()->second;
      for (const auto& [name, s] : ops) {
        numeric(s, name);
        if (s.type != first.type)
          ctx_.fail(node, fmt::format("{}: inputs {} and {} differ in type ({} and {}); the "
                                      "node takes operands of one type (Part II ch. 5)",
                                      where(sc, node), ops.begin()->first, name,
                                      to_string(first.type), to_string(s.type)));
      }
      return first.type;
    };

    if (auto u = unary_nodes().find(kind); u != unary_nodes().end()) {
      const Slot a = only();
      numeric(a, "A");
      const Slot r = result(a.type);
      emit(u->second, r, a.off);
      return single(r);
    }
    if (auto b = binary_nodes().find(kind); b != binary_nodes().end()) {
      const Slot a = get("A"), bb = get("B");
      const Slot r = result(same_type({{"A", a}, {"B", bb}}));
      emit(b->second, r, a.off, bb.off);
      return single(r);
    }
    if (kind == "clamp") {
      const Slot a = get("A"), lo = get("min"), hi = get("max");
      const Slot r = result(same_type({{"A", a}, {"min", lo}, {"max", hi}}));
      emit(Code::Clamp, r, a.off, lo.off, hi.off);
      return single(r);
    }
    if (kind == "select") {
      const Slot a = get("A"), b = get("B"), c = get("C"), d = get("D");
      const Slot r = result(same_type({{"A", a}, {"B", b}, {"C", c}, {"D", d}}));
      emit(Code::Select, r, a.off, b.off, c.off, d.off);
      return single(r);
    }
    if (kind == "constant") {
      Slot r;
      r.off = constant({number(ctx_, node, "value")});
      return single(r);
    }
    if (kind == "constvec") {
      Slot r;
      r.type = Type::Vector;
      r.off = constant({number(ctx_, node, "x"), number(ctx_, node, "y"), number(ctx_, node, "z")});
      return single(r);
    }
    if (kind == "constmat") {
      const std::vector<double> m = numbers(ctx_, node, "matrix", 16);
      if (m.empty()) ctx_.fail(node, where(sc, node) + " has no matrix attribute");
      Slot r;
      r.type = Type::Matrix;
      r.off = prog_.alloc(16);
      std::copy(m.begin(), m.end(), prog_.init.begin() + r.off);
      return single(r);
    }
    if (kind == "constresourceid") {
      Slot r;
      r.type = Type::Resource;
      r.resource = resource_id(ctx_, node, node.attr("value") ? "value" : "resourceid");
      return single(r);
    }
    if (kind == "composevector") {
      const Slot x = get("x", Type::Scalar), y = get("y", Type::Scalar), z = get("z", Type::Scalar);
      const Slot r = result(Type::Vector);
      const Slot* parts[3] = {&x, &y, &z};
      for (int i = 0; i < 3; ++i) {
        Instr in;
        in.op = Code::Copy;
        in.n = 1;
        in.dst = r.off + i;
        in.a = parts[i]->off;
        prog_.code.push_back(in);
      }
      return single(r);
    }
    if (kind == "vectorfromscalar") {
      const Slot a = only();
      if (a.type != Type::Scalar) get("A", Type::Scalar);
      const Slot r = result(Type::Vector);
      emit(Code::Splat, r, a.off);
      return single(r);
    }
    if (kind == "decomposevector") {
      const Slot a = only();
      if (a.type != Type::Vector) ctx_.fail(node, where(sc, node) + ": the input must be a vector");
      std::map<std::string, Slot> m;
      for (const char* c : {"x", "y", "z"}) {
        Slot s;
        s.off = a.off + (c[0] - 'x');
        m[c] = s;
      }
      for (const auto& [name, td] : decl)
        if (!m.count(name) || td.first != Type::Scalar)
          ctx_.fail(*td.second, where(sc, node) + ": the outputs are the scalars x, y and z");
      return m;
    }
    if (kind == "composematrix") {
      const Slot r = result(Type::Matrix);
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
          const std::string name = fmt::format("m{}{}", i, j);
          Instr in;
          in.op = Code::Copy;
          in.n = 1;
          in.dst = r.off + i * 4 + j;
          in.a = get(name.c_str(), Type::Scalar).off;
          prog_.code.push_back(in);
        }
      return single(r);
    }
    if (kind == "matrixfromcolumns" || kind == "matrixfromrows") {
      const Slot a = get("A", Type::Vector), b = get("B", Type::Vector), c = get("C", Type::Vector),
                 d = get("D", Type::Vector);
      const Slot r = result(Type::Matrix);
      emit(kind == "matrixfromcolumns" ? Code::FromColumns : Code::FromRows, r, a.off, b.off, c.off,
           d.off);
      return single(r);
    }
    if (kind == "dot" || kind == "cross") {
      const Slot a = get("A", Type::Vector), b = get("B", Type::Vector);
      const Slot r = result(kind == "dot" ? Type::Scalar : Type::Vector);
      emit(kind == "dot" ? Code::Dot : Code::Cross, r, a.off, b.off);
      return single(r);
    }
    if (kind == "length") {
      const Slot a = only();
      if (a.type != Type::Vector) get("A", Type::Vector);
      const Slot r = result(Type::Scalar);
      emit(Code::Length, r, a.off);
      return single(r);
    }
    if (kind == "matrixvectormultiplication" || kind == "matvecmultiplication") {
      const Slot a = get("A", Type::Matrix), b = get("B", Type::Vector);
      const Slot r = result(Type::Vector);
      emit(Code::MatVec, r, a.off, b.off);
      return single(r);
    }
    if (kind == "transpose" || kind == "inverse") {
      const Slot a = only();
      if (a.type != Type::Matrix) get("A", Type::Matrix);
      const Slot r = result(Type::Matrix);
      emit(kind == "transpose" ? Code::Transpose : Code::Inverse, r, a.off);
      return single(r);
    }
    if (kind == "functioncall") {
      const Slot fid = get("functionID", Type::Resource);
      const El& callee = function(fid.resource, node);
      std::map<std::string, Slot> args;
      for (const auto& [name, s] : ins)
        if (name != "functionID") args[name] = s;
      for (const auto& [name, td] : inputs_of(callee)) {
        auto it = args.find(name);
        if (it == args.end())
          ctx_.fail(node, fmt::format("{}: function {} takes input \"{}\", which the call does "
                                      "not give",
                                      where(sc, node), fid.resource, name));
        if (it->second.type != td.first)
          ctx_.fail(node, fmt::format("{}: input \"{}\" is a {}, function {} takes a {}",
                                      where(sc, node), name, to_string(it->second.type),
                                      fid.resource, to_string(td.first)));
      }
      auto outs = instantiate(callee, fid.resource, args);
      std::map<std::string, Slot> m;
      for (const auto& [name, td] : decl) {
        auto it = outs.find(name);
        if (it == outs.end() || it->second.type != td.first)
          ctx_.fail(*td.second,
                    fmt::format("{}: function {} has no {} output \"{}\"", where(sc, node),
                                fid.resource, to_string(td.first), name));
        m[name] = it->second;
      }
      return m;
    }
    if (kind == "mesh" || kind == "unsignedmesh") {
      // The distance to the mesh object named by the resource input "mesh" (the XSD; the
      // specification's example also writes it as an objectid attribute).
      const Slot pos = get("pos", Type::Vector);
      const bool given =
          std::any_of(ins.begin(), ins.end(), [](const auto& i) { return i.first == "mesh"; });
      if (!given && !node.attr("objectid"))
        ctx_.fail(node, where(sc, node) + " has no input \"mesh\" (the mesh object's id)");
      const long long id =
          given ? get("mesh", Type::Resource).resource : resource_id(ctx_, node, "objectid");
      Instr in;
      in.op = Code::Distance;
      in.dst = prog_.alloc(1);
      in.a = pos.off;
      in.b = static_cast<std::int32_t>(prog_.fields.size());
      prog_.fields.push_back(res_.mesh(id, kind == "mesh", node));
      prog_.code.push_back(in);
      return single(Slot{Type::Scalar, in.dst, 0});
    }
    ctx_.fail(node, fmt::format("{}: <{}> is not a node type this reader knows (Part II ch. 5 "
                                "lists the native nodes)",
                                where(sc, node), node.name));
  }

  static constexpr int kMaxChain = 1000;
  static constexpr std::size_t kMaxOps = 1000000;
  const Ctx& ctx_;
  const Resources& res_;
  Program& prog_;
  std::vector<long long> stack_;
  int depth_ = 0;
};

}  // namespace

void compile_level_set(const Ctx& c, const Resources& resources, long long fid, std::string channel,
                       const El& at, Program& program) {
  Compiler comp(c, resources, program);
  const El& fn = comp.function(fid, at);
  for (const auto& [name, td] : comp.inputs_of(fn))
    if (name != "pos" || td.first != Type::Vector)
      c.fail(at, fmt::format("function {} takes the {} input \"{}\": a level set gives its "
                             "function only the vector \"pos\" (Part I §4.1.1)",
                             fid, to_string(td.first), name));
  program.pos = program.alloc(3);
  Slot pos;
  pos.type = Type::Vector;
  pos.off = program.pos;
  const auto outs = comp.instantiate(fn, fid, {{"pos", pos}});
  if (channel.empty() && fn.name == "functionfromimage3d") channel = "red";
  if (channel.empty())  // the draft's boundary: the function's first scalar output
    if (const El* o = child(fn, "out"))
      for (const auto& k : o->kids)
        if (k->name == "scalarref" && k->attr("identifier")) {
          channel = k->attr("identifier");
          break;
        }
  const auto it = outs.find(channel);
  if (it == outs.end() || it->second.type != Type::Scalar)
    c.fail(at,
           fmt::format("function {} has no scalar output \"{}\" for the level set", fid, channel));
  program.out = it->second.off;
}

}  // namespace trellis::implicit
