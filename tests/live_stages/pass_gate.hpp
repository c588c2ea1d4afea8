// The live stages' tests' view of their passes: counts them, and can hold the stages' thread at
// the end of a pass so that groups handed over meanwhile fold into the next one.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>

#include "ioct/gpu/live_stages/volume_stages.hpp"

namespace ioct::gpu::live {

// Counts passes; while closed, holds the stages' thread at the end of a pass, so that the groups
// handed over meanwhile fold into the next pass (the same passes on every backend).
class PassGate {
 public:
  void on_pass(const StagesPass& pass) {
    std::unique_lock lock(mutex_);
    ++passes_;
    groups_ += pass.groups;
    if (pass.groups > 1) ++folded_passes_;
    changed_.notify_all();
    changed_.wait(lock, [&] { return open_; });
  }
  void close() {
    std::lock_guard lock(mutex_);
    open_ = false;
  }
  void open() {
    {
      std::lock_guard lock(mutex_);
      open_ = true;
    }
    changed_.notify_all();
  }
  // Waits until `groups` hand-overs have been through passes.
  void wait_for_groups(std::uint64_t groups) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return groups_ >= groups; });
  }
  std::uint64_t passes() const {
    std::lock_guard lock(mutex_);
    return passes_;
  }
  std::uint64_t folded_passes() const {
    std::lock_guard lock(mutex_);
    return folded_passes_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = true;
  std::uint64_t passes_ = 0, groups_ = 0, folded_passes_ = 0;
};

}  // namespace ioct::gpu::live
