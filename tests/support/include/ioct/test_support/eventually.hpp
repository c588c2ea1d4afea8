// Waiting in a test for something another thread or process does: `done` polled every 200 us
// until it holds (true) or `timeout` passes (false).
#pragma once

#include <chrono>
#include <thread>

namespace ioct::test_support {

template <typename Predicate>
bool eventually(Predicate done, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

}  // namespace ioct::test_support
