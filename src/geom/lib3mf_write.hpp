// A 3MF package written through write_file_atomic (temporary + rename, or through a FIFO or
// device), never by lib3mf to the path itself: lib3mf makes the whole package in memory first.
#pragma once
#include <Model/COM/NMR_DLLInterfaces.h>

#include <string>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis::detail {

// False when lib3mf cannot make the package (its last error is on `writer`).
inline bool write_3mf_package(NMR::PLib3MFModelWriter* writer, const std::string& path) {
  ULONG64 size = 0;
  if (NMR::lib3mf_writer_getstreamsize(writer, &size) != LIB3MF_OK) return false;
  std::string bytes(static_cast<std::size_t>(size), '\0');
  if (NMR::lib3mf_writer_writetobuffer(writer, reinterpret_cast<BYTE*>(bytes.data()), size) !=
      LIB3MF_OK)
    return false;
  write_file_atomic(path, bytes);
  return true;
}

}  // namespace trellis::detail
