// Drives the Progress contract (core/progress.hpp) from a test: a Progress whose callback records
// every report and sets the cancel flag at the first report of a chosen stage, so the work must
// stop at its next per-layer or per-iteration check by throwing Cancelled.
#pragma once
#include <atomic>
#include <mutex>
#include <string>
#include <vector>

#include "trellis/core/progress.hpp"

namespace trellis::test {

class CancelAt {
 public:
  explicit CancelAt(std::string stage = "") : stage_(std::move(stage)) {
    progress.cancel = &flag;
    progress.report = [this](const std::string& stage, double f) {
      std::lock_guard lock(mutex_);
      reports_.emplace_back(stage, f);
      if (stage_.empty() || stage == stage_) flag = true;
    };
  }
  CancelAt(const CancelAt&) = delete;

  std::atomic<bool> flag{false};
  Progress progress;

  std::vector<std::pair<std::string, double>> reports() const {
    std::lock_guard lock(mutex_);
    return reports_;
  }

 private:
  std::string stage_;
  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, double>> reports_;
};

}  // namespace trellis::test
