#include "shutdown_signals.hpp"

#include <pthread.h>

#include <cerrno>
#include <system_error>

namespace ioct::rt {

ShutdownSignals::ShutdownSignals() {
  sigemptyset(&signals_);
  sigaddset(&signals_, SIGINT);
  sigaddset(&signals_, SIGTERM);
  const int error = ::pthread_sigmask(SIG_BLOCK, &signals_, nullptr);
  if (error != 0) throw std::system_error(error, std::generic_category(), "pthread_sigmask");
}

int ShutdownSignals::wait_for(std::uint64_t timeout_ns) const noexcept {
  const timespec timeout{static_cast<time_t>(timeout_ns / 1'000'000'000u),
                         static_cast<long>(timeout_ns % 1'000'000'000u)};
  const int signal_number = ::sigtimedwait(&signals_, nullptr, &timeout);
  return signal_number > 0 ? signal_number : 0;  // -1: EAGAIN (timeout) or EINTR
}

}  // namespace ioct::rt
