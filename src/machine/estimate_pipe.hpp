// The G-code writer's print-time estimate on a second thread (issue 40): the writer formats the
// text on its own thread and hands over what the estimate reads, in order — text, the words of
// each move line, marks where it wants the time so far — in batches, to a task that reads them
// while the next moves are formatted. The estimate reads exactly what it would read inline, so
// every number written is the same for any thread count; only the times at the marks are known
// at finish() instead of at once, which the writer needs only then (its M73 lines, the footer's
// time and the parts' times go in late anyway).
// Memory stays bounded (at most kQueued batches wait; their buffers are reused). Safe without a
// free worker: if the reading task has not started when the queue is full, or when the writer
// finishes, the writer reads the rest itself.
// Other work beside the writing (run(): the thumbnails) is done by the reading task while it has
// nothing to read, and by the writer at finish() if the reading task has not taken it: not left
// for the writer's final wait, where it would add to the writing instead of going beside it.
#pragma once
#include <tbb/task_group.h>

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "trellis/machine/gcode_reader.hpp"

namespace trellis {

class EstimatePipe {
 public:
  // What reads the handed-over items, as the writer's inline estimate would.
  struct Reader {
    virtual ~Reader() = default;
    virtual void text(std::string_view t) = 0;
    // False: not taken (`line`, the move's text, is read as text instead).
    virtual bool move(const GcodeScanner::Words& w, int g) = 0;
    virtual double elapsed() const = 0;
  };

  // Whether the run has two threads for it (the arena's, within run.threads' global limit).
  static bool worthwhile();

  explicit EstimatePipe(Reader& reader);
  // Without finish() (the writer is failing): what is queued is dropped and the tasks waited for.
  ~EstimatePipe();
  EstimatePipe(const EstimatePipe&) = delete;
  EstimatePipe& operator=(const EstimatePipe&) = delete;

  // The writer's side, in text order.
  void text(std::string_view t);
  void move(const GcodeScanner::Words& w, int g, std::string_view line);
  void mark();
  // Other work of the writer's beside the writing (thumbnails), done by the reading task when it
  // waits for text, else by finish(); finish() waits for it too.
  void run(std::function<void()> work);
  // Everything read and the work beside done: the time at each mark, in order. Rethrows what
  // the reading or the work beside threw.
  std::vector<double> finish();

 private:
  enum class State { idle, reading, taken };
  // A run of items in a buffer of its own (uninitialised memory: the items are written in place).
  struct Batch {
    std::unique_ptr<char[]> data;
    std::size_t size = 0, capacity = 0;
    std::string_view view() const { return {data.get(), size}; }
  };
  // Room for an item of n bytes at the end of batch_ (handed over first if it is full).
  char* room(std::size_t n);
  void hand_over();
  void take_over(std::unique_lock<std::mutex>& lock);
  void read(std::string_view batch);
  void work();
  // Side work not yet taken, run by the caller (the lock held on entry and on return).
  bool run_side(std::unique_lock<std::mutex>& lock);

  Reader& reader_;
  Batch batch_;                // items not yet handed over
  std::vector<double> times_;  // the reader's: the time at each mark read
  std::mutex mutex_;
  std::condition_variable ready_, space_;
  std::deque<Batch> queue_;
  std::vector<Batch> spare_;                // buffers read, for the writer to reuse
  std::deque<std::function<void()>> side_;  // work beside not yet taken
  std::exception_ptr side_error_;           // what the work beside threw on the reading task
  State state_ = State::idle;
  bool closed_ = false, dropping_ = false, finished_ = false;
  std::exception_ptr error_;
  tbb::task_group group_;
};

}  // namespace trellis
