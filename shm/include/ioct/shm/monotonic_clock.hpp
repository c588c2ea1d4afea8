// CLOCK_MONOTONIC in nanoseconds: the time base of every timestamp in the ring. Served by the
// vDSO, so it costs no system call on the publishing path.
#pragma once

#include <time.h>

#include <cstdint>

namespace ioct::shm {

inline std::uint64_t monotonic_ns() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u +
         static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace ioct::shm
