// The acquisition thread: per group it claims a ring slot, has the digitizer fill the slot's
// payload in place, describes the group in the slot header, waits for the moment the group's
// last sweep ends (an absolute CLOCK_MONOTONIC deadline) and publishes.
//
// After start() the thread neither allocates, locks nor logs: what it has to say goes out
// through atomic counters that the housekeeping side reads.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "ioct/hal/digitizer.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "realtime_setup.hpp"
#include "slot_description.hpp"
#include "sweep_clock.hpp"

namespace ioct::rt {

struct LoopCounters {
  std::uint64_t groups_generated = 0;
  std::uint64_t groups_published = 0;
  std::uint64_t deadline_misses = 0;      // groups generated after their last sweep had ended
  std::uint64_t worst_lateness_ns = 0;    // the furthest past its deadline a group was generated
  std::uint64_t generation_ns_total = 0;  // time acquire_group() took, summed over the groups
  std::uint64_t generation_ns_max = 0;
  std::uint64_t missed_sweeps = 0;  // reported by the digitizer
};

class AcquisitionLoop {
 public:
  struct Settings {
    ScanContext context;
    RealtimeRequest realtime;
    std::size_t stack_prefault_bytes = 256 * 1024;
  };

  // `ring` and `digitizer` (prepared with settings.context.geometry) must outlive the loop.
  AcquisitionLoop(shm::RingWriter& ring, hal::Digitizer& digitizer, Settings settings);
  AcquisitionLoop(const AcquisitionLoop&) = delete;
  AcquisitionLoop& operator=(const AcquisitionLoop&) = delete;
  ~AcquisitionLoop();

  // Locks memory when asked, starts the thread, which makes itself real-time, prefaults its
  // stack and starts the digitizer; returns once it runs, with what the real-time setup got.
  // Throws what digitizer.start() throws, and std::logic_error when called twice.
  RealtimeOutcome start();
  // Stops the thread (within one sleep slice), joins it and stops the digitizer. A group not
  // yet published when the stop comes is dropped. Idempotent.
  void stop() noexcept;

  LoopCounters counters() const noexcept;
  // The thread ended on its own because of an error (then see failure()).
  bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }
  std::string failure() const;
  // Sweep 0 started at clock().start_ns(); valid after start().
  SweepClock clock() const noexcept { return clock_; }

 private:
  void run() noexcept;
  void acquire_groups();
  // Sleeps until `deadline_ns` in slices, so a stop request is seen; false when one came.
  bool sleep_until(std::uint64_t deadline_ns) const noexcept;

  shm::RingWriter& ring_;
  hal::Digitizer& digitizer_;
  Settings settings_;
  SweepClock clock_;
  std::thread thread_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> failed_{false};
  std::string failure_;  // written by the thread before failed_ (release)

  struct AtomicCounters {
    std::atomic<std::uint64_t> groups_generated{0};
    std::atomic<std::uint64_t> groups_published{0};
    std::atomic<std::uint64_t> deadline_misses{0};
    std::atomic<std::uint64_t> worst_lateness_ns{0};
    std::atomic<std::uint64_t> generation_ns_total{0};
    std::atomic<std::uint64_t> generation_ns_max{0};
    std::atomic<std::uint64_t> missed_sweeps{0};
  };
  AtomicCounters counters_;
};

}  // namespace ioct::rt
