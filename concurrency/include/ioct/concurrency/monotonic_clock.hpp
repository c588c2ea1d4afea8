// CLOCK_MONOTONIC in nanoseconds: the time base of every timestamp in the ring, the deadlines of
// the acquisition thread and the latencies in the histograms. Served by the vDSO, so reading it
// is no system call and the real-time thread may read it.
#pragma once

#include <time.h>

#include <cstdint>

namespace ioct {

// Any POSIX clock in nanoseconds (CLOCK_REALTIME, CLOCK_PROCESS_CPUTIME_ID...); 0 if the clock
// cannot be read.
inline std::uint64_t clock_ns(clockid_t clock) noexcept {
  timespec ts{};
  if (::clock_gettime(clock, &ts) != 0) return 0;
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u +
         static_cast<std::uint64_t>(ts.tv_nsec);
}

inline std::uint64_t monotonic_ns() noexcept {
  return clock_ns(CLOCK_MONOTONIC);
}

// A duration in seconds (a configuration's) on that time base; 0 for negative ones.
inline std::uint64_t seconds_to_ns(double seconds) noexcept {
  return seconds > 0.0 ? static_cast<std::uint64_t>(seconds * 1e9) : 0;
}

}  // namespace ioct
