// A 32-bit word in shared memory that a writer bumps and readers sleep on: the kernel's futex,
// not a process-private one, since writer and readers are different processes. Waiting only reads
// the word, so a reader with a read-only mapping can wait; waking is the writer's syscall only.
#pragma once

#include <cstdint>

namespace ioct::shm {

// Sleeps while `word` still holds `expected`, at most `timeout_ns`; returns at once when it does
// not. Also returns on a wake, a signal or a spurious wake-up: the caller looks again.
void shared_futex_wait(const std::uint32_t& word, std::uint32_t expected,
                       std::uint64_t timeout_ns) noexcept;

// Bumps `word` (release) and wakes every process sleeping on it.
void shared_futex_bump_and_wake(std::uint32_t& word) noexcept;

}  // namespace ioct::shm
