#include "trellis/core/error.hpp"

namespace trellis {

std::string format_where(const Where& w) {
  std::string out;
  if (!w.file.empty()) out += w.file;
  if (w.line > 0) {
    out += out.empty() ? "line " : ":";
    out += std::to_string(w.line);
  }
  if (w.line > 0 && w.column > 0) {
    out += ':';
    out += std::to_string(w.column);
  }
  if (!w.element.empty()) {
    if (!out.empty()) out += ": ";
    out += w.element;
  }
  return out;
}

static std::string compose(const std::string& message, const Where& where) {
  const std::string at = format_where(where);
  return at.empty() ? message : at + ": " + message;
}

Error::Error(std::string message, Where where)
    : std::runtime_error(compose(message, where)),
      where_(std::move(where)),
      message_(std::move(message)) {}

}  // namespace trellis
