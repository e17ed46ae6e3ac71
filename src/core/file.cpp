#include "trellis/core/file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <sstream>
#include <vector>

#include "output_path.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/memory.hpp"
#include "trellis/core/output_names.hpp"

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

// The signals that end a run with its temporaries removed: Ctrl-C, kill, a closed terminal, a
// reader gone from the pipe an output is written into.
constexpr std::array<int, 4> kCleanupSignals = {SIGINT, SIGTERM, SIGHUP, SIGPIPE};

sigset_t cleanup_signals() {
  sigset_t s;
  sigemptyset(&s);
  for (int sig : kCleanupSignals) sigaddset(&s, sig);
  sigaddset(&s, SIGALRM);  // the watchdog (arm_watchdog)
  return s;
}

// Those signals blocked while a temporary is created and recorded (so none escapes the table)
// and while a batch is committed (all of it, or none).
class SignalsHeld {
 public:
  SignalsHeld() {
    const sigset_t s = cleanup_signals();
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
  std::vector<std::pair<std::string, int>> dirs;               // created, in order
  std::vector<std::pair<detail::FileId, std::string>> inputs;  // never written (RunFiles)
  std::vector<detail::FileId> written;                         // each target once
  bool checked = false;  // RunFiles checked the run: what it reads from now on is an input too
};

Batch& batch() {
  static Batch b;
  return b;
}

void remove_created_dirs(Batch& b) {
  for (auto it = b.dirs.rbegin(); it != b.dirs.rend(); ++it) {
    ::rmdir(it->first.c_str());
    release(g_dir_slots, it->second);
  }
  b.dirs.clear();
}

void remove_staged(Batch& b) {
  for (const auto& s : b.staged) {
    ::unlink(s.temp.c_str());
    release(g_temp_slots, s.slot);
  }
  b.staged.clear();
  remove_created_dirs(b);
}

// The end of a run's batch: nothing is refused any more.
void forget_run(Batch& b) {
  b.inputs.clear();
  b.written.clear();
  b.checked = false;
}

// A file a checked run reads is one of its inputs, declared or not (a mesh its design names, the
// edges file beside AERO vertices): the run never writes it.
void guard_read(const std::string& path) {
  Batch& b = batch();
  std::lock_guard lock(b.mutex);
  if (b.depth == 0 || !b.checked) return;
  const detail::FileId id = detail::file_id(path);
  for (const auto& in : b.inputs)
    if (in.first == id) return;
  b.inputs.emplace_back(id, "a file this run reads");
}

// A write of the open batch to `path`: refused over an input of the run or a target written
// already (the roles RunFiles checked miss derived names: previews, shards, `.worst.json`).
// Character devices take any number of writes.
void claim_target(const std::string& path, const detail::PathState& s) {
  if (s.char_device) return;
  Batch& b = batch();
  std::lock_guard lock(b.mutex);
  if (b.depth == 0) return;
  for (const auto& [id, role] : b.inputs)
    if (id == s.id)
      throw IoError("would overwrite " + role + " (one file): nothing was written", {path});
  for (const auto& id : b.written)
    if (id == s.id)
      throw IoError("written twice by this run (two outputs on one path): nothing was written",
                    {path});
  b.written.push_back(s.id);
}

// Temporaries are named .NAME.trellis-tmp.PID.XXXXXX beside their target: recognisable, and
// the PID says whether the run that made one is still alive.
std::string temporary_prefix(const std::string& name) {
  return "." + name.substr(0, 200) + ".trellis-tmp.";
}

// The PID in a temporary's name, or 0 when `f` is not named like one
// (.NAME.trellis-tmp.PID.XXXXXX).
pid_t temporary_owner(const std::string& f) {
  static constexpr std::string_view kMark = ".trellis-tmp.";
  const std::size_t at = f.rfind(kMark);
  if (f.empty() || f[0] != '.' || at == std::string::npos || at == 0) return 0;
  const char* first = f.data() + at + kMark.size();
  const char* last = f.data() + f.size();
  pid_t pid = 0;
  const auto [rest, bad] = std::from_chars(first, last, pid);
  if (bad != std::errc() || pid <= 0 || last - rest != 7 || *rest != '.') return 0;
  return pid;
}

// A temporary whose run is gone (kill -9, a power cut): its PID names no process. One of a live
// process (this one included) is never touched, whatever its age.
bool stale_temporary(const std::filesystem::path& p) {
  const pid_t pid = temporary_owner(p.filename().string());
  if (pid == 0 || pid == ::getpid()) return false;
  if (::kill(pid, 0) == 0 || errno != ESRCH) return false;
  struct stat st {};
  return ::lstat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// Removes the stale temporaries in `dir`; returns whether `dir` held one and nothing else.
bool remove_stale_in(const std::filesystem::path& dir) {
  std::error_code ec;
  bool stale = false, other = false;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (stale_temporary(it->path()) && ::unlink(it->path().c_str()) == 0)
      stale = true;
    else
      other = true;
  }
  return stale && !other && !ec;
}

// Temporaries left in `dir` by runs that are gone, whatever output they were for, and the folders
// in it (a killed run's preview folder) that held such temporaries and nothing else. Each folder
// once per process: a run writing 10^5 previews into one folder reads it once.
void remove_stale_temporaries(const std::filesystem::path& dir) {
  static std::mutex m;
  static std::vector<std::string> swept;
  std::error_code ec;
  const std::string key = std::filesystem::absolute(dir, ec).lexically_normal().string();
  {
    std::lock_guard lock(m);
    if (std::find(swept.begin(), swept.end(), key) != swept.end()) return;
    swept.push_back(key);
  }
  remove_stale_in(dir);
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    struct stat st {};
    if (::lstat(it->path().c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) continue;
    if (remove_stale_in(it->path())) ::rmdir(it->path().c_str());
  }
}

void write_all(int fd, std::string_view content, const std::string& path) {
  std::size_t off = 0;
  while (off < content.size()) {
    const ssize_t n = ::write(fd, content.data() + off, content.size() - off);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(std::string("cannot write: ") + std::strerror(errno), {path});
    }
    off += static_cast<std::size_t>(n);
  }
}

// A FIFO, a character device or a descriptor: opened and written, never replaced.
void write_stream(const std::string& path, const detail::PathState& s,
                  const std::function<void(const ByteWriter&)>& fill) {
  const int fd = s.descriptor >= 0 ? ::fcntl(s.descriptor, F_DUPFD_CLOEXEC, 0)
                                   : ::open(path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) throw IoError(std::string("cannot open: ") + std::strerror(errno), {path});
  try {
    fill([&](std::string_view content) { write_all(fd, content, path); });
  } catch (...) {
    ::close(fd);
    throw;
  }
  if (::close(fd) != 0 && errno != EINTR)
    throw IoError(std::string("cannot write: ") + std::strerror(errno), {path});
}

// A file: written to a temporary beside `target` (symbolic links resolved), renamed onto it now
// or, in a batch, at commit.
void write_through_temporary(const std::string& path, const std::string& target,
                             const std::function<void(const ByteWriter&)>& fill) {
  namespace fs = std::filesystem;
  const fs::path t(target);
  const fs::path dir = t.has_parent_path() ? t.parent_path() : fs::path(".");
  create_output_directories(dir.string());
  remove_stale_temporaries(dir);
  std::string tmpl =
      (dir / (temporary_prefix(t.filename().string()) + std::to_string(::getpid()) + ".XXXXXX"))
          .string();
  int fd = -1, slot = -1;
  {
    SignalsHeld held;
    fd = ::mkostemp(tmpl.data(), O_CLOEXEC);
    if (fd < 0) throw IoError(std::string("cannot create file: ") + std::strerror(errno), {path});
    slot = hold(g_temp_slots, tmpl);
  }
  auto drop = [&] {
    if (fd >= 0) ::close(fd);
    ::unlink(tmpl.c_str());
    release(g_temp_slots, slot);
  };
  try {
    fill([&](std::string_view content) { write_all(fd, content, path); });
    ::fchmod(fd, static_cast<mode_t>(output_file_mode()));
    const int closed = ::close(fd);
    fd = -1;
    if (closed != 0) throw IoError(std::string("cannot write: ") + std::strerror(errno), {path});
  } catch (...) {
    drop();
    throw;
  }
  Batch& b = batch();
  {
    std::lock_guard lock(b.mutex);
    if (b.depth > 0) {
      b.staged.push_back({tmpl, target, slot});
      return;
    }
  }
  if (std::rename(tmpl.c_str(), target.c_str()) != 0) {
    const int e = errno;
    drop();
    throw IoError(std::string("cannot write: ") + std::strerror(e), {path});
  }
  release(g_temp_slots, slot);
}

// What an interrupted run says on stderr (set before the run; written from the handler with
// write(2), the only output that is async-signal-safe).
char g_interrupt_label[96] = "trellis";

void say_interrupted(int sig) {
  const char* why = sig == SIGINT    ? " interrupted (Ctrl-C)"
                    : sig == SIGTERM ? " stopped (SIGTERM)"
                    : sig == SIGHUP  ? " stopped: its terminal closed (SIGHUP)"
                                     : nullptr;
  if (!why) return;  // SIGPIPE: the reader is gone, stderr may be too
  const char* tail = "; nothing was written and no file was changed\n";
  auto put = [](const char* t) {
    const ssize_t ignored = ::write(2, t, std::strlen(t));
    (void)ignored;
  };
  put("\n");
  put(g_interrupt_label);
  put(why);
  put(tail);
}

// What the watchdog says when it stops a run (made when it is armed: the handler only writes it).
char g_watchdog_text[256] = "";
bool g_cleanup_installed = false;
timespec g_started{};

extern "C" void cleanup_on_signal(int sig) {
  for (auto& s : g_temp_slots)
    if (char* p = s.load()) ::unlink(p);
  for (std::size_t i = g_dir_slots.size(); i-- > 0;)
    if (char* p = g_dir_slots[i].load()) ::rmdir(p);
  if (sig == SIGALRM) {
    const ssize_t ignored = ::write(2, g_watchdog_text, std::strlen(g_watchdog_text));
    (void)ignored;
    ::_exit(2);  // a budget refusal, like the one before the run
  }
  say_interrupted(sig);
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
  guard_read(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(std::string("cannot open: ") + std::strerror(errno), {path});
  // A regular file is read straight into a string of its size (one copy: meshes of 50 MB and
  // more); anything else (a pipe) through a stream.
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && std::filesystem::is_regular_file(path, ec)) {
    std::string out;
    resize_filled(out, size);
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

InputFile::InputFile(const std::string& path) : path_(path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw IoError("is a directory", {path});
  guard_read(path);
  // O_NONBLOCK: a FIFO is refused below, not waited on (no effect on a regular file's reads).
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd_ < 0) throw IoError(std::string("cannot open: ") + std::strerror(errno), {path});
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd_);
    throw IoError("not a regular file", {path});
  }
  size_ = static_cast<std::uint64_t>(st.st_size);
}

InputFile::~InputFile() {
  ::close(fd_);
}

void InputFile::read_at(std::uint64_t offset, char* out, std::size_t n) const {
  while (n > 0) {
    const ssize_t got = ::pread(fd_, out, n, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw IoError(std::string("cannot read: ") + std::strerror(errno), {path_});
    if (got == 0)
      throw IoError("the file ended at byte " + std::to_string(offset) + " of the " +
                        std::to_string(size_) + " it had when opened (changed while read)",
                    {path_});
    out += got;
    offset += static_cast<std::uint64_t>(got);
    n -= static_cast<std::size_t>(got);
  }
}

unsigned output_file_mode() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("Umask:", 0) == 0)
      return 0666u & ~static_cast<unsigned>(std::strtoul(line.c_str() + 6, nullptr, 8));
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
    if (b.depth > 0)
      b.dirs.emplace_back(it->string(), slot);
    else
      release(g_dir_slots, slot);
  }
}

void write_file_atomic_with(const std::string& path,
                            const std::function<void(const ByteWriter&)>& fill) {
  if (detail::names_folder(path))
    throw IoError(
        path.empty() ? "an output needs a path" : "names a folder: an output needs a file name",
        {path});
  const detail::PathState s = detail::inspect_path(path);
  if (s.kind == detail::PathKind::Folder) throw IoError("is a folder: an output is a file", {path});
  if (s.kind == detail::PathKind::Other)
    throw IoError("is " + s.what + ": outputs are files, FIFOs or character devices", {path});
  claim_target(path, s);
  if (s.kind == detail::PathKind::Stream)
    write_stream(path, s, fill);
  else
    write_through_temporary(path, s.target, fill);
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
  SignalsHeld held;
  std::string error;
  for (const auto& s :
       b.staged) {  // a folder made at a target meanwhile: refused before any rename
    struct stat st {};
    if (error.empty() && ::lstat(s.target.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
      error = s.target + ": a folder is there now, where an output file goes: nothing was written";
  }
  for (const auto& s : b.staged) {
    if (error.empty() && std::rename(s.temp.c_str(), s.target.c_str()) != 0)
      error = s.target + ": cannot write: " + std::strerror(errno);
    if (!error.empty()) ::unlink(s.temp.c_str());
    release(g_temp_slots, s.slot);
  }
  b.staged.clear();
  forget_run(b);
  if (!error.empty()) {
    remove_created_dirs(b);  // the ones still empty
    throw IoError(error);
  }
  for (const auto& d : b.dirs) release(g_dir_slots, d.second);
  b.dirs.clear();
}

OutputBatch::~OutputBatch() {
  if (done_) return;
  Batch& b = batch();
  std::lock_guard lock(b.mutex);
  --b.depth;
  if (!outer_) return;
  remove_staged(b);
  forget_run(b);
}

void set_interrupt_label(const std::string& label) {
  const std::size_t n = std::min(label.size(), sizeof g_interrupt_label - 1);
  std::memcpy(g_interrupt_label, label.data(), n);
  g_interrupt_label[n] = '\0';
}

void install_signal_cleanup() {
  ::clock_gettime(CLOCK_MONOTONIC, &g_started);
  g_cleanup_installed = true;
  struct sigaction sa {};
  sa.sa_handler = cleanup_on_signal;
  sa.sa_mask = cleanup_signals();
  ::sigaction(SIGALRM, &sa, nullptr);
  for (int sig : kCleanupSignals) {
    // A signal the run was started ignoring (nohup, a background job) stays ignored.
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    ::sigaction(sig, &sa, nullptr);
  }
}

void arm_watchdog(double budget_seconds) {
  if (!g_cleanup_installed || !(budget_seconds > 0) || !std::isfinite(budget_seconds)) return;
  static std::mutex m;
  static double armed = 0;
  std::lock_guard lock(m);
  if (armed > 0 && armed <= budget_seconds) return;  // the tightest budget of the run holds
  armed = budget_seconds;
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  const double ran =
      double(now.tv_sec - g_started.tv_sec) + 1e-9 * double(now.tv_nsec - g_started.tv_nsec);
  const double stop = 2 * budget_seconds;
  const double left = std::max(0.001, std::min(stop - ran, 1e8));
  std::snprintf(g_watchdog_text, sizeof g_watchdog_text,
                "\n%s stopped: it ran %.3g s, twice its time budget (run.max_time = %.3g s), "
                "whatever the estimate said; nothing was written and no file was changed. Raise "
                "--max-time or pass --force to run it anyway\n",
                g_interrupt_label, stop, budget_seconds);
  itimerval t{};
  t.it_value.tv_sec = static_cast<time_t>(left);
  t.it_value.tv_usec = static_cast<suseconds_t>((left - std::floor(left)) * 1e6);
  ::setitimer(ITIMER_REAL, &t, nullptr);
}

void disarm_watchdog() {
  if (!g_cleanup_installed) return;
  itimerval t{};
  ::setitimer(ITIMER_REAL, &t, nullptr);
}

bool is_stream_output(const std::string& path) {
  return !path.empty() && detail::inspect_path(path).kind == detail::PathKind::Stream;
}

void require_output_format(const std::string& path, const std::vector<OutputFormat>& formats,
                           const std::string& writer, const std::string& what,
                           const std::string& element) {
  if (path.empty() || formats.empty() || is_stream_output(path)) return;
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  std::string list;
  for (std::size_t i = 0; i < formats.size(); ++i) {
    if (ext == formats[i].extension) return;
    list += (i == 0                    ? ""
             : i + 1 == formats.size() ? " or "
                                       : ", ") +
            formats[i].extension +
            (formats[i].format.empty() ? "" : " (" + formats[i].format + ")");
  }
  throw SettingError("'" + path + "' is named " +
                         (ext.empty() ? std::string("without an extension") : ext) + ", but " +
                         writer + " writes " + what + " as " + list + ": name it so",
                     {"", 0, element});
}

namespace detail {

void guard_inputs(const std::vector<std::pair<FileId, std::string>>& inputs) {
  Batch& b = batch();
  std::lock_guard lock(b.mutex);
  if (b.depth == 0) return;
  b.inputs.insert(b.inputs.end(), inputs.begin(), inputs.end());
  b.checked = true;
}

}  // namespace detail

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
    throw IoError("cannot create a temporary file in " + dir +
                  " (TMPDIR): " + std::strerror(errno));
  std::FILE* f = ::fdopen(fd, "w+b");
  if (!f) {
    const int e = errno;
    ::close(fd);
    throw IoError("cannot open a temporary file in " + dir + ": " + std::strerror(e));
  }
  return f;
}

}  // namespace trellis
