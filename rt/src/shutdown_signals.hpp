// SIGINT and SIGTERM, taken synchronously: they are blocked in every thread (block them before
// starting any) and the housekeeping loop waits for them with a timeout, so no handler runs in
// signal context and the real-time thread is never interrupted.
#pragma once

#include <signal.h>

#include <cstdint>

namespace ioct::rt {

class ShutdownSignals {
 public:
  // Blocks SIGINT and SIGTERM in the calling thread; threads created afterwards inherit it.
  ShutdownSignals();

  // Waits up to `timeout_ns` for one of them; returns its number, or 0 when none came.
  int wait_for(std::uint64_t timeout_ns) const noexcept;

 private:
  sigset_t signals_{};
};

}  // namespace ioct::rt
