// Errors for user mistakes and bad input. Each carries where it happened (file, line, element)
// so the CLI can print one clear message; our own bugs are assertions instead.
#pragma once
#include <stdexcept>
#include <string>

namespace trellis {

struct Where {
  std::string file;     // input file, empty if none
  long line = 0;        // 1-based line, 0 if unknown
  std::string element;  // e.g. "edges[12]" or "extrusion.nozzle_diameter"
  long column = 0;      // 1-based column, 0 if unknown
};

class Error : public std::runtime_error {
 public:
  Error(std::string message, Where where = {});
  const Where& where() const { return where_; }
  const std::string& message() const { return message_; }

 private:
  Where where_;
  std::string message_;
};

// Malformed input file (lattice, toolpath, profile, job).
class ParseError : public Error {
  using Error::Error;
};
// A setting with an unknown name, wrong type or value out of range.
class SettingError : public Error {
  using Error::Error;
};
// Input that parses but cannot be planned or written (e.g. empty lattice).
class GeometryError : public Error {
  using Error::Error;
};
// File system failures (cannot open, cannot write).
class IoError : public Error {
  using Error::Error;
};

// A run refused before it starts because its estimated memory or time is beyond the budget
// (run.max_memory, run.max_time; run.force goes beyond on purpose), or that ran out of memory.
class ResourceError : public Error {
  using Error::Error;
};

// The caller stopped the work through Progress::cancel (core/progress.hpp); nothing was produced.
class Cancelled : public Error {
  using Error::Error;
};

// "file:line: element: message", leaving out what is unknown.
std::string format_where(const Where& where);

}  // namespace trellis
