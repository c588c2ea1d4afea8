// The simulated lines: hal::Lines over the bench's laser state.
//
//   - laser emission: set_laser_emission() drives the enable line; laser_emission() reads back
//     what reaches the laser, which the external watchdog cuts when the heartbeat stops
//     (BenchConfig::watchdog_timeout_ms) and a laser that is not ready ignores;
//   - inputs: laser_ready, sweep_trigger_present and k_clock_valid follow the injected faults
//     (laser_not_ready, trigger_loss, k_clock_dropout); the footswitch follows
//     SimulatedBench::set_footswitch();
//   - wait_event() reports input changes as edges, timestamped when the change was made
//     (CLOCK_MONOTONIC), by polling every millisecond. Changes faster than that may be merged.
// While lines are prepared on a bench, the simulated digitizer draws the sample only while
// emission is on.
#pragma once

#include <memory>

#include "ioct/hal/lines.hpp"
#include "ioct/sim/simulated_bench.hpp"

namespace ioct::sim {

class SimulatedLines final : public hal::Lines {
 public:
  explicit SimulatedLines(std::shared_ptr<SimulatedBench> bench);
  ~SimulatedLines() override;

  void prepare(const hal::LinesConfig& config) override;
  void release() noexcept override;
  void set_laser_emission(bool on) noexcept override;
  bool laser_emission() const noexcept override;
  hal::LineInputs read_inputs() noexcept override;
  void toggle_watchdog() noexcept override;
  // Throws std::logic_error before prepare(). For one (housekeeping) thread.
  std::optional<hal::LineEvent> wait_event(std::chrono::nanoseconds timeout) override;
  std::string_view backend() const noexcept override { return "simulated"; }

  SimulatedBench& bench() const noexcept { return *bench_; }

 private:
  std::shared_ptr<SimulatedBench> bench_;
  bool prepared_ = false;
  hal::LineInputs reported_;  // the levels wait_event() has reported so far
};

}  // namespace ioct::sim
