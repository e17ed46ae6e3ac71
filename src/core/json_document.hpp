// Private helper for the JSON readers (lattice, toolpath): parse text and read the document,
// turning every nlohmann error (syntax, number overflow, type) into a ParseError naming the file
// and, for syntax errors, the line.
#pragma once
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

template <class Read>
auto read_json_document(const std::string& text, const std::string& origin, Read read) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw ParseError(std::string("invalid JSON: ") + e.what(),
                     {origin, line_of_offset(text, e.byte > 0 ? e.byte - 1 : 0)});
  } catch (const nlohmann::json::exception& e) {  // e.g. a number too large for a double
    // nlohmann gives no position for an overflow: find the first number that overflows.
    long line = 0, column = 0;
    bool in_string = false;
    for (std::size_t i = 0, line_start = 0; i < text.size(); ++i) {
      const char c = text[i];
      if (c == '\n') line_start = i + 1;
      if (in_string) {
        if (c == '\\')
          ++i;
        else if (c == '"')
          in_string = false;
        continue;
      }
      if (c == '"') {
        in_string = true;
      } else if (c == '-' || (c >= '0' && c <= '9')) {
        char* end = nullptr;
        const double v = std::strtod(text.c_str() + i, &end);
        if (std::isinf(v)) {
          line = line_of_offset(text, i);
          column = static_cast<long>(i - line_start) + 1;
          break;
        }
        if (end > text.c_str() + i) i = static_cast<std::size_t>(end - text.c_str()) - 1;
      }
    }
    throw ParseError(std::string("invalid JSON: ") + e.what(), {origin, line, "", column});
  }
  try {
    return read(doc);
  } catch (const nlohmann::json::exception& e) {
    throw ParseError(std::string("invalid JSON content: ") + e.what(), {origin});
  }
}

}  // namespace trellis
