// The acquisition's time base: sweep n of the run starts at t0 + n * sweep period on
// CLOCK_MONOTONIC. Every timestamp and deadline of a group follows from its first sweep counter,
// so lost sweeps move the times with them.
#pragma once

#include <cmath>
#include <cstdint>

#include "ioct/hal/digitizer_config.hpp"

namespace ioct::rt {

class SweepClock {
 public:
  SweepClock() = default;
  SweepClock(std::uint64_t start_ns, double sweep_period_ns) noexcept
      : start_ns_(start_ns), sweep_period_ns_(sweep_period_ns) {}

  // Start of sweep `sweep`. Exact to a nanosecond for ~100 days of sweeps (double mantissa).
  std::uint64_t sweep_start_ns(std::uint64_t sweep) const noexcept {
    return start_ns_ +
           static_cast<std::uint64_t>(std::llround(static_cast<double>(sweep) * sweep_period_ns_));
  }
  std::uint64_t start_ns() const noexcept { return start_ns_; }

 private:
  std::uint64_t start_ns_ = 0;
  double sweep_period_ns_ = 0.0;
};

struct GroupTimes {
  std::uint64_t first_sweep_ns = 0;  // start of the group's first recorded sweep
  std::uint64_t last_sweep_ns = 0;   // start of its last recorded sweep
  std::uint64_t complete_ns = 0;     // end of the last recorded sweep: the group exists from here
};

inline GroupTimes group_times(const SweepClock& clock, const hal::DigitizerConfig& geometry,
                              std::uint64_t first_sweep) noexcept {
  const std::uint64_t last_sweep = first_sweep +
                                   (geometry.bscans_per_group - 1) * geometry.sweeps_per_bscan() +
                                   (geometry.ascans_per_bscan - 1);
  return {clock.sweep_start_ns(first_sweep), clock.sweep_start_ns(last_sweep),
          clock.sweep_start_ns(last_sweep + 1)};
}

}  // namespace ioct::rt
