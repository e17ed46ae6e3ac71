#include "trellis/core/file.hpp"

#include <functional>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <vector>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

// Paths the signal handler removes: temporaries being written or staged, folders created for
// outputs. Lock-free slots (the handler may run at any moment); a full table only means a path
// is not cleaned on a signal.
constexpr std::size_t kSlots = 4096;
std::array<std::atomic<char*>, kSlots> g_temp_slots{};
std::array<std::atomic<char*>, 512> g_dir_slots{};

template <std::size_t N>
int hold(std::array<std::atomic<char*>, N>& slots, const std::string& path) {
  char* copy = ::strdup(path.c_str());
  if (!copy) throw std::bad_alloc();
  for (std::size_t i = 0; i < N; ++i) {
    char* expected = nullptr;
    if (slots[i].compare_exchange_strong(expected, copy)) return static_cast<int>(i);
  }
  std::free(copy);
  return -1;
}

template <std::size_t N>
void release(std::array<std::atomic<char*>, N>& slots, int slot) {
  if (slot < 0) return;
  char* p = slots[static_cast<std::size_t>(slot)].exchange(nullptr);
  std::free(p);
}

// SIGINT/SIGTERM blocked while a temporary is created and recorded, so none escapes the table.
class SignalsHeld {
 public:
  SignalsHeld() {
    sigset_t s;
    sigemptyset(&s);
    sigaddset(&s, SIGINT);
    sigaddset(&s, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &s, &old_);
  }
  ~SignalsHeld() { pthread_sigmask(SIG_SETMASK, &old_, nullptr); }

 private:
  sigset_t old_;
};

struct Staged {
  std::string temp, target;
  int slot;
};

struct Batch {
  std::mutex mutex;
  int depth = 0;
  std::vector<Staged> staged;
  std::vector<std::pair<std::string, int>> dirs;  // created, in order
};

Batch& batch() {
  static Batch b;
  return b;
}

void remove_staged(Batch& b) {
  for (const auto& s : b.staged) {
    ::unlink(s.temp.c_str());
    release(g_temp_slots, s.slot);
  }
  b.staged.clear();
  for (auto it = b.dirs.rbegin(); it != b.dirs.rend(); ++it) {
    ::rmdir(it->first.c_str());
    release(g_dir_slots, it->second);
  }
  b.dirs.clear();
}

extern "C" void cleanup_on_signal(int sig) {
  for (auto& s : g_temp_slots)
    if (char* p = s.load()) ::unlink(p);
  for (std::size_t i = g_dir_slots.size(); i-- > 0;)
    if (char* p = g_dir_slots[i].load()) ::rmdir(p);
  ::_exit(128 + sig);
}

}  // namespace

std::string read_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw IoError("is a directory", {path});
  // A device or a pipe (/dev/zero, a FIFO) would never end or block: only files are inputs.
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
    throw IoError("not a regular file", {path});
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(std::string("cannot open: ") + std::strerror(errno), {path});
  // A regular file is read straight into a string of its size (one copy: meshes of 50 MB and
  // more); anything else (a pipe) through a stream.
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && std::filesystem::is_regular_file(path, ec)) {
    std::string out(size, '\0');
    in.read(out.data(), static_cast<std::streamsize>(size));
    out.resize(static_cast<std::size_t>(in.gcount()));
    if (in.gcount() == static_cast<std::streamsize>(size) && in.peek() == EOF) return out;
    std::ostringstream rest;  // the file grew while reading
    rest << in.rdbuf();
    return out + rest.str();
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw IoError(std::string("cannot read: ") + std::strerror(errno), {path});
  return ss.str();
}

unsigned output_file_mode() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("Umask:", 0) == 0) return 0666u & ~static_cast<unsigned>(std::strtoul(line.c_str() + 6, nullptr, 8));
  // No /proc: read the mask by setting it (and back).
  static std::mutex m;
  std::lock_guard lock(m);
  const mode_t mask = ::umask(022);
  ::umask(mask);
  return 0666u & ~static_cast<unsigned>(mask);
}

void create_output_directories(const std::string& dir) {
  namespace fs = std::filesystem;
  if (dir.empty()) return;
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path p = fs::path(dir).lexically_normal(); !p.empty() && !fs::exists(p, ec);
       p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  Batch& b = batch();
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    if (it->filename().empty()) continue;  // "a/" ends in an empty name
    SignalsHeld held;
    if (::mkdir(it->c_str(), 0777) != 0) {
      if (errno == EEXIST) continue;
      throw IoError(std::string("cannot create folder: ") + std::strerror(errno), {it->string()});
    }
    const int slot = hold(g_dir_slots, it->string());
    std::lock_guard lock(b.mutex);
    if (b.depth > 0) b.dirs.emplace_back(it->string(), slot);
    else release(g_dir_slots, slot);
  }
}

void write_file_atomic_with(const std::string& path,
                            const std::function<void(const ByteWriter&)>& fill) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  create_output_directories(dir.string());
  std::string tmpl = (dir / ("." + target.filename().string() + ".XXXXXX")).string();
  int fd = -1, slot = -1;
  {
    SignalsHeld held;
    fd = ::mkstemp(tmpl.data());
    if (fd < 0) throw IoError(std::string("cannot create file: ") + std::strerror(errno), {path});
    slot = hold(g_temp_slots, tmpl);
  }
  auto drop = [&] {
    if (fd >= 0) ::close(fd);
    ::unlink(tmpl.c_str());
    release(g_temp_slots, slot);
  };
  auto fail = [&](const std::string& why) {
    drop();
    throw IoError("cannot write: " + why, {path});
  };
  const ByteWriter put = [&](std::string_view content) {
    std::size_t off = 0;
    while (off < content.size()) {
      const ssize_t n = ::write(fd, content.data() + off, content.size() - off);
      if (n < 0) {
        if (errno == EINTR) continue;
        fail(std::strerror(errno));
      }
      off += static_cast<std::size_t>(n);
    }
  };
  try {
    fill(put);
  } catch (const IoError&) {
    throw;  // fail() has cleaned up
  } catch (...) {
    drop();
    throw;
  }
  ::fchmod(fd, static_cast<mode_t>(output_file_mode()));
  const int closed = ::close(fd);
  fd = -1;
  if (closed != 0) fail(std::strerror(errno));
  Batch& b = batch();
  {
    std::lock_guard lock(b.mutex);
    if (b.depth > 0) {
      b.staged.push_back({tmpl, path, slot});
      return;
    }
  }
  if (std::rename(tmpl.c_str(), path.c_str()) != 0) fail(std::strerror(errno));
  release(g_temp_slots, slot);
}

void write_file_atomic(const std::string& path, std::string_view content) {
  write_file_atomic_with(path, [&](const ByteWriter& put) { put(content); });
}

OutputBatch::OutputBatch() {
  Batch& b = batch();
  std::lock_guard lock(b.mutex);
  outer_ = b.depth++ == 0;
}

void OutputBatch::commit() {
  if (done_) return;
  done_ = true;
  Batch& b = batch();
  std::lock_guard lock(b.mutex);
  --b.depth;
  if (!outer_) return;
  std::string error;
  for (const auto& s : b.staged) {
    if (error.empty() && std::rename(s.temp.c_str(), s.target.c_str()) != 0)
      error = s.target + ": cannot write: " + std::strerror(errno);
    if (!error.empty()) ::unlink(s.temp.c_str());
    release(g_temp_slots, s.slot);
  }
  b.staged.clear();
  for (const auto& d : b.dirs) release(g_dir_slots, d.second);
  b.dirs.clear();
  if (!error.empty()) throw IoError(error);
}

OutputBatch::~OutputBatch() {
  if (done_) return;
  Batch& b = batch();
  std::lock_guard lock(b.mutex);
  --b.depth;
  if (outer_) remove_staged(b);
}

void install_signal_cleanup() {
  struct sigaction sa {};
  sa.sa_handler = cleanup_on_signal;
  sigemptyset(&sa.sa_mask);
  sigaddset(&sa.sa_mask, SIGINT);
  sigaddset(&sa.sa_mask, SIGTERM);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
}

long line_of_offset(std::string_view text, std::size_t pos) {
  pos = std::min(pos, text.size());
  return 1 + static_cast<long>(std::count(text.begin(), text.begin() + pos, '\n'));
}

std::FILE* temporary_file() {
  const char* env = std::getenv("TMPDIR");
  const std::string dir = env && *env ? env : "/tmp";
  int fd = -1;
#ifdef O_TMPFILE
  fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);  // never has a name
#endif
  if (fd < 0 && errno != ENOENT && errno != ENOTDIR && errno != EACCES) {
    // A file system without O_TMPFILE: a named file, unlinked at once.
    std::string name = dir + "/trellis-XXXXXX";
    fd = ::mkostemp(name.data(), O_CLOEXEC);
    if (fd >= 0) ::unlink(name.c_str());
  }
  if (fd < 0)
    throw IoError("cannot create a temporary file in " + dir + " (TMPDIR): " +
                  std::strerror(errno));
  std::FILE* f = ::fdopen(fd, "w+b");
  if (!f) {
    const int e = errno;
    ::close(fd);
    throw IoError("cannot open a temporary file in " + dir + ": " + std::strerror(e));
  }
  return f;
}

}  // namespace trellis
