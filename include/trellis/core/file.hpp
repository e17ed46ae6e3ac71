// File helpers: whole-file reads with clear errors, and atomic writes (temp file + rename) so a
// failed run never leaves a half-written output behind.
//
// Outputs of one command or job are committed together: while an OutputBatch is open,
// write_file_atomic writes each file to a temporary beside its target and the batch renames them
// all at commit(); a batch closed without commit (an error, bad_alloc, a cancel) removes its
// temporaries and the folders it created, so the output folder holds what it held before.
// Temporaries are named .NAME.trellis-tmp.PID.XXXXXX; those whose process is gone (kill -9) are
// removed by the next write into their folder (each folder once per process), with the
// subfolders that held nothing else (a killed run's previews). SIGINT, SIGTERM, SIGHUP and SIGPIPE
// (install_signal_cleanup) remove the temporaries of the moment too, then exit with 128 + the
// signal. The set of live temporaries is the one process-wide state here: a signal handler can
// reach nothing else; the open batch also holds the inputs of its run (RunFiles, never written)
// and the targets written (each once).
//
// What a path names decides how it is written: a missing or regular file through a temporary and
// rename (a symbolic link: the file it points to); a FIFO, a character device (/dev/null) or a
// descriptor (/dev/stdout, /dev/fd/N) is opened and written through, never replaced; a folder,
// a block device or a socket is an IoError. Whether a run may write there at all is RunFiles'
// (core/run_files.hpp).
#pragma once
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <string_view>

namespace trellis {

std::string read_file(const std::string& path);

// Whether writing `path` goes through to a stream: a FIFO, a character device (/dev/null, a link to
// it) or a descriptor (/dev/stdout). Its name says no format: the writers write their route's own
// format there (the output name checks pass it).
bool is_stream_output(const std::string& path);

// A regular file read in pieces, from any thread and in any order (pread), with read_file's
// checks when opened (a folder, a device or a FIFO is refused; a run's input is guarded). For
// files too large to copy whole before use. A piece the file no longer holds (it shrank while
// read) is an IoError naming the file: never a crash, as a mapping of the file would be (SIGBUS).
class InputFile {
 public:
  explicit InputFile(const std::string& path);
  ~InputFile();
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  std::uint64_t size() const { return size_; }
  // Bytes offset .. offset + n into `out`.
  void read_at(std::uint64_t offset, char* out, std::size_t n) const;

 private:
  std::string path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};
void write_file_atomic(const std::string& path, std::string_view content);
// The same, written in pieces (a file too large to hold): `fill` appends bytes through the writer
// it is given; an exception from it removes the temporary.
using ByteWriter = std::function<void(std::string_view)>;
void write_file_atomic_with(const std::string& path,
                            const std::function<void(const ByteWriter&)>& fill);
// Line number (1-based) of byte offset `pos` in `text`.
long line_of_offset(std::string_view text, std::size_t pos);

// create_directories for an output folder: the folders it creates are removed again (when still
// empty) if the enclosing OutputBatch is not committed or a signal ends the process.
void create_output_directories(const std::string& dir);

// Opens a batch of outputs (see above). Batches nest: only the outermost one commits or removes.
class OutputBatch {
 public:
  OutputBatch();
  ~OutputBatch();
  OutputBatch(const OutputBatch&) = delete;
  OutputBatch& operator=(const OutputBatch&) = delete;
  // Renames every staged temporary onto its target (outermost batch only).
  void commit();

 private:
  bool outer_ = false;
  bool done_ = false;
};

// SIGINT, SIGTERM, SIGHUP and SIGPIPE remove the live temporaries and created folders, then
// _exit(128 + signal); a signal the process was started ignoring (nohup) stays ignored. For
// programs (the CLI); a library user keeps its own signal handling.
void install_signal_cleanup();
// What the interrupted run is called in the message the signal handler prints ("trellis pbf
// interrupted (Ctrl-C); nothing was written and no file was changed").
void set_interrupt_label(const std::string& label);
// The watchdog: once the process has run twice `budget_seconds` (run.max_time) since
// install_signal_cleanup, it stops as on a signal (temporaries and created folders removed), says
// so on stderr and exits 2, whatever the estimate before the run said. Armed by check_budget
// (core/budget.hpp) unless run.force; the tightest budget of a run holds. Nothing without
// install_signal_cleanup: a library user keeps its own SIGALRM.
void arm_watchdog(double budget_seconds);
// Stops the watchdog: a run ending with its own error says that error whole (the watchdog's
// line could otherwise cut it).
void disarm_watchdog();

// An anonymous temporary file (read/write, binary) for data too large to hold in memory: made in
// $TMPDIR (or /tmp when TMPDIR is unset or empty), unlinked already, so it is gone with the
// process whatever happens. std::tmpfile ignores TMPDIR; this does not. Throws IoError naming the
// folder if it cannot be made there.
std::FILE* temporary_file();

// The file mode new outputs get: 0666 less the process umask.
unsigned output_file_mode();

}  // namespace trellis
