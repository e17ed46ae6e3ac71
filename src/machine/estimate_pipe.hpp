// The G-code writer's print-time estimate on a second thread (issue 40): the writer formats the
// text on its own thread and hands over what the estimate reads, in order — text, the words of
// each move line, marks where it wants the time so far — in batches, to a task that reads them
// while the next moves are formatted. The estimate reads exactly what it would read inline, so
// every number written is the same for any thread count; only the times at the marks are known
// at finish() instead of at once, which the writer needs only then (its M73 lines, the footer's
// time and the parts' times go in late anyway).
// Memory stays bounded (at most kQueued batches wait). Safe without a free worker: if the reading
// task has not started when the queue is full, or when the writer finishes, the writer reads the
// rest itself.
#pragma once
#include <tbb/task_group.h>

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
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
  // Other work of the writer's beside the writing (thumbnails); finish() waits for it too.
  void run(std::function<void()> work);
  // Everything read and the work beside done: the time at each mark, in order. Rethrows what
  // the reading or the work beside threw.
  std::vector<double> finish();

 private:
  enum class State { idle, reading, taken };
  void hand_over();
  void take_over(std::unique_lock<std::mutex>& lock);
  void read(std::string_view batch);
  void work();

  Reader& reader_;
  std::string batch_;          // items not yet handed over
  std::vector<double> times_;  // the reader's: the time at each mark read
  std::mutex mutex_;
  std::condition_variable ready_, space_;
  std::deque<std::string> queue_;
  State state_ = State::idle;
  bool closed_ = false, dropping_ = false, finished_ = false;
  std::exception_ptr error_;
  tbb::task_group group_;
};

}  // namespace trellis
