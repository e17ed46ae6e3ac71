// Internal (implicit3mf module): the model part as a small element tree (every element with its
// line and column) and the helpers that read its attributes, refusing with the part, line and
// column (implicit_3mf_read.cpp builds the tree, implicit_compile.cpp compiles function graphs).
#pragma once
#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "trellis/core/error.hpp"

namespace trellis::implicit {

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

inline std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

struct Ctx {
  std::string file, part;
  [[noreturn]] void fail(const El& e, const std::string& why) const {
    throw ParseError(why, {file, e.line, part, e.column});  // "file:line:column: part: why"
  }
};

inline const El* child(const El& e, std::string_view name) {
  for (const auto& k : e.kids)
    if (k->name == name) return k.get();
  return nullptr;
}

inline double number(const Ctx& c, const El& e, const char* attr, std::optional<double> dflt = {}) {
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

inline std::vector<double> numbers(const Ctx& c, const El& e, const char* attr, std::size_t count) {
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

inline long long resource_id(const Ctx& c, const El& e, const char* attr) {
  const char* s = e.attr(attr);
  if (!s) c.fail(e, fmt::format("<{}> has no {} attribute", e.name, attr));
  char* end = nullptr;
  const long long v = std::strtoll(s, &end, 10);
  if (end == s || *end != '\0' || v <= 0)
    c.fail(e, fmt::format("<{}> {}=\"{}\" is not a resource id", e.name, attr, s));
  return v;
}

}  // namespace trellis::implicit
