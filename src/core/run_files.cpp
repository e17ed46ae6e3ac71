#include "trellis/core/run_files.hpp"

#include <utility>

#include "output_path.hpp"
#include "trellis/core/error.hpp"

namespace trellis {

namespace {

[[noreturn]] void refuse(const std::string& path, const std::string& why,
                         const std::string& remedy) {
  throw IoError(why + ": nothing was written; " + remedy, {path});
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
  for (const Entry& in : inputs_) inputs.emplace_back(detail::file_id(in.path), in.role);
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
             "pass --follow-symlinks (run.follow_symlinks = true) to write to " + s.target +
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
