// Recursive-descent reader for .vcad designs. Hand-written: the language is small and errors
// must point at a line and column.
#include "trellis/field/vcad.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string_view>
#include <variant>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/geom/mesh.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis {

namespace {

struct Pos {
  long line = 1, column = 1;
};

enum class Tok {
  Ident,
  Number,
  String,
  LParen,
  RParen,
  LBrace,
  RBrace,
  LBracket,
  RBracket,
  Comma,
  Semicolon,
  End
};

struct Token {
  Tok kind;
  std::string text;
  double number = 0;
  Pos pos;
};

const char* tok_name(Tok t) {
  switch (t) {
    case Tok::Ident:
      return "a name";
    case Tok::Number:
      return "a number";
    case Tok::String:
      return "a string";
    case Tok::LParen:
      return "'('";
    case Tok::RParen:
      return "')'";
    case Tok::LBrace:
      return "'{'";
    case Tok::RBrace:
      return "'}'";
    case Tok::LBracket:
      return "'['";
    case Tok::RBracket:
      return "']'";
    case Tok::Comma:
      return "','";
    case Tok::Semicolon:
      return "';'";
    case Tok::End:
      return "end of file";
  }
  return "?";
}

class Lexer {
 public:
  Lexer(const std::string& text, const std::string& name) : s_(text), name_(name) {}

  [[noreturn]] void fail(const std::string& msg, Pos p) const {
    throw ParseError(msg, {name_, p.line, "", p.column});
  }

  Token next() {
    skip();
    Token t;
    t.pos = pos_;
    if (i_ >= s_.size()) {
      t.kind = Tok::End;
      return t;
    }
    const char c = s_[i_];
    auto single = [&](Tok k) {
      advance();
      t.kind = k;
      t.text = std::string(1, c);
      return t;
    };
    switch (c) {
      case '(':
        return single(Tok::LParen);
      case ')':
        return single(Tok::RParen);
      case '{':
        return single(Tok::LBrace);
      case '}':
        return single(Tok::RBrace);
      case '[':
        return single(Tok::LBracket);
      case ']':
        return single(Tok::RBracket);
      case ',':
        return single(Tok::Comma);
      case ';':
        return single(Tok::Semicolon);
      default:
        break;
    }
    if (c == '"') {
      advance();
      t.kind = Tok::String;
      while (i_ < s_.size() && s_[i_] != '"') {
        const char ch = s_[i_];
        // Expressions may be split over lines (FGM paper, Listing 5): newlines become spaces.
        t.text += (ch == '\n' || ch == '\r' || ch == '\t') ? ' ' : ch;
        advance();
      }
      if (i_ >= s_.size()) fail("string not closed", t.pos);
      advance();
      return t;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.') {
      const char* begin = s_.c_str() + i_;
      char* end = nullptr;
      const double v = std::strtod(begin, &end);
      if (end == begin) fail(fmt::format("unexpected '{}'", c), t.pos);
      const std::size_t len = static_cast<std::size_t>(end - begin);
      // Decimal only: strtod also reads 0x10 (as 16), 0x1p3, inf and nan.
      const std::string_view text(begin, len);
      if (text.find_first_not_of("0123456789.eE+-") != std::string_view::npos)
        fail(fmt::format("'{}' is not a decimal number", text), t.pos);
      if (!std::isfinite(v) || std::abs(v) > 1e6)
        fail("number beyond ±1e6 (mm): out of range", t.pos);
      for (std::size_t k = 0; k < len; ++k) advance();
      t.kind = Tok::Number;
      t.number = v;
      t.text = std::string(begin, len);
      return t;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      t.kind = Tok::Ident;
      while (i_ < s_.size() &&
             (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_')) {
        t.text += s_[i_];
        advance();
      }
      return t;
    }
    fail(fmt::format("unexpected character '{}'", std::isprint(static_cast<unsigned char>(c))
                                                      ? std::string(1, c)
                                                      : fmt::format("\\x{:02x}", c & 0xff)),
         t.pos);
  }

 private:
  void advance() {
    if (s_[i_] == '\n') {
      ++pos_.line;
      pos_.column = 1;
    } else {
      ++pos_.column;
    }
    ++i_;
  }
  void skip() {
    for (;;) {
      while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) advance();
      if (i_ + 1 < s_.size() && s_[i_] == '/' && s_[i_ + 1] == '/') {
        while (i_ < s_.size() && s_[i_] != '\n') advance();
        continue;
      }
      if (i_ + 1 < s_.size() && s_[i_] == '/' && s_[i_ + 1] == '*') {
        const Pos start = pos_;
        advance();
        advance();
        while (i_ + 1 < s_.size() && !(s_[i_] == '*' && s_[i_ + 1] == '/')) advance();
        if (i_ + 1 >= s_.size()) fail("comment not closed", start);
        advance();
        advance();
        continue;
      }
      return;
    }
  }
  const std::string& s_;
  const std::string& name_;
  std::size_t i_ = 0;
  Pos pos_;
};

struct Arg {
  enum Kind { Number, String, Tuple, List } kind;
  double number = 0;
  std::string text;
  std::vector<double> tuple;
  std::vector<std::string> list;
  Pos pos;
};

const char* arg_name(Arg::Kind k) {
  switch (k) {
    case Arg::Number:
      return "a number";
    case Arg::String:
      return "a string";
    case Arg::Tuple:
      return "a tuple (x, y, z)";
    case Arg::List:
      return "a list [...]";
  }
  return "?";
}

class Parser {
 public:
  Parser(const std::string& text, const std::string& name, const VcadOptions& opt)
      : lex_(text, name), name_(name), opt_(opt) {
    tok_ = lex_.next();
  }

  VcadDesign parse() {
    VcadDesign d;
    d.source = name_;
    std::vector<Field> top;
    if (tok_.kind == Tok::Ident && tok_.text == "root") {
      const Pos at = tok_.pos;
      advance();
      auto args = parse_args();
      if (args.size() != 3)
        fail(fmt::format("root takes 3 tuples (min, max, voxel size), got {}", args.size()), at);
      const Vec3 lo = tuple3(args[0], "root min"), hi = tuple3(args[1], "root max");
      d.resolution = tuple3(args[2], "root voxel size");
      if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z))
        fail("root: min must be below max on every axis", args[0].pos);
      if (!(d.resolution.x > 0 && d.resolution.y > 0 && d.resolution.z > 0))
        fail("root: voxel sizes must be positive", args[2].pos);
      mesh_voxel_ = std::min({d.resolution.x, d.resolution.y, d.resolution.z});
      d.has_root = true;
      d.root_min = lo;
      d.root_max = hi;
      expect(Tok::LBrace);
      top = parse_block(at);
      if (tok_.kind != Tok::End) fail("nothing may follow root's block", tok_.pos);
    } else {
      while (tok_.kind != Tok::End) top.push_back(parse_node());
      if (top.empty()) fail("empty design", tok_.pos);
    }
    Field f = top.size() == 1 ? top.front() : unite(top);
    if (d.has_root) f = clip_box(f, d.root_min, d.root_max);
    d.field = f;
    return d;
  }

 private:
  [[noreturn]] void fail(const std::string& msg, Pos p) const { lex_.fail(msg, p); }
  void advance() { tok_ = lex_.next(); }
  void expect(Tok k) {
    if (tok_.kind != k)
      fail(fmt::format("expected {} but found {}", tok_name(k),
                       tok_.kind == Tok::End ? "end of file" : "'" + tok_.text + "'"),
           tok_.pos);
    advance();
  }

  std::vector<Arg> parse_args() {
    expect(Tok::LParen);
    std::vector<Arg> args;
    if (tok_.kind == Tok::RParen) {
      advance();
      return args;
    }
    for (;;) {
      args.push_back(parse_arg());
      if (tok_.kind == Tok::Comma) {
        advance();
        continue;
      }
      expect(Tok::RParen);
      return args;
    }
  }

  // item (, item)* close — `take` stores the current item token.
  template <class F>
  void sequence(Tok item, Tok close, const char* what, F&& take) {
    for (;;) {
      if (tok_.kind != item) fail(what, tok_.pos);
      take();
      advance();
      if (tok_.kind != Tok::Comma) break;
      advance();
    }
    expect(close);
  }

  Arg parse_arg() {
    Arg a;
    a.pos = tok_.pos;
    switch (tok_.kind) {
      case Tok::Number:
        a.kind = Arg::Number;
        a.number = tok_.number;
        advance();
        return a;
      case Tok::String:
        a.kind = Arg::String;
        a.text = tok_.text;
        advance();
        return a;
      case Tok::LParen:
        a.kind = Arg::Tuple;
        advance();
        sequence(Tok::Number, Tok::RParen, "tuples hold numbers only",
                 [&] { a.tuple.push_back(tok_.number); });
        return a;
      case Tok::LBracket:
        a.kind = Arg::List;
        advance();
        if (tok_.kind == Tok::RBracket) {
          advance();
          return a;
        }
        sequence(Tok::String, Tok::RBracket, "lists hold strings only", [&] {
          a.list.push_back(tok_.text);
          list_pos_.push_back(tok_.pos);
        });
        return a;
      default:
        fail(fmt::format("expected an argument but found {}",
                         tok_.kind == Tok::End ? "end of file" : "'" + tok_.text + "'"),
             tok_.pos);
    }
  }

  double number(const Arg& a, const char* what) {
    if (a.kind != Arg::Number)
      fail(fmt::format("{}: expected a number, got {}", what, arg_name(a.kind)), a.pos);
    return a.number;
  }
  Vec3 tuple3(const Arg& a, const char* what) {
    if (a.kind == Arg::Number) return {a.number, a.number, a.number};
    if (a.kind != Arg::Tuple || a.tuple.size() != 3)
      fail(fmt::format("{}: expected (x, y, z)", what), a.pos);
    return {a.tuple[0], a.tuple[1], a.tuple[2]};
  }
  // Leaves: `n` numeric arguments then an optional material string.
  std::string material(const std::vector<Arg>& args, std::size_t n, const std::string& node,
                       Pos at) {
    if (args.size() < n || args.size() > n + 1)
      fail(fmt::format("{} takes {} argument{} and an optional material, got {}", node, n,
                       n == 1 ? "" : "s", args.size()),
           at);
    if (args.size() == n + 1) {
      if (args[n].kind != Arg::String)
        fail(fmt::format("{}: the last argument is a material name string", node), args[n].pos);
      return args[n].text;
    }
    return {};
  }
  Expression expression(const Arg& a, const char* what) {
    if (a.kind != Arg::String) fail(fmt::format("{}: expected an expression string", what), a.pos);
    check(a.text, a.pos);
    return {a.text};
  }
  void check(const std::string& text, Pos at) {
    long col = 0;
    try {
      check_expression(text, &col);
    } catch (const ParseError& e) {
      // Column inside the string: +1 for the opening quote (exact when the string is one line).
      fail(e.message(), {at.line, at.column + col - 1});
    }
  }

  // Wraps library errors (bad sizes etc.) with the node's position.
  template <class F>
  Field at_node(Pos at, F&& make) {
    try {
      return make();
    } catch (const ParseError& e) {
      fail(e.message(), at);
    } catch (const GeometryError& e) {
      fail(e.message(), at);
    }
  }

  std::vector<Field> parse_block(Pos owner) {
    std::vector<Field> children;
    while (tok_.kind != Tok::RBrace) {
      if (tok_.kind == Tok::End) fail("block not closed: missing '}'", owner);
      children.push_back(parse_node());
    }
    advance();
    return children;
  }

  Field children_of(const std::string& node, Pos at) {
    if (tok_.kind != Tok::LBrace) fail(node + " needs a block { ... }", tok_.pos);
    advance();
    auto kids = parse_block(at);
    if (kids.empty()) fail(node + " has an empty block", at);
    return kids.size() == 1 ? kids.front() : unite(kids);
  }
  std::vector<Field> list_of(const std::string& node, Pos at) {
    if (tok_.kind != Tok::LBrace) fail(node + " needs a block { ... }", tok_.pos);
    advance();
    auto kids = parse_block(at);
    if (kids.empty()) fail(node + " has an empty block", at);
    return kids;
  }

  Field parse_node() {
    if (tok_.kind != Tok::Ident)
      fail(fmt::format("expected a node name but found {}",
                       tok_.kind == Tok::End ? "end of file" : "'" + tok_.text + "'"),
           tok_.pos);
    const std::string node = tok_.text;
    const Pos at = tok_.pos;
    if (depth_ >= kMaxDepth) fail("nodes nested deeper than 256 levels", at);
    struct Depth {
      int& d;
      explicit Depth(int& x) : d(x) { ++d; }
      ~Depth() { --d; }
    } guard(depth_);
    advance();
    if (tok_.kind != Tok::LParen) fail(node + ": expected '(' after the name", tok_.pos);
    list_pos_.clear();
    const auto args = parse_args();
    const auto list_pos = list_pos_;
    Field f = build(node, at, args, list_pos);
    if (tok_.kind == Tok::Semicolon) advance();
    return f;
  }

  Field build(const std::string& node, Pos at, const std::vector<Arg>& args,
              const std::vector<Pos>& list_pos) {
    auto leaf = [&](std::size_t n, auto make) {
      const std::string m = material(args, n, node, at);
      return at_node(at, [&] { return make(m); });
    };
    if (node == "sphere")
      return leaf(
          1, [&](const std::string& m) { return sphere(number(args[0], "sphere radius"), m); });
    if (node == "cube")
      return leaf(1, [&](const std::string& m) { return cube(number(args[0], "cube size"), m); });
    if (node == "rectprism") {
      if (!args.empty() && args[0].kind == Arg::Tuple)
        return leaf(1, [&](const std::string& m) {
          return rectprism(tuple3(args[0], "rectprism size"), m);
        });
      return leaf(3, [&](const std::string& m) {
        return rectprism({number(args[0], "rectprism x"), number(args[1], "rectprism y"),
                          number(args[2], "rectprism z")},
                         m);
      });
    }
    if (node == "cylinder")
      return leaf(2, [&](const std::string& m) {
        return cylinder(number(args[0], "cylinder radius"), number(args[1], "cylinder height"), m);
      });
    if (node == "cone")
      return leaf(2, [&](const std::string& m) {
        return cone(number(args[0], "cone radius"), number(args[1], "cone height"), m);
      });
    if (node == "torus")
      return leaf(2, [&](const std::string& m) {
        return torus(number(args[0], "torus major radius"), number(args[1], "torus minor radius"),
                     m);
      });
    if (node == "function")
      return leaf(3, [&](const std::string& m) {
        const Vec3 lo = tuple3(args[0], "function min"), hi = tuple3(args[1], "function max");
        return function(lo, hi, expression(args[2], "function"), m);
      });
    if (node == "gyroid" || node == "schwarz_p" || node == "schwarz_d" || node == "diamond" ||
        node == "neovius" || node == "iwp") {
      const TpmsKind kind = node == "gyroid"      ? TpmsKind::Gyroid
                            : node == "schwarz_p" ? TpmsKind::SchwarzP
                            : node == "neovius"   ? TpmsKind::Neovius
                            : node == "iwp"       ? TpmsKind::Iwp
                                                  : TpmsKind::SchwarzD;
      if (args.empty() || args.size() > 3) fail(node + " takes (cell [, c [, material]])", at);
      const Vec3 cell = tuple3(args[0], "cell size");
      Expression c;
      if (args.size() >= 2) {
        if (args[1].kind == Arg::Number)
          c.text = fmt::format("{}", args[1].number);
        else
          c = expression(args[1], "sheet c");
        double v = 0;
        if (constant_expression(c.text, &v) && !std::isfinite(v))
          fail(fmt::format("{}: the sheet parameter c = \"{}\" is not a finite number", node,
                           c.text),
               args[1].pos);
      }
      std::string m;
      if (args.size() == 3) {
        if (args[2].kind != Arg::String) fail(node + ": material must be a string", args[2].pos);
        m = args[2].text;
      }
      return at_node(at, [&] { return tpms(kind, cell, c, m); });
    }
    if (node == "mesh") {
      const std::string m = material(args, 1, node, at);
      if (args[0].kind != Arg::String) fail("mesh: expected a file name string", args[0].pos);
      namespace fs = std::filesystem;
      fs::path p(args[0].text);
      if (p.is_relative()) {
        const fs::path base =
            !opt_.base_dir.empty() ? fs::path(opt_.base_dir) : fs::path(name_).parent_path();
        p = base / p;
      }
      try {
        const TriangleMesh mesh = read_mesh(p.string());
        MeshSdfOptions o;
        o.voxel = mesh_voxel_ > 0 ? mesh_voxel_ : opt_.mesh_voxel;
        Field f = mesh_field(mesh, o, p.string());
        (void)m;  // a mesh leaf's material: recorded through fgrade in the listings
        return m.empty() ? f : fgrade(f, {Expression{"1"}}, {m});
      } catch (const Error& e) {
        fail("mesh(\"" + args[0].text + "\"): " + std::string(e.what()), args[0].pos);
      }
    }
    if (node == "union" || node == "intersection" || node == "difference") {
      if (args.size() > 1) fail(node + " takes no argument or a blend radius", at);
      const double k = args.empty() ? 0.0 : number(args[0], "blend radius");
      if (k < 0)
        fail(fmt::format("{}: the blend radius must be ≥ 0 mm, got {}", node, k), args[0].pos);
      auto kids = list_of(node, at);
      return at_node(at, [&] {
        if (node == "union") return k > 0 ? smooth_unite(kids, k) : unite(kids);
        if (node == "intersection") return k > 0 ? smooth_intersect(kids, k) : intersect(kids);
        return k > 0 ? smooth_subtract(kids, k) : subtract(kids);
      });
    }
    if (node == "translate" || node == "scale" || node == "rotate") {
      Vec3 v;
      if (args.size() == 1)
        v = tuple3(args[0], node.c_str());
      else if (args.size() == 3)
        v = {number(args[0], "x"), number(args[1], "y"), number(args[2], "z")};
      else
        fail(node + " takes (x, y, z)", at);
      Field child = children_of(node, at);
      return at_node(at, [&] {
        if (node == "translate") return translate(child, v);
        if (node == "scale") return scale(child, v);
        return rotate(child, v);
      });
    }
    if (node == "fgrade") {
      if (args.size() < 2 || args.size() > 3 || args[0].kind != Arg::List ||
          args[1].kind != Arg::List)
        fail("fgrade takes ([\"expr\", ...], [\"material\", ...] [, \"mode\"])", at);
      // OpenVCAD's optional third argument names a blending mode; Trellis has one (fractions
      // clamped to 0..1 and normalised), so a mode would be ignored: refused instead.
      if (args.size() == 3)
        fail(args[2].kind == Arg::String
                 ? fmt::format("fgrade: the mode \"{}\" is not supported (the fractions are always "
                               "clamped to 0..1 and normalised); leave the third argument out",
                               args[2].text)
                 : std::string("fgrade: a third argument is not supported; leave it out"),
             args[2].pos);
      if (args[0].list.size() != args[1].list.size())
        fail(fmt::format("fgrade: {} expressions but {} materials", args[0].list.size(),
                         args[1].list.size()),
             at);
      std::vector<Expression> exprs;
      for (std::size_t i = 0; i < args[0].list.size(); ++i) {
        check(args[0].list[i], i < list_pos.size() ? list_pos[i] : at);
        exprs.push_back({args[0].list[i]});
      }
      Field child = children_of(node, at);
      return at_node(at, [&] { return fgrade(child, exprs, args[1].list); });
    }
    if (node == "fprocess") {
      // fprocess(["expr", ...], ["temperature" | "speed" | "flow" | "fan", ...]) { ... }: the
      // same shape as fgrade, process parameters instead of materials.
      if (args.size() != 2 || args[0].kind != Arg::List || args[1].kind != Arg::List)
        fail(
            "fprocess takes ([\"expr\", ...], [\"temperature\" | \"speed\" | \"flow\" | "
            "\"fan\", ...])",
            at);
      std::vector<Expression> exprs;
      for (std::size_t i = 0; i < args[0].list.size(); ++i) {
        check(args[0].list[i], i < list_pos.size() ? list_pos[i] : at);
        exprs.push_back({args[0].list[i]});
      }
      const std::string label = fmt::format(
          "fprocess at {}:{}", std::filesystem::path(name_).filename().string(), at.line);
      Field child = children_of(node, at);
      return at_node(at, [&] { return fprocess(child, exprs, args[1].list, label); });
    }
    if (node == "root") fail("root may only be the outermost node", at);
    fail("unknown node '" + node + "'", at);
  }

  Lexer lex_;
  std::string name_;
  const VcadOptions& opt_;
  Token tok_;
  double mesh_voxel_ = 0;
  std::vector<Pos> list_pos_;
  static constexpr int kMaxDepth = 256;
  int depth_ = 0;
};

}  // namespace

VcadDesign parse_vcad(const std::string& text, const std::string& name,
                      const VcadOptions& options) {
  Parser p(text, name, options);
  return p.parse();
}

VcadDesign read_vcad(const std::string& path, const VcadOptions& options) {
  return parse_vcad(read_file(path), path, options);
}

}  // namespace trellis
