#include "ioct/common/stop_signals.hpp"

#include <poll.h>
#include <pthread.h>
#include <sys/eventfd.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <system_error>
#include <utility>

namespace ioct {

StopSignals::StopSignals() {
  sigemptyset(&signals_);
  sigaddset(&signals_, SIGINT);
  sigaddset(&signals_, SIGTERM);
  const int error = ::pthread_sigmask(SIG_BLOCK, &signals_, nullptr);
  if (error != 0) throw std::system_error(error, std::generic_category(), "pthread_sigmask");
  fd_ = ::signalfd(-1, &signals_, SFD_NONBLOCK | SFD_CLOEXEC);
  if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "signalfd");
}

StopSignals::~StopSignals() {
  if (fd_ >= 0) ::close(fd_);
}

int StopSignals::take() const noexcept {
  signalfd_siginfo info{};
  const ssize_t got = ::read(fd_, &info, sizeof(info));
  return got == static_cast<ssize_t>(sizeof(info)) ? static_cast<int>(info.ssi_signo) : 0;
}

int StopSignals::wait_for(std::uint64_t timeout_ns) const noexcept {
  pollfd p{fd_, POLLIN, 0};
  ::poll(&p, 1, static_cast<int>(timeout_ns / 1'000'000u));
  return take();
}

StopWatcher::StopWatcher(const StopSignals& signals, std::function<void(int)> on_stop)
    : on_stop_(std::move(on_stop)), wake_fd_(::eventfd(0, EFD_CLOEXEC)) {
  if (wake_fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
  try {
    thread_ = std::thread([this, &signals] { watch(signals); });
  } catch (...) {
    ::close(wake_fd_);
    throw;
  }
}

void StopWatcher::end_by(int signal) {
  ::signal(signal, SIG_DFL);
  sigset_t only{};
  sigemptyset(&only);
  sigaddset(&only, signal);
  ::pthread_sigmask(SIG_UNBLOCK, &only, nullptr);
  ::raise(signal);
  std::_Exit(128 + signal);  // not reached: the default action of SIGINT and SIGTERM ends us
}

StopWatcher::~StopWatcher() {
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
  thread_.join();
  ::close(wake_fd_);
}

void StopWatcher::watch(const StopSignals& signals) const {
  bool asked = false;
  for (;;) {
    pollfd fds[2] = {{signals.fd(), POLLIN, 0}, {wake_fd_, POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if ((fds[1].revents & POLLIN) != 0) return;
    const int signal = signals.take();
    if (signal == 0) continue;
    if (asked) end_by(signal);  // the second
    asked = true;
    on_stop_(signal);
  }
}

}  // namespace ioct
