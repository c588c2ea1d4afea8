// The simulated bench: the one piece of simulated hardware that the simulated digitizer, galvo
// output and lines share, so that what one does shows in the others, as on a real bench:
//   - the scanner (galvo FIFO and mirrors): the galvo output feeds it, the digitizer clocks it
//     and records the sample where the mirrors actually point;
//   - the laser's lines: emission enable (read back through the external watchdog), laser
//     ready, sweep trigger and k-clock present, the footswitch;
//   - the fault injector, switched from any thread.
// Make one with std::make_shared and hand it to each simulated backend. A digitizer made without
// one makes its own, with no galvo output (the beam then follows the raster exactly) and no
// lines (emission is taken as on).
#pragma once

#include <atomic>
#include <cstdint>

#include "ioct/hal/lines.hpp"
#include "ioct/sim/fault_injector.hpp"
#include "ioct/sim/simulated_scanner.hpp"

namespace ioct::sim {

struct BenchConfig {
  MirrorDynamics mirrors;
  // The external watchdog cuts emission when the heartbeat line has not toggled for this long
  // (0: no watchdog in the emission path).
  std::uint32_t watchdog_timeout_ms = 100;
  // The digitizer's on-board memory, in sweeps: how far the host may fall behind before records
  // are lost (slow_consumer).
  std::uint32_t digitizer_buffer_sweeps = 32'768;

  // Throws ioct::ConfigError ("bench.<key>").
  void validate() const;
};

class SimulatedBench {
 public:
  explicit SimulatedBench(const BenchConfig& config = {});
  SimulatedBench(const SimulatedBench&) = delete;
  SimulatedBench& operator=(const SimulatedBench&) = delete;

  const BenchConfig& config() const noexcept { return config_; }
  FaultInjector& faults() noexcept { return faults_; }
  const FaultInjector& faults() const noexcept { return faults_; }
  SimulatedScanner& scanner() noexcept { return scanner_; }
  const SimulatedScanner& scanner() const noexcept { return scanner_; }

  // A galvo output drives the scanner: the beam follows the mirrors, not the ideal raster.
  void attach_galvo() noexcept { galvo_attached_.store(true, std::memory_order_release); }
  bool galvo_attached() const noexcept { return galvo_attached_.load(std::memory_order_acquire); }
  // A lines backend drives emission: light reaches the sample only while emission is on.
  void attach_lines(bool attached) noexcept {
    lines_attached_.store(attached, std::memory_order_release);
  }
  bool lines_attached() const noexcept { return lines_attached_.load(std::memory_order_acquire); }

  // --- lines ---
  void command_emission(bool on) noexcept;
  bool emission_commanded() const noexcept { return emission_.load(std::memory_order_acquire); }
  // The heartbeat line toggled (the external watchdog is fed).
  void heartbeat() noexcept;
  // Emission as the read-back line sees it: commanded, laser ready, watchdog fed.
  bool emission_on() const noexcept;
  void set_footswitch(bool pressed) noexcept;
  bool footswitch() const noexcept { return footswitch_.load(std::memory_order_acquire); }
  std::uint64_t footswitch_changed_ns() const noexcept {
    return footswitch_changed_ns_.load(std::memory_order_acquire);
  }
  hal::LineInputs inputs() const noexcept;

  // What the digitizer needs to know: does light reach the sample now?
  bool light_on_sample() const noexcept;

 private:
  BenchConfig config_;
  FaultInjector faults_;
  SimulatedScanner scanner_;
  std::atomic<bool> galvo_attached_{false};
  std::atomic<bool> lines_attached_{false};
  std::atomic<bool> emission_{false};
  std::atomic<std::uint64_t> last_heartbeat_ns_{0};
  std::atomic<bool> footswitch_{false};
  std::atomic<std::uint64_t> footswitch_changed_ns_{0};
};

}  // namespace ioct::sim
