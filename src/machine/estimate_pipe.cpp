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
constexpr std::size_t kQueued = 16;
// How long the writer waits with a full queue for the reading task to start before reading
// itself (no free worker: the run's other work holds it).
constexpr std::chrono::milliseconds kPatience{50};

// The items, each a tag and its fields: text (length, bytes), a move (g, the words' letters as a
// bit set, their values in letter order, the line's length and bytes), a mark.
constexpr char kText = 'T', kMove = 'M', kMark = 'K';

template <class T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

template <class T>
T get(const char*& at) {
  T v;
  std::memcpy(&v, at, sizeof v);
  at += sizeof v;
  return v;
}

}  // namespace

bool EstimatePipe::worthwhile() {
  const std::size_t allowed =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  const auto arena = static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  return std::min(allowed, arena) >= 2;
}

EstimatePipe::EstimatePipe(Reader& reader) : reader_(reader) {
  batch_.reserve(kBatch + 4096);
  group_.run([this] { work(); });
}

EstimatePipe::~EstimatePipe() {
  if (finished_) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = dropping_ = true;
    queue_.clear();
    if (state_ == State::idle) state_ = State::taken;  // the task, if it starts, does nothing
    ready_.notify_all();
    space_.notify_all();
  }
  try {
    group_.wait();
  } catch (...) {  // the writer's own error is on its way out
  }
}

void EstimatePipe::text(std::string_view t) {
  if (t.empty()) return;
  batch_ += kText;
  put(batch_, static_cast<std::uint64_t>(t.size()));
  batch_.append(t);
  if (batch_.size() >= kBatch) hand_over();
}

void EstimatePipe::move(const GcodeScanner::Words& w, int g, std::string_view line) {
  // The fields composed in place, then appended at once (an append each cost more than the
  // rest of a move's formatting).
  char item[1 + 1 + sizeof w.seen + sizeof w.value + sizeof(std::uint32_t)];
  char* p = item;
  *p++ = kMove;
  *p++ = static_cast<char>(g);
  std::memcpy(p, &w.seen, sizeof w.seen);
  p += sizeof w.seen;
  for (std::uint32_t s = w.seen; s != 0; s &= s - 1, p += sizeof(double))
    std::memcpy(p, &w.value[std::countr_zero(s)], sizeof(double));
  const auto n = static_cast<std::uint32_t>(line.size());
  std::memcpy(p, &n, sizeof n);
  p += sizeof n;
  batch_.append(item, static_cast<std::size_t>(p - item));
  batch_.append(line);
  if (batch_.size() >= kBatch) hand_over();
}

void EstimatePipe::mark() {
  batch_ += kMark;
}

void EstimatePipe::run(std::function<void()> work) {
  group_.run(std::move(work));
}

std::vector<double> EstimatePipe::finish() {
  hand_over();
  {
    std::unique_lock<std::mutex> lock(mutex_);
    closed_ = true;
    ready_.notify_all();
    if (state_ == State::idle) take_over(lock);
  }
  group_.wait();  // the reading task (if it started) and the work beside
  finished_ = true;
  if (error_) std::rethrow_exception(error_);
  return std::move(times_);
}

void EstimatePipe::hand_over() {
  if (batch_.empty()) return;
  std::unique_lock<std::mutex> lock(mutex_);
  while (queue_.size() >= kQueued && !error_ && state_ != State::taken) {
    if (state_ == State::reading) {
      space_.wait(lock);
    } else if (!space_.wait_for(lock, kPatience, [&] { return state_ != State::idle; })) {
      take_over(lock);
    }
  }
  if (error_) {
    batch_.clear();
    return;
  }
  if (state_ == State::taken) {
    lock.unlock();
    read(batch_);
    batch_.clear();
    return;
  }
  queue_.push_back(std::move(batch_));
  ready_.notify_one();
  batch_ = std::string();
  batch_.reserve(kBatch + 4096);
}

// The reading task has not started: the writer reads what is queued, and from now on each batch
// as it hands it over.
void EstimatePipe::take_over(std::unique_lock<std::mutex>& lock) {
  state_ = State::taken;
  std::deque<std::string> queued = std::move(queue_);
  queue_.clear();
  lock.unlock();
  for (const std::string& b : queued) read(b);
  lock.lock();
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

void EstimatePipe::work() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (state_ != State::idle) return;  // the writer read it all itself
  state_ = State::reading;
  space_.notify_all();
  for (;;) {
    ready_.wait(lock, [&] { return !queue_.empty() || closed_; });
    if (queue_.empty()) break;
    const std::string batch = std::move(queue_.front());
    queue_.pop_front();
    space_.notify_all();
    if (error_ || dropping_) continue;
    lock.unlock();
    try {
      read(batch);
    } catch (...) {
      lock.lock();
      error_ = std::current_exception();
      queue_.clear();
      space_.notify_all();
      continue;
    }
    lock.lock();
  }
}

}  // namespace trellis
