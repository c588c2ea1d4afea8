// When the next of a regular stream of events is due (groups come at the scan's rate), and how a
// thread that waits for it should wait: asleep until shortly before it is due, then awake and
// polling for a short window around it, so the thread is running when the event comes. Waking a
// sleeping thread takes tens of microseconds on a quiet machine but up to a millisecond on some
// hosts (deep idle states, a virtual CPU the hypervisor parked), and that wake-up would be in
// every group's latency. If the event does not come within the window, the thread sleeps until
// the next one's; when none came for kAwaitedEvents periods the stream is taken as stopped and
// the thread only sleeps, so a stopped producer costs no CPU (without that bound, a period under
// twice the window would keep it spinning for as long as the producer is stopped).
//
// Only where a GPU does the work: there a group's pass takes about a millisecond and a wake-up is
// a large part of it. Where a CPU does it, a pass takes tens to hundreds of milliseconds, a
// wake-up is lost in it, and a thread polling awake takes a core the passes need (measured on two
// cores under load: more groups dropped behind with the window than without).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

namespace ioct {

class ArrivalForecast {
 public:
  // Event number `sequence` happened at `t_ns` (CLOCK_MONOTONIC); numbers skipped were missed,
  // so an interval is divided among them. A time or number that does not move forward (a
  // producer's restart) starts the forecast afresh.
  void observe(std::uint64_t t_ns, std::uint64_t sequence) noexcept {
    if (seen_ > 0 && (t_ns <= last_ns_ || sequence <= last_sequence_)) {
      seen_ = 0;
      next_ = 0;
    }
    if (seen_ > 0) {
      intervals_[next_] = (t_ns - last_ns_) / (sequence - last_sequence_);
      next_ = (next_ + 1) % kIntervals;
    }
    last_ns_ = t_ns;
    last_sequence_ = sequence;
    if (seen_ <= kIntervals) ++seen_;
  }

  // The events' period: the shortest of the last few intervals, so the forecast errs early
  // (inside the window) rather than late; 0 until two events were seen.
  std::uint64_t period_ns() const noexcept {
    const int known = std::min(seen_ - 1, kIntervals);
    if (known <= 0) return 0;
    return *std::min_element(intervals_.begin(), intervals_.begin() + known);
  }

  // The first time the next event is due at or after `now_ns` minus `late_ns`: the last event
  // plus whole periods (events missed in between are skipped over); 0 when there is no forecast,
  // or when that is more than kAwaitedEvents periods after the last event (the stream stopped).
  std::uint64_t next_due_ns(std::uint64_t now_ns, std::uint64_t late_ns) const noexcept {
    const std::uint64_t period = period_ns();
    if (period == 0) return 0;
    std::uint64_t due = last_ns_ + period;
    if (due + late_ns < now_ns) due += ((now_ns - late_ns - due) / period + 1) * period;
    return due - last_ns_ <= kAwaitedEvents * period ? due : 0;
  }

  // Due times after the last event that are still awaited; past them the stream has stopped.
  static constexpr std::uint64_t kAwaitedEvents = 4;

 private:
  static constexpr int kIntervals = 4;
  std::array<std::uint64_t, kIntervals> intervals_{};
  int next_ = 0;
  int seen_ = 0;  // events seen, counted up to kIntervals + 1
  std::uint64_t last_ns_ = 0;
  std::uint64_t last_sequence_ = 0;
};

// How long a thread waiting for the forecast event sleeps before it looks again: 0 means "do not
// sleep, look again at once" (inside the window of `spin_ns` on each side of when the event is
// due); otherwise up to `poll_ns`, ending where the window begins. spin_ns = 0: always poll_ns.
inline std::uint64_t idle_sleep_ns(const ArrivalForecast& forecast, std::uint64_t now_ns,
                                   std::uint64_t spin_ns, std::uint64_t poll_ns) noexcept {
  if (spin_ns == 0) return poll_ns;
  const std::uint64_t due = forecast.next_due_ns(now_ns, spin_ns);
  if (due == 0) return poll_ns;
  const std::uint64_t window_start = due > spin_ns ? due - spin_ns : 0;
  if (now_ns >= window_start) return 0;  // inside the window (next_due_ns skipped past ones)
  return std::min(poll_ns, window_start - now_ns);
}

}  // namespace ioct
