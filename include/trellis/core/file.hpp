// File helpers: whole-file reads with clear errors, and atomic writes (temp file + rename) so a
// failed run never leaves a half-written output behind.
#pragma once
#include <string>
#include <string_view>

namespace trellis {

std::string read_file(const std::string& path);
void write_file_atomic(const std::string& path, std::string_view content);
// Line number (1-based) of byte offset `pos` in `text`.
long line_of_offset(std::string_view text, std::size_t pos);

}  // namespace trellis
