#include "output_path.hpp"

#include <sys/stat.h>

#include <charconv>
#include <filesystem>

namespace trellis::detail {

namespace fs = std::filesystem;

namespace {

// /dev/stdout, /dev/stderr, /dev/fd/N and /proc/self/fd/N name a descriptor of this process.
int descriptor_of(const std::string& path) {
  const std::string p = fs::path(path).lexically_normal().string();
  if (p == "/dev/stdout") return 1;
  if (p == "/dev/stderr") return 2;
  for (const std::string prefix : {"/dev/fd/", "/proc/self/fd/"}) {
    if (p.rfind(prefix, 0) != 0) continue;
    int fd = -1;
    const char* end = p.data() + p.size();
    const auto [ptr, ec] = std::from_chars(p.data() + prefix.size(), end, fd);
    if (ec == std::errc() && ptr == end && fd >= 0) return fd;
  }
  return -1;
}

// The path with every symbolic link of its last component followed (a dangling link gives
// where it points).
std::string resolve_links(std::string path) {
  for (int hops = 0; hops < 40; ++hops) {
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return path;
    std::error_code ec;
    const fs::path to = fs::read_symlink(path, ec);
    if (ec) return path;
    path = (to.is_absolute() ? to : fs::path(path).parent_path() / to).lexically_normal().string();
  }
  return path;
}

std::string absolute_normal(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) p = fs::absolute(path, ec).lexically_normal();
  return p.string();
}

}  // namespace

bool names_folder(const std::string& path) {
  const fs::path name = fs::path(path).filename();
  return name.empty() || name == "." || name == "..";
}

FileId file_id(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) return {true, st.st_dev, st.st_ino, {}};
  return {false, 0, 0, absolute_normal(resolve_links(path))};
}

PathState inspect_path(const std::string& path) {
  PathState s;
  struct stat st {};
  s.descriptor = descriptor_of(path);
  if (s.descriptor >= 0) {
    s.target = path;
    if (::fstat(s.descriptor, &st) != 0) {
      s.kind = PathKind::Other;
      s.what = "a descriptor this process does not have open";
      return s;
    }
    s.kind = PathKind::Stream;
    s.char_device = S_ISCHR(st.st_mode);
    s.id = {true, st.st_dev, st.st_ino, {}};
    return s;
  }
  s.link = ::lstat(path.c_str(), &st) == 0 && S_ISLNK(st.st_mode);
  s.target = s.link ? resolve_links(path) : path;
  s.id = file_id(path);
  if (!s.id.exists) return s;
  ::stat(path.c_str(), &st);
  if (S_ISREG(st.st_mode))
    s.kind = PathKind::File;
  else if (S_ISDIR(st.st_mode))
    s.kind = PathKind::Folder;
  else if (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode))
    s.kind = PathKind::Stream;
  else
    s.kind = PathKind::Other;
  s.char_device = S_ISCHR(st.st_mode);
  if (s.kind == PathKind::Other) s.what = S_ISBLK(st.st_mode) ? "a block device" : "a socket";
  return s;
}

}  // namespace trellis::detail
