#include "progress_signal.hpp"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <climits>

namespace ioct::hal::usb::detail {

void ProgressSignal::notify() noexcept {
  value_.fetch_add(1, std::memory_order_seq_cst);
  if (sleepers_.load(std::memory_order_seq_cst) != 0) {
    syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&value_), FUTEX_WAKE_PRIVATE, INT_MAX,
            nullptr, nullptr, 0);
  }
}

bool ProgressSignal::wait(std::uint32_t seen, std::uint64_t deadline_ns) noexcept {
  static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t));
  sleepers_.fetch_add(1, std::memory_order_seq_cst);
  bool in_time = true;
  while (value_.load(std::memory_order_seq_cst) == seen) {
    if (monotonic_ns() >= deadline_ns) {
      in_time = false;
      break;
    }
    const timespec deadline{static_cast<time_t>(deadline_ns / 1'000'000'000u),
                            static_cast<long>(deadline_ns % 1'000'000'000u)};
    // FUTEX_WAIT_BITSET takes an absolute CLOCK_MONOTONIC deadline.
    syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&value_),
            FUTEX_WAIT_BITSET | FUTEX_PRIVATE_FLAG, seen, &deadline, nullptr,
            FUTEX_BITSET_MATCH_ANY);
  }
  sleepers_.fetch_sub(1, std::memory_order_seq_cst);
  return in_time;
}

}  // namespace ioct::hal::usb::detail
