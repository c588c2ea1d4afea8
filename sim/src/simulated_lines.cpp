#include "ioct/sim/simulated_lines.hpp"

#include <stdexcept>
#include <thread>

#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::sim {
SimulatedLines::SimulatedLines(std::shared_ptr<SimulatedBench> bench) : bench_(std::move(bench)) {
  if (!bench_) throw std::invalid_argument("simulated lines: no bench");
}

SimulatedLines::~SimulatedLines() {
  release();
}

void SimulatedLines::prepare(const hal::LinesConfig& config) {
  config.validate();
  bench_->command_emission(false);  // outputs start inactive
  bench_->attach_lines(true);
  reported_ = bench_->inputs();
  prepared_ = true;
}

void SimulatedLines::release() noexcept {
  if (!prepared_) return;
  // A released enable line is not driven: the laser stays off.
  bench_->command_emission(false);
  prepared_ = false;
}

void SimulatedLines::set_laser_emission(bool on) noexcept {
  if (prepared_) bench_->command_emission(on);
}

bool SimulatedLines::laser_emission() const noexcept {
  return bench_->emission_on();
}

hal::LineInputs SimulatedLines::read_inputs() noexcept {
  return bench_->inputs();
}

void SimulatedLines::toggle_watchdog() noexcept {
  if (prepared_) bench_->heartbeat();
}

std::optional<hal::LineEvent> SimulatedLines::wait_event(std::chrono::nanoseconds timeout) {
  if (!prepared_) throw std::logic_error("simulated lines: wait_event() before prepare()");
  const std::uint64_t deadline =
      ioct::monotonic_ns() + static_cast<std::uint64_t>(std::max<std::int64_t>(0, timeout.count()));
  const FaultInjector& faults = bench_->faults();
  for (;;) {
    const hal::LineInputs now = bench_->inputs();
    const auto edge = [&](hal::InputLine line, bool& reported, bool level,
                          std::uint64_t changed_ns) -> std::optional<hal::LineEvent> {
      if (reported == level) return std::nullopt;
      reported = level;
      return hal::LineEvent{line, level, changed_ns != 0 ? changed_ns : ioct::monotonic_ns()};
    };
    if (auto e = edge(hal::InputLine::laser_ready, reported_.laser_ready, now.laser_ready,
                      faults.changed_ns(Fault::laser_not_ready))) {
      return e;
    }
    if (auto e = edge(hal::InputLine::sweep_trigger_present, reported_.sweep_trigger_present,
                      now.sweep_trigger_present, faults.changed_ns(Fault::trigger_loss))) {
      return e;
    }
    if (auto e = edge(hal::InputLine::k_clock_valid, reported_.k_clock_valid, now.k_clock_valid,
                      faults.changed_ns(Fault::k_clock_dropout))) {
      return e;
    }
    if (auto e = edge(hal::InputLine::footswitch, reported_.footswitch, now.footswitch,
                      bench_->footswitch_changed_ns())) {
      return e;
    }
    if (ioct::monotonic_ns() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace ioct::sim
