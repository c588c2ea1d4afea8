#include "signal_verdict.hpp"

#include <algorithm>
#include <cmath>

namespace ioct::view {

std::string_view to_string(Signal signal) noexcept {
  switch (signal) {
    case Signal::live:
      return "live";
    case Signal::stale:
      return "stale";
    case Signal::no_signal:
      return "no_signal";
  }
  return "no_signal";
}

namespace {

std::uint64_t to_ns(double seconds) {
  return static_cast<std::uint64_t>(std::llround(seconds * 1e9));
}

}  // namespace

SignalVerdict judge_signal(const SignalInputs& in, const StalePolicy& policy) {
  SignalVerdict v;
  const double period_s = in.status.group_period_ns > 0
                              ? static_cast<double>(in.status.group_period_ns) * 1e-9
                              : policy.unknown_period_s;
  v.bound_ns = to_ns(policy.stale_after_s > 0.0 ? policy.stale_after_s
                                                : policy.stale_after_periods * period_s);
  if (in.status.last_group_published_ns != 0 && in.now_ns > in.status.last_group_published_ns) {
    v.age_ns = in.now_ns - in.status.last_group_published_ns;
  }
  if (!in.attached) {
    v.reason = "no frames from ioct-gpu";
    return v;
  }
  if (!in.health.alive) {
    v.reason = "ioct-gpu is not running";
    return v;
  }
  if (in.health.heartbeat_age_ns > to_ns(policy.writer_silent_s)) {
    v.reason = "ioct-gpu is not responding";
    return v;
  }
  switch (static_cast<shm::SourceState>(in.status.source_state)) {
    case shm::SourceState::live:
      break;
    case shm::SourceState::producer_gone:
      v.reason = "ioct-rt stopped: the acquisition is gone";
      return v;
    case shm::SourceState::waiting:
    default:
      v.reason = "waiting for ioct-rt";
      return v;
  }
  if (in.status.last_group_published_ns == 0) {
    v.reason = "no group acquired yet";
    return v;
  }
  if (v.age_ns > v.bound_ns) {
    v.signal = Signal::stale;
    v.reason = "no new group for " + std::to_string(v.age_ns / 1'000'000) + " ms";
    return v;
  }
  v.signal = Signal::live;
  return v;
}

}  // namespace ioct::view
