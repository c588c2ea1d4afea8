#include "safety_supervisor.hpp"

#include <future>
#include <stdexcept>

#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::rt {

SafetySupervisor::SafetySupervisor(hal::Lines& lines, AcquisitionLoop& loop,
                                   SupervisorSettings settings)
    : lines_(lines), loop_(loop), settings_(settings), machine_(settings.policy) {}

SafetySupervisor::~SafetySupervisor() {
  stop();
}

RealtimeOutcome SafetySupervisor::start() {
  if (thread_.joinable()) throw std::logic_error("safety supervisor: start() twice");
  std::promise<RealtimeOutcome> ready;
  std::future<RealtimeOutcome> started = ready.get_future();
  heartbeat_ns_.store(ioct::monotonic_ns(), std::memory_order_relaxed);
  thread_ = std::thread([this, ready = std::move(ready)]() mutable {
    RealtimeOutcome outcome;
    make_current_thread_realtime(settings_.realtime, outcome);
    prefault_stack(64 * 1024);
    ready.set_value(outcome);
    run();
  });
  return started.get();
}

void SafetySupervisor::stop() noexcept {
  quit_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
}

std::uint64_t SafetySupervisor::request_start() noexcept {
  return start_requests_.fetch_add(1, std::memory_order_acq_rel) + 1;
}

std::uint64_t SafetySupervisor::request_stop() noexcept {
  return stop_requests_.fetch_add(1, std::memory_order_acq_rel) + 1;
}

SafetyStatus SafetySupervisor::status() const {
  const std::lock_guard lock(status_mutex_);
  return published_;
}

void SafetySupervisor::run() noexcept {
  // Emission off before anything else, whatever the line held.
  lines_.set_laser_emission(false);
  while (!quit_.load(std::memory_order_relaxed)) {
    // Wakes early on an input edge, so a dropped k-clock or trigger is seen at once.
    try {
      if (lines_.wait_event(std::chrono::nanoseconds(settings_.poll_interval_ns))) {
        ++working_.input_edges;
      }
    } catch (...) {
      // A backend that cannot wait: the poll below still runs, at the latest one interval on.
    }
    poll_once();
  }
  lines_.set_laser_emission(false);
  loop_.set_emission_on(false);
  loop_.command_park();
}

void SafetySupervisor::poll_once() noexcept {
  // The operator's requests first, the lines after: a re-arm sent just after its cause cleared
  // is then judged on lines read after it was made, never on a read that came before it.
  const std::uint64_t starts = start_requests_.load(std::memory_order_acquire);
  const std::uint64_t stops = stop_requests_.load(std::memory_order_acquire);
  SafetyInputs in;
  in.now_ns = ioct::monotonic_ns();
  in.lines = lines_.read_inputs();
  in.emission_readback = lines_.laser_emission();
  const LoopReport loop = loop_.report();
  in.acquisition_streaming = loop.streaming;
  // Faults and verification count only for the run command standing now (and, while a fault is
  // being handled, the one just withdrawn): a re-arm must not see the last cycle's faults.
  const SafetyState now_state = machine_.state();
  const bool handling = now_state == SafetyState::fault || now_state == SafetyState::stopping;
  if (last_cycle_ != 0 && loop.serving_cycle == last_cycle_ && (running_ || handling)) {
    in.acquisition_faults = loop.faults;
    in.acquisition_verified = running_ && loop.verified;
  }
  in.acquisition_heartbeat_ns = loop.heartbeat_ns;
  const std::uint64_t first_start = start_seen_ + 1;  // the first request this poll answers
  in.start_requested = starts != start_seen_;
  in.stop_requested = stops != stop_seen_;
  start_seen_ = starts;
  stop_seen_ = stops;

  const SafetyState before = machine_.state();
  const SafetyOutputs out = machine_.step(in);

  // 1. Emission. Off is driven on every poll, so nothing else can hold it on.
  if (out.emission != emission_commanded_ || !out.emission) {
    lines_.set_laser_emission(out.emission);
    emission_commanded_ = out.emission;
  }
  loop_.set_emission_on(machine_.state() == SafetyState::scanning);
  // 2. The acquisition thread: run (a new numbered command) or park.
  if (out.loop == LoopCommand::run && !running_) {
    loop_.command_run(++last_cycle_);
    running_ = true;
  } else if (out.loop == LoopCommand::park && running_) {
    loop_.command_park();
    running_ = false;
  }
  // 3. The external watchdog is fed only while emission is known to be under control.
  if (out.feed_watchdog && in.now_ns - last_toggle_ns_ >= settings_.watchdog_toggle_interval_ns) {
    lines_.toggle_watchdog();
    last_toggle_ns_ = in.now_ns;
    ++working_.watchdog_toggles;
  }

  const SafetyState after = machine_.state();
  if (after != before) {
    // A full queue (housekeeping stalled) loses the log line, never blocks the thread; the
    // state itself is in the status.
    static_cast<void>(transitions_.push({in.now_ns, before, after, machine_.record().faults}));
  }
  working_.state = after;
  working_.record = machine_.record();
  working_.inputs = in.lines;
  footswitch_.observe(in.lines.footswitch, in.now_ns);
  working_.footswitch_presses = footswitch_.presses();
  working_.emission_commanded = emission_commanded_;
  working_.emission_readback = in.emission_readback;
  ++working_.polls;
  working_.start_requests_handled = starts;
  working_.stop_requests_handled = stops;
  if (in.start_requested) {
    working_.last_refusal = machine_.refusal();
    working_.last_refusal_first_request = first_start;
    working_.last_refusal_request = starts;
  }
  heartbeat_ns_.store(in.now_ns, std::memory_order_relaxed);
  if (status_mutex_.try_lock()) {
    published_ = working_;
    status_mutex_.unlock();
  }
}

}  // namespace ioct::rt
