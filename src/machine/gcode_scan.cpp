// A G-code file through the scanner (issue 40: reading within a small factor of `cat`):
//  - a regular file is read a 128 kB window at a time into buffers used in turn (the copy stays
//    in the cache and costs what mapping the file did; no per-line allocation; a line across two
//    windows is the scanner's one partial line). A file another program shortens or rewrites
//    while it is read is an error naming it (a mapped file ended the process with SIGBUS);
//  - a large file, when two threads are allowed, is scanned on two: this thread finds the lines
//    and lexes the plain moves among them (gcode_lex::lex_move: words and numbers), a second
//    thread reads them in order with the one scanner (its state, its warnings, its sink: the
//    counts, the print-time planner, the toolpath builder), a lexed move as feed() would read
//    that line (from its words: GcodeScanner::move_words). Everything but the lexing happens on
//    the second thread in the order of the text: the results are those of a one-thread scan.
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "gcode_lex.hpp"
#include "gcode_pipe.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/bgcode.hpp"
#include "trellis/machine/gcode_reader.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#define TRELLIS_READ_IN_WINDOWS 1
#endif

namespace trellis {

namespace {

// Files from this size on are scanned on two threads (when allowed): below it the second
// thread's start costs more than it saves.
constexpr std::uint64_t kTwoThreadBytes = std::uint64_t{2} << 20;

// The lines of `text` to `pipe`, the plain moves lexed; `partial`: the start of a line the last
// window ended in (completed here), and where one this window ends in is kept.
void lex_window(std::string_view text, std::string& partial, ScanPipe& pipe) {
  const char* p = text.data();
  const char* const end = p + text.size();
  if (!partial.empty()) {
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', text.size()));
    if (nl == nullptr) {
      partial.append(p, end);
      return;
    }
    partial.append(p, nl);
    pipe.own_line(partial);
    partial.clear();
    p = nl + 1;
  }
  // Lines up to the window's last newline (lex_move needs one ahead); the rest is a partial line.
  const char* const last_nl = gcode_lex::last_newline(p, end);
  if (last_nl == nullptr) {
    partial.assign(p, end);
    return;
  }
  GcodeScanner::Words w;
  while (p <= last_nl) {
    if (const char* next = gcode_lex::lex_move(p, w)) {
      pipe.move(p, static_cast<std::uint32_t>(next - 1 - p), w);
      p = next;
      continue;
    }
    const char* nl =
        static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(last_nl + 1 - p)));
    pipe.line(p, static_cast<std::size_t>(nl - p));
    p = nl + 1;
  }
  if (p < end) partial.assign(p, end);
}

#ifdef TRELLIS_READ_IN_WINDOWS
// An open file descriptor, closed when done.
struct Fd {
  int fd = -1;
  explicit Fd(const std::string& path) : fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {}
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

// A regular file of plain text: its size; 0 when it is none of that (a pipe, a device, an
// empty or binary G-code): read with the stream then.
std::uint64_t regular_size(const Fd& f) {
  struct stat st {};
  if (f.fd < 0 || ::fstat(f.fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size < 4) return 0;
  char magic[4] = {};
  if (::pread(f.fd, magic, 4, 0) != 4 || is_bgcode(std::string_view(magic, 4))) return 0;
  return static_cast<std::uint64_t>(st.st_size);
}

// A window of text: small enough that the copy into it stays in a core's cache (read() into
// 128 kB costs what mapping the file costs: bench/io_vs_cat.sh; a mapped file cut short by
// another program while being read ends the process with SIGBUS instead of an error).
constexpr std::size_t kWindow = std::size_t{128} << 10;
// Windows in turn on two threads (tests/machine/test_scan_file.cpp counts on at most 2 MB ahead).
constexpr std::size_t kRing = 16;

[[noreturn]] void changed_while_read(const std::string& path) {
  throw IoError(
      "changed while it was read (another program shortened or rewrote it): read it again once "
      "it is complete",
      {path});
}

// Buffers for the windows of a file, used in turn (owned by the caller: what was fed from them
// may still be read when feed_windows throws).
using WindowBuffers = std::vector<std::unique_ptr<char[]>>;

// The file's `size` bytes read a window at a time into `buffers` in turn, each window to `feed`
// (its text); `reuse(n)` before a buffer is filled again returns once the first n windows are
// done with. A file that ends early, or whose size is not `size` once read, is an error naming
// it (the results would be of neither version).
template <class Feed, class Reuse>
void feed_windows(const Fd& f, std::uint64_t size, const std::string& path, WindowBuffers& buffers,
                  Feed&& feed, Reuse&& reuse) {
  const std::size_t ring = buffers.size();
  std::uint64_t k = 0;
  for (std::uint64_t at = 0; at < size; at += kWindow, ++k) {
    const auto want = static_cast<std::size_t>(std::min<std::uint64_t>(kWindow, size - at));
    auto& buffer = buffers[k % ring];
    if (!buffer) {
      buffer = std::make_unique<char[]>(kWindow);
    } else if (ring > 1) {
      reuse(k - ring + 1);
    }
    std::size_t got = 0;
    while (got < want) {
      const ssize_t n = ::pread(f.fd, buffer.get() + got, want - got, static_cast<off_t>(at + got));
      if (n > 0) {
        got += static_cast<std::size_t>(n);
      } else if (n == 0) {
        changed_while_read(path);
      } else if (errno != EINTR) {
        throw IoError(std::string("cannot read: ") + std::strerror(errno), {path});
      }
    }
    feed(std::string_view(buffer.get(), want));
  }
  struct stat st {};
  if (::fstat(f.fd, &st) != 0 || static_cast<std::uint64_t>(st.st_size) != size)
    changed_while_read(path);
}
#endif

// The file through the stream, in 1 MB pieces (pipes, devices, binary G-code).
void feed_stream(std::ifstream& in, GcodeScanner& scanner, const std::string& path) {
  char magic[4] = {};
  in.read(magic, 4);
  const std::string_view head(magic, static_cast<std::size_t>(in.gcount()));
  if (is_bgcode(head)) {
    in.seekg(0);
    read_bgcode(
        [&](char* dst, std::size_t n) {
          in.read(dst, static_cast<std::streamsize>(n));
          return static_cast<std::size_t>(in.gcount());
        },
        [&](std::string_view t) { scanner.feed(t); }, path);
    return;
  }
  scanner.feed(head);
  std::string buf(1 << 20, '\0');
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got == 0) break;
    scanner.feed(std::string_view(buf.data(), got));
  }
  if (in.bad()) throw IoError("cannot read", {path});
}

}  // namespace

int scan_threads_allowed() {
  const auto allowed =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  return static_cast<int>(std::min<std::size_t>(
      allowed, static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()))));
}

// A regular file read a window at a time into buffers used in turn; a large one (2 MB on) on two
// threads when the task arena and any tbb::global_control allow two (lines found and moves lexed
// on this thread, read on the other in order: the same results); pipes and binary G-code in 1 MB
// pieces.
void scan_gcode_file(const std::string& path, GcodeSink& sink, const GcodeReadOptions& options,
                     Diagnostics& diag) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw IoError("is a directory", {path});
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open", {path});
  GcodeScanner scanner(sink, options, diag, path);
  bool windows = false;
#ifdef TRELLIS_READ_IN_WINDOWS
  const Fd f(path);
  const std::uint64_t size = regular_size(f);
  windows = size > 0;
  if (size >= kTwoThreadBytes && scan_threads_allowed() >= 2) {
    // Sixteen windows in turn: the lexing runs up to 2 MB ahead of the reading. (Declared before
    // the pipe: its reading thread ends before they go.)
    WindowBuffers buffers(kRing);
    ScanPipe pipe(scanner, !options.valve_on.empty() || !options.valve_off.empty());
    std::string partial;
    try {
      feed_windows(
          f, size, path, buffers,
          [&](std::string_view text) {
            lex_window(text, partial, pipe);
            pipe.mark();
          },
          [&](std::uint64_t n) { pipe.wait_windows(n); });
      if (!partial.empty()) pipe.own_line(partial);  // the last line, without a newline
    } catch (...) {
      // A failure of this thread's (no memory, the file unreadable or cut short): what was
      // recorded is read first, as on one thread.
      pipe.drain();
      throw;
    }
    pipe.finish();
  } else if (windows) {
    WindowBuffers buffer(1);
    feed_windows(
        f, size, path, buffer, [&](std::string_view text) { scanner.feed(text); },
        [](std::uint64_t) {});
  }
#endif
  if (!windows) feed_stream(in, scanner, path);
  scanner.finish();
}

}  // namespace trellis
