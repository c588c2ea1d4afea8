// A word one thread bumps when something happened and another sleeps on until it changes or a
// CLOCK_MONOTONIC deadline passes: a futex, so neither side locks or allocates.
#pragma once

#include <atomic>
#include <cstdint>

#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::hal::usb::detail {

class ProgressSignal {
 public:
  std::uint32_t value() const noexcept { return value_.load(std::memory_order_seq_cst); }
  // Bumps the word and wakes a sleeper (a syscall only when one sleeps).
  void notify() noexcept;
  // Sleeps while the word still equals `seen`, at most until `deadline_ns` (CLOCK_MONOTONIC).
  // False when the deadline passed.
  bool wait(std::uint32_t seen, std::uint64_t deadline_ns) noexcept;

 private:
  std::atomic<std::uint32_t> value_{0};
  std::atomic<std::uint32_t> sleepers_{0};
};

}  // namespace ioct::hal::usb::detail
