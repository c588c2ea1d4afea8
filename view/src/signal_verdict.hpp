// Whether what the page shows is live: the one decision behind the STALE / NO SIGNAL banner.
// Pure, so every case is tested without processes.
//
//   no_signal  no frame ring, its writer is dead or silent, or ioct-gpu has no producer
//   stale      the newest group is older than the bound (default: three measured group periods)
//   live       otherwise
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "ioct/shm/frame_ring.hpp"

namespace ioct::view {

enum class Signal { live, stale, no_signal };
std::string_view to_string(Signal signal) noexcept;

struct SignalInputs {
  bool attached = false;  // the frame ring is mapped
  shm::FrameWriterHealth health;
  shm::FrameRingStatus status{};
  std::uint64_t now_ns = 0;  // CLOCK_MONOTONIC
};

struct StalePolicy {
  double stale_after_s = 0.0;        // fixed bound; 0: from the group period
  double stale_after_periods = 3.0;  // bound = periods x the measured group period
  double unknown_period_s = 1.0;     // the period assumed before one is measured
  double writer_silent_s = 1.0;      // a heartbeat older than this: the writer is gone
};

struct SignalVerdict {
  Signal signal = Signal::no_signal;
  std::uint64_t age_ns = 0;    // of the newest group; 0 when there is none
  std::uint64_t bound_ns = 0;  // the stale bound applied
  std::string reason;          // for the page and the log: why it is not live
};

SignalVerdict judge_signal(const SignalInputs& in, const StalePolicy& policy);

}  // namespace ioct::view
