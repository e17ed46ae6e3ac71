// Reads 3MF level-set designs (implicit_3mf.hpp): libzip for the package, expat for the model
// part (a small element tree with every element's line and column), then the function graphs
// compiled into implicit_graph.hpp's program. Section numbers: 3MF Volumetric & Implicit
// Extension v1.0, Part I (volumetric) and Part II (implicit).
#include <expat.h>
#include <fmt/format.h>
#include <zip.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "implicit_3mf_module.hpp"
#include "implicit_graph.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh.hpp"

namespace trellis::implicit {

namespace {

// ---------------------------------------------------------------- package and XML

std::optional<std::string> read_part(zip_t* z, std::string name, const std::string& file) {
  if (!name.empty() && name[0] == '/') name.erase(0, 1);
  zip_stat_t st;
  if (zip_stat(z, name.c_str(), ZIP_FL_ENC_GUESS, &st) != 0) return std::nullopt;
  zip_file_t* f = zip_fopen(z, name.c_str(), 0);
  if (!f) throw ParseError("cannot open part /" + name + " of the package", {file});
  std::string out(static_cast<std::size_t>(st.size), '\0');
  const zip_int64_t n = out.empty() ? 0 : zip_fread(f, out.data(), st.size);
  zip_fclose(f);
  if (n != static_cast<zip_int64_t>(st.size))
    throw ParseError("cannot read part /" + name + " of the package (damaged)", {file});
  return out;
}

struct Zip {
  zip_t* z = nullptr;
  ~Zip() {
    if (z) zip_discard(z);
  }
};

struct El {
  std::string uri, name;                                   // name: the local name
  std::vector<std::pair<std::string, std::string>> attrs;  // local names
  std::vector<std::unique_ptr<El>> kids;
  long line = 0, column = 0;
  const char* attr(std::string_view n) const {
    for (const auto& [k, v] : attrs)
      if (k == n) return v.c_str();
    return nullptr;
  }
};

// Elements nested deeper than this are refused (the tree is freed recursively; 3MF models nest
// a handful of levels).
constexpr std::size_t kMaxDepth = 200;

struct Tree {
  std::unique_ptr<El> root;
  std::vector<El*> stack;
  XML_Parser parser = nullptr;
  std::string problem;
};

std::pair<std::string, std::string> split_name(const XML_Char* s) {
  const char* space = std::strrchr(s, ' ');
  if (!space) return {{}, s};
  return {std::string(s, static_cast<std::size_t>(space - s)), space + 1};
}

void on_start(void* self, const XML_Char* name, const XML_Char** atts) {
  auto* t = static_cast<Tree*>(self);
  if (t->stack.size() >= kMaxDepth) {
    t->problem = fmt::format("elements nest deeper than {} levels", kMaxDepth);
    XML_StopParser(t->parser, XML_FALSE);
    return;
  }
  auto e = std::make_unique<El>();
  std::tie(e->uri, e->name) = split_name(name);
  for (int i = 0; atts[i]; i += 2) e->attrs.emplace_back(split_name(atts[i]).second, atts[i + 1]);
  e->line = static_cast<long>(XML_GetCurrentLineNumber(t->parser));
  e->column = static_cast<long>(XML_GetCurrentColumnNumber(t->parser)) + 1;
  El* raw = e.get();
  if (t->stack.empty())
    t->root = std::move(e);
  else
    t->stack.back()->kids.push_back(std::move(e));
  t->stack.push_back(raw);
}

void on_end(void* self, const XML_Char*) {
  auto* t = static_cast<Tree*>(self);
  if (!t->stack.empty()) t->stack.pop_back();
}

std::unique_ptr<El> parse_xml(const std::string& bytes, const std::string& file,
                              const std::string& part) {
  Tree t;
  XML_Parser p = XML_ParserCreateNS("UTF-8", ' ');
  t.parser = p;
  XML_SetUserData(p, &t);
  XML_SetElementHandler(p, on_start, on_end);
  const XML_Status s = XML_Parse(p, bytes.data(), static_cast<int>(bytes.size()), XML_TRUE);
  const long line = static_cast<long>(XML_GetCurrentLineNumber(p));
  const long column = static_cast<long>(XML_GetCurrentColumnNumber(p)) + 1;
  std::string why = t.problem;
  if (why.empty() && s == XML_STATUS_ERROR) why = XML_ErrorString(XML_GetErrorCode(p));
  XML_ParserFree(p);
  if (!why.empty())
    throw ParseError(why, {file, line, part, column});
  return std::move(t.root);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The model part: the start part of the package's relationships (3MF Core §2.1), else the
// usual /3D/3dmodel.model.
std::string model_part_name(zip_t* z, const std::string& file) {
  if (auto rels = read_part(z, "_rels/.rels", file)) {
    try {
      auto root = parse_xml(*rels, file, "/_rels/.rels");
      for (const auto& r : root->kids) {
        const char* type = r->attr("Type");
        const char* target = r->attr("Target");
        if (type && target && std::string(type).ends_with("/3dmodel")) return target;
      }
    } catch (const ParseError&) {
      // The model part's usual name below; a broken .rels is not what this reader checks.
    }
  }
  return "/3D/3dmodel.model";
}

// ---------------------------------------------------------------- the model

struct Ctx {
  std::string file, part;
  [[noreturn]] void fail(const El& e, const std::string& why) const {
    throw ParseError(why, {file, e.line, part, e.column});  // "file:line:column: part: why"
  }
};

const El* child(const El& e, std::string_view name) {
  for (const auto& k : e.kids)
    if (k->name == name) return k.get();
  return nullptr;
}

double number(const Ctx& c, const El& e, const char* attr, std::optional<double> dflt = {}) {
  const char* s = e.attr(attr);
  if (!s) {
    if (dflt) return *dflt;
    c.fail(e, fmt::format("<{}> has no {} attribute", e.name, attr));
  }
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  while (end && *end == ' ') ++end;
  if (end == s || *end != '\0' || !std::isfinite(v))
    c.fail(e, fmt::format("<{}> {}=\"{}\" is not a number", e.name, attr, s));
  return v;
}

std::vector<double> numbers(const Ctx& c, const El& e, const char* attr, std::size_t count) {
  const char* s = e.attr(attr);
  std::vector<double> out;
  if (!s) return out;
  const char* p = s;
  while (true) {
    while (*p && std::isspace(static_cast<unsigned char>(*p))) ++p;
    if (!*p) break;
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p || !std::isfinite(v))
      c.fail(e, fmt::format("<{}> {}=\"{}\" is not a list of numbers", e.name, attr, s));
    out.push_back(v);
    p = end;
  }
  if (out.size() != count)
    c.fail(e, fmt::format("<{}> {} has {} numbers, not {}", e.name, attr, out.size(), count));
  return out;
}

long long resource_id(const Ctx& c, const El& e, const char* attr) {
  const char* s = e.attr(attr);
  if (!s) c.fail(e, fmt::format("<{}> has no {} attribute", e.name, attr));
  char* end = nullptr;
  const long long v = std::strtoll(s, &end, 10);
  if (end == s || *end != '\0' || v <= 0)
    c.fail(e, fmt::format("<{}> {}=\"{}\" is not a resource id", e.name, attr, s));
  return v;
}

// A 3MF ST_Matrix3D (Core §3.3: row vectors, p' = [x y z 1] · M, the last row the translation)
// as an Affine.
Affine matrix3d(const Ctx& c, const El& e, const char* attr) {
  Affine a;
  const std::vector<double> m = numbers(c, e, attr, 12);
  if (m.empty()) return a;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) a.l[i][j] = m[static_cast<std::size_t>(j * 3 + i)];
    a.t[i] = m[static_cast<std::size_t>(9 + i)];
  }
  return a;
}

Affine compose(const Affine& outer, const Affine& inner) {  // outer ∘ inner
  Affine r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      r.l[i][j] = 0;
      for (int k = 0; k < 3; ++k) r.l[i][j] += outer.l[i][k] * inner.l[k][j];
    }
    r.t[i] = outer.t[i];
    for (int k = 0; k < 3; ++k) r.t[i] += outer.l[i][k] * inner.t[k];
  }
  return r;
}

std::optional<Affine> inverse(const Affine& a) {
  const auto& m = a.l;
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (!(std::abs(det) > 1e-300)) return std::nullopt;
  Affine r;
  r.l[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / det;
  r.l[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
  r.l[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
  r.l[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / det;
  r.l[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
  r.l[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
  r.l[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / det;
  r.l[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det;
  r.l[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
  for (int i = 0; i < 3; ++i)
    r.t[i] = -(r.l[i][0] * a.t[0] + r.l[i][1] * a.t[1] + r.l[i][2] * a.t[2]);
  return r;
}

double unit_mm(const Ctx& c, const El& model) {
  const char* u = model.attr("unit");
  if (!u) return 1;  // Core §3.4: millimeter by default
  const std::string s = u;
  if (s == "micron") return 0.001;
  if (s == "millimeter") return 1;
  if (s == "centimeter") return 10;
  if (s == "inch") return 25.4;
  if (s == "foot") return 304.8;
  if (s == "meter") return 1000;
  c.fail(model, "unknown unit \"" + s + "\"");
}

// Whether an element is a function resource (Part I §2.1): <i:implicitfunction>, the 2022
// draft's <v:function> holding nodes, or another type (functionfromimage3d, private).
bool is_function(const El& e) {
  return e.name == "implicitfunction" || e.name == "function" || e.name == "functionfromimage3d";
}

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
  Compiler(const Ctx& ctx, const std::map<long long, const El*>& functions, Program& prog)
      : ctx_(ctx), functions_(functions), prog_(prog) {}

  // The function resource `id` (a levelset's or a functioncall's), or a refusal at `where`.
  const El& function(long long id, const El& where) const {
    auto it = functions_.find(id);
    if (it == functions_.end())
      ctx_.fail(where, fmt::format("there is no function with id {}", id));
    const El& f = *it->second;
    if (f.name == "functionfromimage3d")
      ctx_.fail(where, fmt::format("function {} is a <functionfromimage3d> (volumetric image "
                                   "stack, Part I §2.2), which this reader does not read yet: "
                                   "only implicit functions (Part II ch. 3)",
                                   id));
    if (f.name == "function" && f.kids.empty())
      ctx_.fail(f, fmt::format("function {} has no nodes", id));
    return f;
  }

  // The declared inputs of a function: name → type (Part II ch. 3, <i:in>).
  std::map<std::string, std::pair<Type, const El*>> inputs_of(const El& fn) const {
    std::map<std::string, std::pair<Type, const El*>> out;
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

  // Compiles function `fn` (resource `id`) with its inputs bound: its outputs by name.
  std::map<std::string, Slot> instantiate(const El& fn, long long id,
                                          const std::map<std::string, Slot>& inputs) {
    if (std::find(stack_.begin(), stack_.end(), id) != stack_.end())
      ctx_.fail(fn, fmt::format("function {} calls itself (through functioncall nodes): the "
                                "graph must be acyclic (Part II §6.1)",
                                id));
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
    if (kind == "mesh" || kind == "unsignedmesh")
      ctx_.fail(node, fmt::format("{}: the distance to a mesh (Part II ch. 5, {}) is not read "
                                  "yet; give the part as a mesh object or a .vcad mesh()",
                                  where(sc, node), kind));
    ctx_.fail(node, fmt::format("{}: <{}> is not a node type this reader knows (Part II ch. 5 "
                                "lists the native nodes)",
                                where(sc, node), node.name));
  }

  static constexpr int kMaxChain = 1000;
  static constexpr std::size_t kMaxOps = 1000000;
  const Ctx& ctx_;
  const std::map<long long, const El*>& functions_;
  Program& prog_;
  std::vector<long long> stack_;
  int depth_ = 0;
};

// ---------------------------------------------------------------- objects and the build

bool truthy(const char* s) {
  return s && (std::string(s) == "true" || std::string(s) == "1");
}

// A core <mesh> (Core §4.1) in build millimetres: vertices through the item transform `m`.
TriangleMesh mesh_of(const Ctx& c, const El& mesh, const Affine& m, double mm) {
  TriangleMesh tm;
  const El* vs = child(mesh, "vertices");
  const El* ts = child(mesh, "triangles");
  if (!vs || !ts) c.fail(mesh, "<mesh> has no <vertices> or no <triangles>");
  for (const auto& v : vs->kids) {
    const Vec3 p = m.apply({number(c, *v, "x"), number(c, *v, "y"), number(c, *v, "z")});
    tm.vertices.push_back(p * mm);
  }
  for (const auto& t : ts->kids) {
    std::array<std::uint32_t, 3> tri{};
    const char* names[3] = {"v1", "v2", "v3"};
    for (int i = 0; i < 3; ++i) {
      const double v = number(c, *t, names[i]);
      if (!(v >= 0 && v < static_cast<double>(tm.vertices.size())) || v != std::floor(v))
        c.fail(*t, fmt::format("<triangle> {}={} names no vertex of the mesh ({} vertices)",
                               names[i], v, tm.vertices.size()));
      tri[static_cast<std::size_t>(i)] = static_cast<std::uint32_t>(v);
    }
    tm.triangles.push_back(tri);
  }
  if (tm.vertices.empty() || tm.triangles.empty()) c.fail(mesh, "the mesh is empty");
  return tm;
}

// Whether the mesh is its own bounding box (every vertex a corner of it, 12 triangles): then
// clipping to the box is clipping to the mesh.
bool is_box(const TriangleMesh& m, const BBox3& b) {
  if (m.triangles.size() != 12) return false;
  auto corner = [](double v, double lo, double hi) { return v == lo || v == hi; };
  for (const Vec3& v : m.vertices)
    if (!corner(v.x, b.min.x, b.max.x) || !corner(v.y, b.min.y, b.max.y) ||
        !corner(v.z, b.min.z, b.max.z))
      return false;
  return true;
}

struct Model {
  const Ctx& ctx;
  double mm = 1;
  std::map<long long, const El*> functions, objects;
  const VcadOptions& options;
};

// The field of one build item's object: its level set (Part I §4.1.1) or the 2022 draft's
// <volumedata><boundary>, clipped to its mesh; `box` grows by the mesh's box.
Field object_field(const Model& md, const El& item, const El& obj, long long oid, BBox3& box) {
  const Ctx& c = md.ctx;
  const El* ls = child(obj, "levelset");
  const El* boundary = nullptr;
  if (const El* vd = child(obj, "volumedata")) boundary = child(*vd, "boundary");
  if (!ls && !boundary) {
    if (child(obj, "components"))
      c.fail(obj, fmt::format("object {} is made of components; level-set designs are read from "
                              "objects with a <levelset> placed by the build directly",
                              oid));
    c.fail(obj, fmt::format("object {} is a mesh and the build also places level-set objects: "
                            "a mix of meshes and level sets is not read yet",
                            oid));
  }
  const El& at = ls ? *ls : *boundary;
  long long fid = 0;
  std::string channel;
  const El* domain = nullptr;
  Affine to_function;  // object → function coordinates
  bool bbox_only = false;
  if (ls) {
    fid = resource_id(c, *ls, "functionid");
    const char* ch = ls->attr("channel");
    if (!ch) c.fail(*ls, "<levelset> has no channel (the function output it uses)");
    channel = ch;
    const long long meshid = resource_id(c, *ls, "meshid");
    auto mo = md.objects.find(meshid);
    if (mo == md.objects.end() || !child(*mo->second, "mesh"))
      c.fail(*ls, fmt::format("meshid {} names no mesh object (Part I §4.1.1: the mesh bounds "
                              "the level set)",
                              meshid));
    domain = child(*mo->second, "mesh");
    to_function = matrix3d(c, *ls, "transform");
    bbox_only = truthy(ls->attr("meshbboxonly"));
  } else {
    fid = resource_id(c, *boundary, boundary->attr("functionId") ? "functionId" : "functionid");
    if (const char* ch = boundary->attr("channel")) channel = ch;
    domain = child(obj, "mesh");
    if (!domain) c.fail(obj, fmt::format("object {} has a boundary but no mesh to bound it", oid));
  }
  const double fallback = number(c, at, "fallbackvalue", 0.0);

  auto program = std::make_shared<Program>();
  Compiler comp(c, md.functions, *program);
  const El& fn = comp.function(fid, at);
  for (const auto& [name, td] : comp.inputs_of(fn))
    if (name != "pos" || td.first != Type::Vector)
      c.fail(at, fmt::format("function {} takes the {} input \"{}\": a level set gives its "
                             "function only the vector \"pos\" (Part I §4.1.1)",
                             fid, to_string(td.first), name));
  program->pos = program->alloc(3);
  Slot pos;
  pos.type = Type::Vector;
  pos.off = program->pos;
  const auto outs = comp.instantiate(fn, fid, {{"pos", pos}});
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
  program->out = it->second.off;

  const Affine item_m = matrix3d(c, item, "transform");  // object → build (model units)
  const auto item_inv = inverse(item_m);
  if (!item_inv) c.fail(item, "the item's transform is singular");
  Affine from_mm;
  for (int i = 0; i < 3; ++i) from_mm.l[i][i] = 1 / md.mm;
  const Field graph =
      graph_field(program, compose(to_function, compose(*item_inv, from_mm)), fallback);

  const TriangleMesh mesh = mesh_of(c, *domain, item_m, md.mm);
  BBox3 b;
  for (const Vec3& v : mesh.vertices) b.add(v);
  box.add(b.min);
  box.add(b.max);
  Field f = clip_box(graph, b.min, b.max);
  if (!bbox_only && !is_box(mesh, b)) {
    // The level set intersected with the mesh itself (Part I §4.1.1, meshbboxonly false).
    MeshSdfOptions mo;
    mo.voxel = md.options.mesh_voxel;
    const Vec3 n = (b.max - b.min) * (1 / mo.voxel);
    if (!(n.x * n.y * n.z <= 1e10))
      c.fail(at, fmt::format("the mesh that bounds object {} spans {:.3g} voxels of {} mm: too "
                             "many for its distance field; set meshbboxonly=\"true\" or a "
                             "coarser slice.mesh_voxel",
                             oid, n.x * n.y * n.z, mo.voxel));
    f = intersect({f, mesh_field(mesh, mo, fmt::format("{} object {}", c.file, oid))});
  }
  return f;
}

bool is_implicit(const std::string& path) {
  Zip z;
  int err = 0;
  z.z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z.z) return false;
  std::optional<std::string> bytes;
  try {
    bytes = read_part(z.z, model_part_name(z.z, path), path);
  } catch (const ParseError&) {
    return false;
  }
  if (!bytes) return false;
  const bool extension = bytes->find("3dmanufacturing/volumetric/") != std::string::npos ||
                         bytes->find("3dmanufacturing/implicit/") != std::string::npos;
  return extension && (bytes->find("levelset") != std::string::npos ||
                       bytes->find("boundary") != std::string::npos);
}

VcadDesign read(const std::string& path, const VcadOptions& options) {
  Zip z;
  int err = 0;
  z.z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z.z) {
    zip_error_t e;
    zip_error_init_with_code(&e, err);
    const std::string why = zip_error_strerror(&e);
    zip_error_fini(&e);
    throw ParseError("not a 3MF package (a ZIP file): " + why, {path});
  }
  const std::string part = model_part_name(z.z, path);
  const auto bytes = read_part(z.z, part, path);
  if (!bytes) throw ParseError("the package has no model part " + part, {path});
  const Ctx ctx{path, part[0] == '/' ? part : "/" + part};
  const auto root = parse_xml(*bytes, path, ctx.part);
  if (root->name != "model") ctx.fail(*root, "the model part's root is not <model>");
  Model md{ctx, unit_mm(ctx, *root), {}, {}, options};
  const El* resources = child(*root, "resources");
  const El* build = child(*root, "build");
  if (!resources || !build) ctx.fail(*root, "<model> has no <resources> or no <build>");
  for (const auto& k : resources->kids) {
    if (is_function(*k)) md.functions[resource_id(ctx, *k, "id")] = k.get();
    if (k->name == "object") md.objects[resource_id(ctx, *k, "id")] = k.get();
  }
  std::vector<Field> parts;
  BBox3 box;
  for (const auto& item : build->kids) {
    if (item->name != "item") continue;
    const long long oid = resource_id(ctx, *item, "objectid");
    auto o = md.objects.find(oid);
    if (o == md.objects.end()) ctx.fail(*item, fmt::format("no object has id {}", oid));
    parts.push_back(object_field(md, *item, *o->second, oid, box));
  }
  if (parts.empty()) ctx.fail(*build, "the build places no object");
  VcadDesign d;
  d.field = parts.size() == 1 ? parts[0] : unite(std::move(parts));
  d.has_root = true;
  d.root_min = box.min;
  d.root_max = box.max;
  d.source = path;
  return d;
}

}  // namespace
}  // namespace trellis::implicit

TRELLIS_MODULE_ENTRY(implicit3mf, trellis::Implicit3mfModule, &trellis::implicit::is_implicit,
                     &trellis::implicit::read)
