#include "shared_futex.hpp"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <climits>

#include "ioct/shm/atomic_word.hpp"

namespace ioct::shm {

void shared_futex_wait(const std::uint32_t& word, std::uint32_t expected,
                       std::uint64_t timeout_ns) noexcept {
  const timespec timeout{static_cast<time_t>(timeout_ns / 1'000'000'000u),
                         static_cast<long>(timeout_ns % 1'000'000'000u)};
  // FUTEX_WAIT without FUTEX_PRIVATE_FLAG: keyed on the shared page, so another process wakes it.
  // EAGAIN (the word moved), ETIMEDOUT and EINTR all mean "look again".
  ::syscall(SYS_futex, &word, FUTEX_WAIT, expected, &timeout, nullptr, 0);
}

void shared_futex_bump_and_wake(std::uint32_t& word) noexcept {
  std::atomic_ref<std::uint32_t>(word).fetch_add(1,
                                                 std::memory_order_release);  // see atomic_word.hpp
  ::syscall(SYS_futex, &word, FUTEX_WAKE, INT_MAX, nullptr, nullptr, 0);
}

}  // namespace ioct::shm
