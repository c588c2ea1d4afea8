// The safety thread: the only user of the lines (laser emission, watchdog heartbeat, inputs). It
// polls the inputs (waking early on an edge), reads what the acquisition thread reports, runs the
// safety state machine, and applies its outputs in a fixed order: emission first, then the run
// or park command to the acquisition thread, then the watchdog heartbeat. It runs at a higher
// SCHED_FIFO priority than the acquisition thread, so a fault drops emission within one poll
// interval whatever the acquisition thread is doing.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string_view>
#include <thread>

#include "acquisition_loop.hpp"
#include "footswitch_presses.hpp"
#include "ioct/concurrency/spsc_queue.hpp"
#include "ioct/hal/lines.hpp"
#include "realtime_setup.hpp"
#include "safety_state_machine.hpp"

namespace ioct::rt {

struct SupervisorSettings {
  SafetyPolicy policy;
  std::uint64_t poll_interval_ns = 1'000'000;
  std::uint64_t watchdog_toggle_interval_ns = 5'000'000;
  RealtimeRequest realtime{.fifo_priority = 85, .cpu = -1, .lock_memory = false};
};

struct SafetyStatus {
  SafetyState state = SafetyState::idle;
  SafetyRecord record;
  hal::LineInputs inputs;
  bool emission_commanded = false;
  bool emission_readback = false;
  std::uint64_t polls = 0;
  std::uint64_t watchdog_toggles = 0;
  std::uint64_t input_edges = 0;
  std::uint64_t footswitch_presses = 0;  // FootswitchPresses, since start
  std::uint64_t start_requests_handled = 0;
  std::uint64_t stop_requests_handled = 0;
  std::string_view last_refusal;  // static text; empty when the last start was not refused
  // The start requests it answered: several that came within one poll get one answer.
  std::uint64_t last_refusal_first_request = 0;
  std::uint64_t last_refusal_request = 0;
};

struct SafetyTransition {
  std::uint64_t time_ns = 0;
  SafetyState from = SafetyState::idle;
  SafetyState to = SafetyState::idle;
  std::uint32_t faults = 0;
};

class SafetySupervisor {
 public:
  // `lines` (prepared) and `loop` (started) must outlive the supervisor.
  SafetySupervisor(hal::Lines& lines, AcquisitionLoop& loop, SupervisorSettings settings);
  SafetySupervisor(const SafetySupervisor&) = delete;
  SafetySupervisor& operator=(const SafetySupervisor&) = delete;
  ~SafetySupervisor();

  // Starts the thread; returns what its real-time setup got.
  RealtimeOutcome start();
  // Ends the thread after driving emission off and commanding the park. Idempotent.
  void stop() noexcept;

  // From the housekeeping thread (control channel, signals). Each returns the request's number;
  // status().start_requests_handled reaching it means the machine has seen it.
  std::uint64_t request_start() noexcept;
  std::uint64_t request_stop() noexcept;

  SafetyStatus status() const;
  std::optional<SafetyTransition> take_transition() noexcept { return transitions_.pop(); }
  // CLOCK_MONOTONIC of the thread's last poll: the process is alive when this is fresh.
  std::uint64_t heartbeat_ns() const noexcept {
    return heartbeat_ns_.load(std::memory_order_relaxed);
  }
  const SupervisorSettings& settings() const noexcept { return settings_; }

 private:
  void run() noexcept;
  void poll_once() noexcept;

  hal::Lines& lines_;
  AcquisitionLoop& loop_;
  SupervisorSettings settings_;
  SafetyStateMachine machine_;
  std::thread thread_;
  std::atomic<bool> quit_{false};
  std::atomic<std::uint64_t> start_requests_{0};
  std::atomic<std::uint64_t> stop_requests_{0};
  std::atomic<std::uint64_t> heartbeat_ns_{0};
  SpscQueue<SafetyTransition> transitions_{64};

  // The thread's own state.
  std::uint64_t start_seen_ = 0;
  std::uint64_t stop_seen_ = 0;
  std::uint64_t last_cycle_ = 0;  // number of the latest run command
  bool running_ = false;          // a run command is standing
  bool emission_commanded_ = false;
  std::uint64_t last_toggle_ns_ = 0;
  SafetyStatus working_;
  FootswitchPresses footswitch_;

  // The status the housekeeping side reads: copied under a mutex the safety thread only ever
  // try-locks (it skips a copy rather than wait).
  mutable std::mutex status_mutex_;
  SafetyStatus published_;
};

}  // namespace ioct::rt
