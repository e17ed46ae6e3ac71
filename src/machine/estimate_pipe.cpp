#include "estimate_pipe.hpp"

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdint>
#include <cstring>

namespace trellis {

namespace {

// About 256 kB a batch (a few thousand moves), at most 16 waiting: 4 MB whatever the file's size.
constexpr std::size_t kBatch = std::size_t{1} << 18;
constexpr std::size_t kCapacity = kBatch + 4096;  // a batch's buffer: the last item fits in
constexpr std::size_t kQueued = 16;
constexpr std::size_t kSpare = 4;  // buffers kept for reuse (no new pages for each batch)
// How long the writer waits with a full queue for the reading task to start before reading
// itself (no free worker: the run's other work holds it).
constexpr std::chrono::milliseconds kPatience{50};

// The items, each a tag and its fields: text (length, bytes), a move (g, the words' letters as a
// bit set, their values in letter order, the line's length and bytes), a mark.
constexpr char kText = 'T', kMove = 'M', kMark = 'K';

template <class T>
char* put(char* at, const T& v) {
  std::memcpy(at, &v, sizeof v);
  return at + sizeof v;
}

template <class T>
T get(const char*& at) {
  T v;
  std::memcpy(&v, at, sizeof v);
  at += sizeof v;
  return v;
}

// The threads the run has here (the arena's, within run.threads' global limit).
std::size_t concurrency() {
  const std::size_t allowed =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  const auto arena = static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  return std::min(allowed, arena);
}

}  // namespace

bool EstimatePipe::worthwhile() {
  return concurrency() >= 2;
}

EstimatePipe::EstimatePipe(Reader& reader) : reader_(reader) {
  batch_.data.reset(new char[kCapacity]);
  batch_.capacity = kCapacity;
  group_.run([this] { work(); });
}

EstimatePipe::~EstimatePipe() {
  if (finished_) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = dropping_ = true;
    queue_.clear();
    side_.clear();
    if (state_ == State::idle) state_ = State::taken;  // the task, if it starts, does nothing
    ready_.notify_all();
    space_.notify_all();
  }
  try {
    group_.wait();
  } catch (...) {  // the writer's own error is on its way out
  }
}

char* EstimatePipe::room(std::size_t n) {
  if (batch_.size + n > batch_.capacity) {
    hand_over();
    if (n > batch_.capacity) {  // a text longer than a batch: a buffer of its own
      batch_.data.reset(new char[n]);
      batch_.capacity = n;
    }
  }
  return batch_.data.get() + batch_.size;
}

void EstimatePipe::text(std::string_view t) {
  if (t.empty()) return;
  const std::size_t n = 1 + sizeof(std::uint64_t) + t.size();
  char* p = room(n);
  *p++ = kText;
  p = put(p, static_cast<std::uint64_t>(t.size()));
  std::memcpy(p, t.data(), t.size());
  batch_.size += n;
  if (batch_.size >= kBatch) hand_over();
}

// Written in place (the writer's hot path: one per move line).
void EstimatePipe::move(const GcodeScanner::Words& w, int g, std::string_view line) {
  const std::size_t n = 2 + sizeof w.seen +
                        sizeof(double) * static_cast<std::size_t>(std::popcount(w.seen)) +
                        sizeof(std::uint32_t) + line.size();
  char* p = room(n);
  p[0] = kMove;
  p[1] = static_cast<char>(g);
  p = put(p + 2, w.seen);
  for (std::uint32_t s = w.seen; s != 0; s &= s - 1) p = put(p, w.value[std::countr_zero(s)]);
  p = put(p, static_cast<std::uint32_t>(line.size()));
  std::memcpy(p, line.data(), line.size());
  batch_.size += n;
  if (batch_.size >= kBatch) hand_over();
}

void EstimatePipe::mark() {
  *room(1) = kMark;
  ++batch_.size;
}

void EstimatePipe::run(std::function<void()> work) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    side_.push_back(std::move(work));
  }
  ready_.notify_all();
  // With a third thread free, it may take the work first (with two, this task finds it taken:
  // the one worker holds the reading task, and the writer runs this one in its final wait).
  if (concurrency() >= 3)
    group_.run([this] {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!dropping_) run_side(lock);
    });
}

std::vector<double> EstimatePipe::finish() {
  hand_over();
  {
    std::unique_lock<std::mutex> lock(mutex_);
    closed_ = true;
    ready_.notify_all();
    if (state_ == State::idle) take_over(lock);
    // The work beside the reading task has not taken (it is still reading, or never came).
    while (run_side(lock)) {
    }
  }
  group_.wait();  // the reading task (if it started), and the work beside it took
  finished_ = true;
  if (error_) std::rethrow_exception(error_);
  if (side_error_) std::rethrow_exception(side_error_);
  return std::move(times_);
}

void EstimatePipe::hand_over() {
  if (batch_.size == 0) return;
  std::unique_lock<std::mutex> lock(mutex_);
  while (queue_.size() >= kQueued && !error_ && state_ != State::taken) {
    if (state_ == State::reading) {
      space_.wait(lock);
    } else if (!space_.wait_for(lock, kPatience, [&] { return state_ != State::idle; })) {
      take_over(lock);
    }
  }
  if (error_) {
    batch_.size = 0;
    return;
  }
  if (state_ == State::taken) {
    lock.unlock();
    read(batch_.view());
    batch_.size = 0;
    return;
  }
  queue_.push_back(std::move(batch_));
  ready_.notify_one();
  batch_ = Batch();
  if (!spare_.empty()) {
    batch_ = std::move(spare_.back());
    spare_.pop_back();
  }
  lock.unlock();
  batch_.size = 0;
  if (batch_.capacity < kCapacity) {
    batch_.data.reset(new char[kCapacity]);
    batch_.capacity = kCapacity;
  }
}

// The reading task has not started: the writer reads what is queued, and from now on each batch
// as it hands it over.
void EstimatePipe::take_over(std::unique_lock<std::mutex>& lock) {
  state_ = State::taken;
  std::deque<Batch> queued = std::move(queue_);
  queue_.clear();
  lock.unlock();
  for (const Batch& b : queued) read(b.view());
  lock.lock();
}

bool EstimatePipe::run_side(std::unique_lock<std::mutex>& lock) {
  if (side_.empty()) return false;
  const std::function<void()> f = std::move(side_.front());
  side_.pop_front();
  lock.unlock();
  try {
    f();
  } catch (...) {
    lock.lock();
    if (!side_error_) side_error_ = std::current_exception();
    return true;
  }
  lock.lock();
  return true;
}

void EstimatePipe::read(std::string_view batch) {
  const char* at = batch.data();
  const char* const end = at + batch.size();
  while (at < end) {
    const char tag = *at++;
    if (tag == kText) {
      const auto n = static_cast<std::size_t>(get<std::uint64_t>(at));
      reader_.text({at, n});
      at += n;
    } else if (tag == kMove) {
      const int g = static_cast<unsigned char>(*at++);
      GcodeScanner::Words w;
      w.seen = get<std::uint32_t>(at);
      for (std::uint32_t s = w.seen; s != 0; s &= s - 1)
        w.value[std::countr_zero(s)] = get<double>(at);
      const std::size_t n = get<std::uint32_t>(at);
      if (!reader_.move(w, g)) reader_.text({at, n});
      at += n;
    } else {
      times_.push_back(reader_.elapsed());
    }
  }
}

// The reading task: each batch as it comes, in order; the work beside while none waits.
void EstimatePipe::work() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (state_ != State::idle) return;  // the writer read it all itself
  state_ = State::reading;
  space_.notify_all();
  for (;;) {
    ready_.wait(lock, [&] { return !queue_.empty() || closed_ || !side_.empty(); });
    if (queue_.empty()) {
      if (run_side(lock)) continue;
      break;  // closed, everything read
    }
    Batch batch = std::move(queue_.front());
    queue_.pop_front();
    space_.notify_all();
    if (error_ || dropping_) continue;
    lock.unlock();
    try {
      read(batch.view());
    } catch (...) {
      lock.lock();
      error_ = std::current_exception();
      queue_.clear();
      space_.notify_all();
      continue;
    }
    lock.lock();
    if (spare_.size() < kSpare) spare_.push_back(std::move(batch));
  }
}

}  // namespace trellis
