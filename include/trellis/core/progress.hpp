// Progress and cancel hooks passed into long-running work. Both optional.
#pragma once
#include <atomic>
#include <functional>
#include <string>

namespace trellis {

struct Progress {
  // Called with a stage name and a fraction in [0,1]; may be called from worker threads.
  std::function<void(const std::string& stage, double fraction)> report;
  // Set to true from any thread to stop work early; the work then throws trellis::Error.
  const std::atomic<bool>* cancel = nullptr;

  void operator()(const std::string& stage, double fraction) const {
    if (report) report(stage, fraction);
  }
  bool cancelled() const { return cancel && cancel->load(std::memory_order_relaxed); }
};

}  // namespace trellis
