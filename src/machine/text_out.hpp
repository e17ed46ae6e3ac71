// The writers' output text (private): written in place through a pointer, one room check per
// line or number instead of one capacity check per append.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <string>
#include <string_view>

namespace trellis::fastnum {

// The text being written: the first size() bytes of a std::string whose further bytes (up to
// its own size, grown a chunk at a time within its capacity) are room already made, so a line
// is written in place through a pointer (room(), then commit()) with one check per line, not
// one per append. take() hands the text over as the string.
class TextOut {
 public:
  // Takes `s` (its memory, its text kept).
  void adopt(std::string s) {
    s_ = std::move(s);
    n_ = s_.size();
  }
  std::string take() {
    s_.resize(n_);
    n_ = 0;
    return std::move(s_);
  }
  void reserve(std::size_t n) { s_.reserve(n); }
  std::string& storage() { return s_; }  // for advise_huge_pages (its capacity)
  std::size_t size() const { return n_; }
  bool empty() const { return n_ == 0; }
  const char* data() const { return s_.data(); }
  char* data() { return s_.data(); }
  std::string_view view() const { return {s_.data(), n_}; }
  void clear() { n_ = 0; }
  void resize(std::size_t n) {
    if (n > s_.size()) s_.resize(n);
    n_ = n;
  }
  // Where to write up to `n` bytes at the end of the text; commit(end) keeps them.
  [[gnu::always_inline]] char* room(std::size_t n) {
    if (s_.size() - n_ < n) [[unlikely]]
      grow(n);
    return s_.data() + n_;
  }
  [[gnu::always_inline]] void commit(const char* end) {
    n_ = static_cast<std::size_t>(end - s_.data());
  }
  TextOut& operator+=(std::string_view t) {
    std::memcpy(room(t.size()), t.data(), t.size());
    n_ += t.size();
    return *this;
  }
  TextOut& operator+=(char c) {
    *room(1) = c;
    ++n_;
    return *this;
  }

 private:
  // At least `n` bytes of room: the string grown by up to a chunk within its capacity (zeroed
  // while it is in the cache, then written over); a new block, twice as large, only when the
  // capacity runs out (a buffer handed in keeps its memory while it is large enough).
  [[gnu::noinline]] void grow(std::size_t n) {
    constexpr std::size_t kChunk = std::size_t{64} << 10;
    const std::size_t need = n_ + n;
    if (need > s_.capacity()) s_.reserve(std::max(need, 2 * s_.capacity()));
    s_.resize(std::max(need, std::min(s_.capacity(), s_.size() + kChunk)));
  }
  std::string s_;
  std::size_t n_ = 0;
};

}  // namespace trellis::fastnum
