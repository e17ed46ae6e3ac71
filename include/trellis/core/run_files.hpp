// The files of one run — every input and output with the role that names it in messages —
// declared before the run starts and checked in one place, so that no command loses a file.
// check() refuses the run (IoError: exit 2 in the CLI) before anything is read or written when
//   - an output is one of the inputs, or two outputs are one file: the same device and inode
//     when the file exists, else the same absolute path, symbolic links followed. Character
//     devices (/dev/null) are exempt: nothing in them can be lost;
//   - an output meant as a file names a folder ("out/", an existing folder), or an output is a
//     block device or a socket;
//   - an input is not a file or a folder: a character device, a FIFO or a socket (/dev/zero, a
//     pipe) may never end or block forever, so it is never read;
//   - an output path is a symbolic link, unless `follow_symlinks` (run.follow_symlinks,
//     --follow-symlinks): then the file it points to is written and the link kept. A link to a
//     FIFO or a character device (/dev/stdout) is written through like the device itself.
// When an OutputBatch is open (core/file.hpp), check() hands it the inputs: any later write of
// the run to one of them — by a name no role declared, such as a preview or a shard — is
// refused, and so is a write to any file the run reads after the check (read_file: a mesh its
// design names, the edges file beside AERO vertices).
#pragma once
#include <string>
#include <vector>

namespace trellis {

class RunFiles {
 public:
  explicit RunFiles(bool follow_symlinks = false) : follow_symlinks_(follow_symlinks) {}
  // `role` is a phrase for messages: "the input", "the report (--report)". An empty path is an
  // output or input not given, and ignored (the CLI refuses an empty path it is given).
  void input(std::string role, std::string path);
  void output(std::string role, std::string path);
  // A folder the run writes files into (previews).
  void output_folder(std::string role, std::string path);
  void check() const;

 private:
  struct Entry {
    std::string role, path;
    bool folder = false;
  };
  bool follow_symlinks_;
  std::vector<Entry> inputs_, outputs_;
};

}  // namespace trellis
