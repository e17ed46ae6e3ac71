// Recoverable oddities (a duplicate edge dropped, a directed flag ignored): counted by kind,
// the first few kept as messages, printed as warnings and written into reports.
#pragma once
#include <map>
#include <string>
#include <vector>

namespace trellis {

class Diagnostics {
 public:
  static constexpr std::size_t kMaxMessagesPerKind = 5;

  void warn(const std::string& kind, const std::string& message);
  void merge(const Diagnostics& other);
  std::size_t count(const std::string& kind) const;
  std::size_t total() const;
  const std::map<std::string, std::size_t>& counts() const { return counts_; }
  struct Message {
    std::string kind, text;
  };
  // Messages kept (at most kMaxMessagesPerKind per kind), in order of arrival.
  const std::vector<Message>& messages() const { return messages_; }

 private:
  std::map<std::string, std::size_t> counts_;
  std::vector<Message> messages_;
};

}  // namespace trellis
