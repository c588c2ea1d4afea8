// SIGINT and SIGTERM, taken synchronously: they are blocked in every thread (block them before
// starting any) and read from a signalfd in the housekeeping loop's poll(), so no handler runs
// in signal context and the real-time threads are never interrupted.
#pragma once

#include <signal.h>

#include <cstdint>

namespace ioct::rt {

class ShutdownSignals {
 public:
  // Blocks SIGINT and SIGTERM in the calling thread (threads created afterwards inherit it) and
  // opens a non-blocking signalfd for them. Throws std::system_error.
  ShutdownSignals();
  ShutdownSignals(const ShutdownSignals&) = delete;
  ShutdownSignals& operator=(const ShutdownSignals&) = delete;
  ~ShutdownSignals();

  // Readable when a signal is pending.
  int fd() const noexcept { return fd_; }
  // The pending signal's number, or 0 when none.
  int take() const noexcept;
  // Waits up to `timeout_ns` for one; its number, or 0 when none came.
  int wait_for(std::uint64_t timeout_ns) const noexcept;

 private:
  sigset_t signals_{};
  int fd_ = -1;
};

}  // namespace ioct::rt
