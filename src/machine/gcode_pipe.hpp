// Handing what a G-code scanner reads to another thread (private to src/machine).
#pragma once
#include <bit>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <string_view>
#include <thread>
#include <vector>

#include "trellis/machine/gcode_reader.hpp"

namespace trellis {

// Threads a scan may use: the task arena's, bounded by a global_control (Python's limit, any
// caller's) where one is set.
int scan_threads_allowed();

// The lines of a G-code file, handed from the thread that finds them to a thread that reads them
// with `scanner`, in order: the scanner and its sink see what they would see on one thread
// (gcode_scan.cpp). A record is a line's place in the text read (which stays in its buffer until
// the reader is past the window's mark(): wait_windows()), a plain move's words beside it
// (lexed: gcode_lex::lex_move); a line across two windows is copied in. Records go over in chunks
// of about kChunk bytes through a short queue (the lexing side waits when kDepth are pending:
// memory stays a few chunks).
class ScanPipe {
 public:
  // `valves`: the scanner was given valve commands (GcodeReadOptions::valve_on / valve_off).
  ScanPipe(GcodeScanner& scanner, bool valves) : scanner_(scanner), valves_(valves) {
    cur_.reserve(kChunk + kSlack);
    reader_ = std::thread([this] { consume(); });
  }
  ~ScanPipe() {
    if (!reader_.joinable()) return;
    {
      std::lock_guard lock(m_);
      stop_ = true;
    }
    data_.notify_all();
    reader_.join();
  }
  ScanPipe(const ScanPipe&) = delete;
  ScanPipe& operator=(const ScanPipe&) = delete;

  // A plain move lex_move took: its text (without the newline) and words.
  [[gnu::always_inline]] void move(const char* text, std::uint32_t len,
                                   const GcodeScanner::Words& w) {
    if (cur_.size >= kChunk) hand_off(false);
    char* p = cur_.data.get() + cur_.size;  // room: kSlack past kChunk
    const char* const start = p;
    *p++ = kMove;
    std::memcpy(p, &text, sizeof text);
    std::memcpy(p + sizeof text, &len, sizeof len);
    p = put_words(p + sizeof text + sizeof len, w);
    cur_.size += static_cast<std::size_t>(p - start);
  }
  // Any other line, in the text read.
  void line(const char* text, std::size_t len) {
    if (cur_.size >= kChunk) hand_off(false);
    char* p = cur_.data.get() + cur_.size;
    *p++ = kLine;
    std::memcpy(p, &text, sizeof text);
    std::memcpy(p + sizeof text, &len, sizeof len);
    cur_.size += 1 + sizeof text + sizeof len;
  }
  // A line held nowhere else (across two windows; the last one without a newline): copied.
  void own_line(std::string_view text) { put_text(kOwnLine, text); }
  // The end of a window of text: once the reader is past it, windows_read() counts it.
  void mark() {
    if (cur_.size >= kChunk) hand_off(false);
    cur_.data.get()[cur_.size++] = kMark;
  }
  // Waits until the reader is past `n` marks (the text of those windows may go); the reader's
  // exception, if it threw one, rethrown.
  void wait_windows(std::uint64_t n) {
    {
      std::lock_guard lock(m_);
      if (marks_ >= n) return;
    }
    hand_off(false);  // the mark may still be in the chunk being recorded
    std::unique_lock lock(m_);
    idle_.wait(lock, [&] { return marks_ >= n || error_; });
    if (error_) std::rethrow_exception(error_);
  }
  // Every line recorded so far read (the text they point into may go); the reader's exception,
  // if it threw one, rethrown.
  void sync() {
    hand_off(false);
    std::unique_lock lock(m_);
    idle_.wait(lock, [&] { return (full_.empty() && !busy_) || error_; });
    if (error_) std::rethrow_exception(error_);
  }
  // sync() for a failure of the lexing thread's: the reader's own exception dropped (the
  // caller's goes on).
  void drain() noexcept {
    try {
      sync();
    } catch (...) {
    }
  }
  // The same, and the reading thread ended.
  void finish() {
    hand_off(true);
    reader_.join();
    if (error_) std::rethrow_exception(error_);
  }

 private:
  static constexpr std::size_t kChunk = 128u << 10, kSlack = 512, kDepth = 4;
  static constexpr char kMove = 0, kLine = 1, kOwnLine = 2, kMark = 3;

  // A move's words: the letters' bits, then the values of those letters in order.
  [[gnu::always_inline]] static char* put_words(char* p, const GcodeScanner::Words& w) {
    std::memcpy(p, &w.seen, sizeof w.seen);
    p += sizeof w.seen;
    for (std::uint32_t bits = w.seen; bits; bits &= bits - 1) {
      std::memcpy(p, &w.value[std::countr_zero(bits)], sizeof(double));
      p += sizeof(double);
    }
    return p;
  }
  [[gnu::always_inline]] static const char* take_words(const char* p, GcodeScanner::Words& w) {
    std::memcpy(&w.seen, p, sizeof w.seen);
    p += sizeof w.seen;
    for (std::uint32_t bits = w.seen; bits; bits &= bits - 1) {
      std::memcpy(&w.value[std::countr_zero(bits)], p, sizeof(double));
      p += sizeof(double);
    }
    return p;
  }
  void put_text(char kind, std::string_view text) {
    if (cur_.size >= kChunk) hand_off(false);
    const std::size_t len = text.size();
    cur_.reserve(cur_.size + 1 + sizeof len + len + kSlack);
    char* p = cur_.data.get() + cur_.size;
    *p++ = kind;
    std::memcpy(p, &len, sizeof len);
    if (len) std::memcpy(p + sizeof len, text.data(), len);
    cur_.size += 1 + sizeof len + len;
  }

  // A chunk of records: bytes, `size` of `capacity` used.
  struct Chunk {
    std::unique_ptr<char[]> data;
    std::size_t size = 0, capacity = 0;
    void reserve(std::size_t n) {
      if (n <= capacity) return;
      auto bigger = std::make_unique<char[]>(n);
      if (size) std::memcpy(bigger.get(), data.get(), size);
      data = std::move(bigger);
      capacity = n;
    }
  };

  // The chunk to the reading thread (waiting while kDepth are pending); `last`: no more follow.
  void hand_off(bool last) {
    std::unique_lock lock(m_);
    space_.wait(lock, [&] { return full_.size() < kDepth || error_; });
    if (error_ && !last) std::rethrow_exception(error_);  // the reading failed: stop lexing
    if (cur_.size) {
      full_.push_back(std::move(cur_));
      if (free_.empty()) {
        cur_ = Chunk();
      } else {
        cur_ = std::move(free_.back());
        free_.pop_back();
      }
    }
    cur_.size = 0;
    done_ = last;
    lock.unlock();
    cur_.reserve(kChunk + kSlack);
    data_.notify_one();
  }

  void consume() {
    for (;;) {
      Chunk chunk;
      {
        std::unique_lock lock(m_);
        data_.wait(lock, [&] { return !full_.empty() || done_ || stop_; });
        if (stop_ || full_.empty()) return;
        chunk = std::move(full_.front());
        full_.pop_front();
        busy_ = true;
      }
      space_.notify_one();
      try {
        read(chunk);
      } catch (...) {
        std::lock_guard lock(m_);
        error_ = std::current_exception();
        full_.clear();
        busy_ = false;
        space_.notify_all();
        idle_.notify_all();
        return;
      }
      {
        std::lock_guard lock(m_);
        chunk.size = 0;
        free_.push_back(std::move(chunk));
        busy_ = false;
      }
      idle_.notify_all();
    }
  }

  void read(const Chunk& chunk) {
    const char* p = chunk.data.get();
    const char* const end = p + chunk.size;
    GcodeScanner::Words w;
    while (p < end) {
      const char kind = *p++;
      if (kind == kMove) {
        const char* text;
        std::uint32_t len;
        std::memcpy(&text, p, sizeof text);
        std::memcpy(&len, p + sizeof text, sizeof len);
        p = take_words(p + sizeof text + sizeof len, w);
        // As feed() reads the line: from its words, unless valve commands are (or may be) in
        // force (it reads the text then; either way gives the same without valves).
        if (valves_)
          scanner_.line(std::string_view(text, len));
        else
          scanner_.move_words(w, text[1] - '0');
      } else if (kind == kLine) {
        const char* text;
        std::size_t len;
        std::memcpy(&text, p, sizeof text);
        std::memcpy(&len, p + sizeof text, sizeof len);
        p += sizeof text + sizeof len;
        line(std::string_view(text, len));
      } else if (kind == kMark) {
        {
          std::lock_guard lock(m_);
          ++marks_;
        }
        idle_.notify_all();
      } else {
        std::size_t len;
        std::memcpy(&len, p, sizeof len);
        const std::string_view text(p + sizeof len, len);
        p += sizeof len + len;
        line(text);
      }
    }
  }

  // A line of text to the scanner. Our pneumatic header names the valve commands ("; job:
  // valve_on = ..."): from such a line on, moves are read from their text.
  void line(std::string_view text) {
    if (!valves_ && text.find("valve_o") != std::string_view::npos) valves_ = true;
    scanner_.line(text);
  }

  GcodeScanner& scanner_;
  bool valves_;  // valve commands may be in force (kMove lines read from their text)
  Chunk cur_;    // the chunk being recorded (the lexing thread's)
  std::mutex m_;
  std::condition_variable data_, space_, idle_;
  std::deque<Chunk> full_;   // recorded, not yet read
  std::vector<Chunk> free_;  // read: their memory reused
  bool done_ = false, stop_ = false, busy_ = false;
  std::uint64_t marks_ = 0;   // marks read
  std::exception_ptr error_;  // the reading thread's (a ParseError, the sink's own)
  std::thread reader_;
};

}  // namespace trellis
