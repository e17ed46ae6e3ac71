#include "trellis/core/diagnostics.hpp"

namespace trellis {

void Diagnostics::warn(const std::string& kind, const std::string& message) {
  if (++counts_[kind] <= kMaxMessagesPerKind) messages_.push_back({kind, message});
}

void Diagnostics::merge(const Diagnostics& other) {
  for (const auto& [kind, n] : other.counts_) counts_[kind] += n;
  for (const auto& m : other.messages_) messages_.push_back(m);
}

std::size_t Diagnostics::count(const std::string& kind) const {
  auto it = counts_.find(kind);
  return it == counts_.end() ? 0 : it->second;
}

std::size_t Diagnostics::total() const {
  std::size_t n = 0;
  for (const auto& [kind, c] : counts_) n += c;
  return n;
}

}  // namespace trellis
