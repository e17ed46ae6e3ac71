#include "trellis/core/run_files.hpp"

#include <sys/stat.h>

#include <utility>

#include "output_path.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

namespace {

[[noreturn]] void refuse(const std::string& path, const std::string& why,
                         const std::string& remedy) {
  throw IoError(why + ": nothing was written; " + remedy, {path});
}

// What a node that is neither a file nor a folder is, for a message.
std::string node_kind(mode_t mode) {
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISFIFO(mode)) return "a FIFO";
  return S_ISBLK(mode) ? "a block device" : "a socket";
}

}  // namespace

void RunFiles::input(std::string role, std::string path) {
  if (!path.empty()) inputs_.push_back({std::move(role), std::move(path)});
}

void RunFiles::output(std::string role, std::string path) {
  if (!path.empty()) outputs_.push_back({std::move(role), std::move(path)});
}

void RunFiles::output_folder(std::string role, std::string path) {
  if (!path.empty()) outputs_.push_back({std::move(role), std::move(path), true});
}

void RunFiles::check() const {
  std::vector<std::pair<detail::FileId, std::string>> inputs;
  for (const Entry& in : inputs_) {
    // What it names (/dev/stdin redirected from a file is that file), links followed.
    struct stat st {};
    if (::stat(in.path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode))
      throw IoError(in.role + " is " + node_kind(st.st_mode) +
                        ": only a file is read (a device or a pipe may never end, or block "
                        "forever); save it to a file first",
                    {in.path});
    inputs.emplace_back(detail::file_id(in.path), in.role);
  }
  std::vector<std::pair<detail::FileId, std::string>> outputs;
  for (const Entry& out : outputs_) {
    const detail::PathState s = detail::inspect_path(out.path);
    if (!out.folder && (detail::names_folder(out.path) || s.kind == detail::PathKind::Folder))
      refuse(out.path, out.role + " names a folder", "give it a file name");
    if (s.kind == detail::PathKind::Other)
      refuse(out.path, out.role + " is " + s.what,
             "an output is a file, a FIFO or a character device");
    if (s.link && s.kind != detail::PathKind::Stream && !follow_symlinks_)
      refuse(out.path, out.role + " is a symbolic link (to " + s.target + ")",
             "set run.follow_symlinks = true to write to " + s.target +
                 " and keep the link, or choose another path");
    if (s.char_device) continue;
    for (const auto& [id, role] : inputs)
      if (id == s.id)
        refuse(out.path, out.role + " would overwrite " + role + " (one file)",
               "choose another path for " + out.role);
    for (const auto& [id, role] : outputs)
      if (id == s.id)
        refuse(out.path, role + " and " + out.role + " are one file",
               "give each output its own path");
    outputs.emplace_back(s.id, out.role);
  }
  detail::guard_inputs(inputs);
}

}  // namespace trellis
