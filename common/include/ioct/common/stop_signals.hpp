// SIGINT and SIGTERM as a request to stop, taken the same way in every process: blocked in all
// threads and read from a signalfd, so no handler runs in signal context and no real-time thread is
// ever interrupted. Construct StopSignals first in main, before any thread starts (threads inherit
// the mask). A loop that polls takes the signals from fd() (ioct-rt's housekeeping loop); a process
// whose loops do not (ioct-gpu, ioct-record) lets a StopWatcher call its stop function.
#pragma once

#include <signal.h>

#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>

namespace ioct {

class StopSignals {
 public:
  // Blocks SIGINT and SIGTERM in the calling thread and opens a non-blocking signalfd for them.
  // Throws std::system_error.
  StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  StopSignals(StopSignals&&) = delete;
  StopSignals& operator=(StopSignals&&) = delete;
  ~StopSignals();

  // Readable when a signal is pending.
  [[nodiscard]] int fd() const noexcept { return fd_; }
  // The pending signal's number, or 0 when none.
  [[nodiscard]] int take() const noexcept;
  // Waits up to `timeout_ns` for one; its number, or 0 when none came.
  [[nodiscard]] int wait_for(std::uint64_t timeout_ns) const noexcept;

 private:
  sigset_t signals_{};
  int fd_ = -1;
};

// A thread that calls `on_stop(signal)` (on that thread, not in signal context) at the first
// signal. The second signal ends the process at once by the signal's default action, as a second
// Ctrl-C should. A process with nothing to stop yet (still starting) calls end_by() from on_stop.
class StopWatcher {
 public:
  StopWatcher(const StopSignals& signals, std::function<void(int signal)> on_stop);
  StopWatcher(const StopWatcher&) = delete;
  StopWatcher& operator=(const StopWatcher&) = delete;
  StopWatcher(StopWatcher&&) = delete;
  StopWatcher& operator=(StopWatcher&&) = delete;
  ~StopWatcher();  // stops watching; a signal afterwards stays pending

  // Ends the process by `signal`'s default action, now (it is unblocked in the calling thread).
  [[noreturn]] static void end_by(int signal);

 private:
  void watch(const StopSignals& signals) const;

  std::function<void(int)> on_stop_;
  int wake_fd_ = -1;  // an eventfd: the destructor's "stop watching"
  std::thread thread_;
};

// What a StopWatcher stops: the object running now (its request_stop()), or the process itself
// while none runs (a start-up stuck in a driver stays interruptible). The lock makes sure no stop
// reaches an object after its run has ended.
template <class Target>
class StopTarget {
 public:
  void stop(int signal) {
    const std::lock_guard lock(mutex_);
    if (target_ == nullptr) StopWatcher::end_by(signal);
    target_->request_stop();
  }

  // `target` is what a signal stops while the returned guard lives.
  [[nodiscard]] auto running(Target& target) {
    struct Guard {
      explicit Guard(StopTarget& o) : owner(o) {}
      Guard(const Guard&) = delete;
      Guard& operator=(const Guard&) = delete;
      Guard(Guard&&) = delete;
      Guard& operator=(Guard&&) = delete;
      ~Guard() { owner.set(nullptr); }
      StopTarget& owner;
    };
    set(&target);
    return Guard(*this);
  }

 private:
  void set(Target* target) {
    const std::lock_guard lock(mutex_);
    target_ = target;
  }

  std::mutex mutex_;
  Target* target_ = nullptr;
};

}  // namespace ioct
