#include "ioct/sim/simulated_bench.hpp"

#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::sim {
void BenchConfig::validate() const {
  if (mirrors.natural_hz != 0.0) {  // 0: ideal mirrors
    ioct::require_real_in_range("bench.mirrors.natural_hz", mirrors.natural_hz, 10.0, 100'000.0);
  }
  ioct::require_real_in_range("bench.mirrors.damping", mirrors.damping, 0.05, 5.0);
  ioct::require_integer_in_range("bench.watchdog_timeout_ms", watchdog_timeout_ms, 0, 60'000);
  ioct::require_integer_in_range("bench.digitizer_buffer_sweeps", digitizer_buffer_sweeps, 0,
                                 1u << 28);
}

SimulatedBench::SimulatedBench(const BenchConfig& config) : config_(config), scanner_(faults_) {
  config_.validate();
  scanner_.set_dynamics(config_.mirrors, 100'000.0);
}

void SimulatedBench::command_emission(bool on) noexcept {
  emission_.store(on, std::memory_order_release);
}

void SimulatedBench::heartbeat() noexcept {
  last_heartbeat_ns_.store(ioct::monotonic_ns(), std::memory_order_release);
}

bool SimulatedBench::emission_on() const noexcept {
  if (!emission_.load(std::memory_order_acquire)) return false;
  if (faults_.active(Fault::laser_not_ready)) return false;
  if (config_.watchdog_timeout_ms == 0) return true;
  const std::uint64_t last = last_heartbeat_ns_.load(std::memory_order_acquire);
  return last != 0 &&
         ioct::monotonic_ns() - last <= std::uint64_t{config_.watchdog_timeout_ms} * 1'000'000ull;
}

void SimulatedBench::set_footswitch(bool pressed) noexcept {
  if (footswitch_.exchange(pressed, std::memory_order_acq_rel) != pressed) {
    footswitch_changed_ns_.store(ioct::monotonic_ns(), std::memory_order_release);
  }
}

hal::LineInputs SimulatedBench::inputs() const noexcept {
  const std::uint32_t mask = faults_.active_mask();
  const auto off = [mask](Fault fault) { return (mask & FaultInjector::bit(fault)) != 0; };
  hal::LineInputs inputs;
  inputs.laser_ready = !off(Fault::laser_not_ready);
  inputs.sweep_trigger_present = !off(Fault::trigger_loss);
  inputs.k_clock_valid = !off(Fault::k_clock_dropout);
  inputs.footswitch = footswitch_.load(std::memory_order_acquire);
  return inputs;
}

bool SimulatedBench::light_on_sample() const noexcept {
  if (faults_.active(Fault::laser_not_ready)) return false;
  return !lines_attached() || emission_on();
}

}  // namespace ioct::sim
