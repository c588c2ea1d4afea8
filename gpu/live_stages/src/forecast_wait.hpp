// How the stages' thread and the frame publisher's encoding thread wait for their next piece of
// work (a group's hand-over, a frame): asleep on their condition variable, except within the spin
// window around when the forecast says it is due, where they watch a counter of arrivals awake,
// so the work starts when it comes instead of when a sleeping thread is woken
// (concurrency/arrival_forecast.hpp says why).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>

#include "ioct/concurrency/arrival_forecast.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/concurrency/spin_pause.hpp"

namespace ioct::gpu::live {

// One wait, with `lock` held on entry and on return: until `wake` is notified, `limit_ns` passed
// (UINT64_MAX: no limit), or, inside the window, `arrivals` changed or a slice of 50 us passed
// (the lock is released meanwhile). The caller checks its condition again after each.
inline void wait_for_next(std::unique_lock<std::mutex>& lock, std::condition_variable& wake,
                          const ArrivalForecast& forecast,
                          const std::atomic<std::uint64_t>& arrivals, std::uint64_t spin_ns,
                          std::uint64_t limit_ns) {
  const std::uint64_t now = ioct::monotonic_ns();
  const std::uint64_t sleep = idle_sleep_ns(forecast, now, spin_ns, limit_ns);
  if (sleep == 0) {
    constexpr std::uint64_t kSlice = 50'000;
    const std::uint64_t seen = arrivals.load(std::memory_order_relaxed);
    lock.unlock();
    while (arrivals.load(std::memory_order_acquire) == seen &&
           ioct::monotonic_ns() < now + kSlice) {
      spin_pause();
    }
    lock.lock();
  } else if (sleep == UINT64_MAX) {
    wake.wait(lock);
  } else {
    wake.wait_for(lock, std::chrono::nanoseconds(sleep));
  }
}

}  // namespace ioct::gpu::live
