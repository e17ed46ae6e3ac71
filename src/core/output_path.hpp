// What a path names right now, for the output rules (private to core): file.cpp writes by it,
// run_files.cpp checks a run's files by it before the run starts.
#pragma once
#include <sys/types.h>

#include <string>
#include <utility>
#include <vector>

namespace trellis::detail {

enum class PathKind {
  Missing,  // nothing there yet (its folder may be missing too)
  File,     // a regular file
  Folder,
  Stream,  // a FIFO, a character device or an open descriptor: written through, never replaced
  Other,   // a block device or a socket: never an output
};

// Identity of a file: device and inode when it exists, else its absolute normalised path with
// symbolic links resolved.
struct FileId {
  bool exists = false;
  dev_t dev = 0;
  ino_t ino = 0;
  std::string path;
  bool operator==(const FileId& o) const {
    return exists == o.exists && (exists ? dev == o.dev && ino == o.ino : path == o.path);
  }
};

struct PathState {
  PathKind kind = PathKind::Missing;
  bool link = false;         // the path is a symbolic link (a descriptor name is not one)
  bool char_device = false;  // a Stream that is a character device (/dev/null, a terminal)
  int descriptor = -1;       // /dev/stdout, /dev/stderr, /dev/fd/N, /proc/self/fd/N: N
  std::string target;        // where writing lands: the path with its symbolic links resolved
  std::string what;          // for Other: "a block device" or "a socket"
  FileId id;
};

PathState inspect_path(const std::string& path);
FileId file_id(const std::string& path);
// "file.json" or "out/" names no file: true for an empty last component ("", "a/", ".", "..").
bool names_folder(const std::string& path);

// While an OutputBatch is open, every write to one of these files (role: "the input") is
// refused, whatever path names it, and so is every write to a file read_file reads from now on
// (file.cpp).
void guard_inputs(const std::vector<std::pair<FileId, std::string>>& inputs);

}  // namespace trellis::detail
