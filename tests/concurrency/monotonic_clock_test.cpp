// monotonic_ns() is CLOCK_MONOTONIC (the clock of std::chrono::steady_clock on Linux, and of
// every timestamp in the ring) and never goes back.
#include "ioct/concurrency/monotonic_clock.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>

namespace ioct {
namespace {

std::uint64_t steady_ns() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::steady_clock::now().time_since_epoch())
                                        .count());
}

TEST(MonotonicClock, ReadsTheSteadyClockAndNeverGoesBack) {
  std::uint64_t last = monotonic_ns();
  for (int i = 0; i < 10'000; ++i) {
    const std::uint64_t before = steady_ns();
    const std::uint64_t now = monotonic_ns();
    const std::uint64_t after = steady_ns();
    ASSERT_LE(before, now);
    ASSERT_LE(now, after);
    ASSERT_LE(last, now);
    last = now;
  }
}

TEST(MonotonicClock, OtherClocksAndAnUnreadableOne) {
  EXPECT_GT(clock_ns(CLOCK_REALTIME), std::uint64_t{1'600'000'000} * 1'000'000'000u)
      << "after 2020";
  EXPECT_GT(clock_ns(CLOCK_PROCESS_CPUTIME_ID), 0u);
  EXPECT_EQ(clock_ns(static_cast<clockid_t>(-1000)), 0u) << "an invalid clock reads as 0";
}

}  // namespace
}  // namespace ioct
