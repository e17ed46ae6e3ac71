// Private helper for the JSON readers (lattice, toolpath): parse text and read the document,
// turning every nlohmann error (syntax, number overflow, type) into a ParseError naming the file
// and, for syntax errors, the line.
#pragma once
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
    throw ParseError(std::string("invalid JSON: ") + e.what(), {origin});
  }
  try {
    return read(doc);
  } catch (const nlohmann::json::exception& e) {
    throw ParseError(std::string("invalid JSON content: ") + e.what(), {origin});
  }
}

}  // namespace trellis
