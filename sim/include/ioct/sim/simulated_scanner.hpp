// The simulated galvo scanner: the DAC stream's FIFO and the two mirrors behind it.
//
// The galvo output (SimulatedGalvoOutput) queues commanded positions with push(); the bench's
// clock, the simulated digitizer, clocks one out per sweep trigger with advance() and reads back
// where the mirrors actually were. Each mirror follows its command as a second-order system
// (natural frequency, damping; exact zero-order-hold discretisation per sweep), so a ramp lags by
// 2 zeta / omega, a fast flyback rings, and forward and reverse lines of a bidirectional scan
// are misregistered, as on a real scanner.
//
// Threads: push(), start_stream() and configure() on the producer's thread; advance() on the
// digitizer's (often the same real-time thread); park() and status() from any thread. The FIFO
// is single-producer single-consumer and lock-free; park() only raises flags that advance() acts
// on. configure() only while the stream is stopped and the digitizer is not advancing.
#pragma once

#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

#include "ioct/hal/galvo_output.hpp"
#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/fault_injector.hpp"

namespace ioct::sim {

struct MirrorDynamics {
  double natural_hz = 2000.0;  // closed-loop bandwidth of the servo; 0: ideal mirrors, no lag
  double damping = 0.7;
};

class SimulatedScanner {
 public:
  explicit SimulatedScanner(const FaultInjector& faults);
  SimulatedScanner(const SimulatedScanner&) = delete;
  SimulatedScanner& operator=(const SimulatedScanner&) = delete;

  // The mirrors' dynamics and the time one sweep lasts.
  void set_dynamics(const MirrorDynamics& dynamics, double sweep_rate_hz);

  // --- the galvo output's side ---
  // Allocates the FIFO, empties it and rests the mirrors at the park position.
  void configure(const hal::GalvoOutputConfig& config);
  void start_stream() noexcept;
  std::size_t push(std::span<const hal::GalvoSample> samples) noexcept;
  void park() noexcept;
  hal::GalvoStatus status() const noexcept;
  bool configured() const noexcept { return capacity_ != 0; }

  // --- the bench's clock ---
  // `sweeps` sweeps pass. With `triggers` the DAC clocks one sample out per sweep (without, the
  // trigger is gone and the command holds). Writes each sweep's beam position (the mirrors at
  // mid-sweep) to `positions` unless it is null.
  void advance(std::uint64_t sweeps, bool triggers, hal::BeamPosition* positions) noexcept;
  // Where the mirrors are now (advance()'s thread).
  hal::BeamPosition mirror() const noexcept {
    return {static_cast<float>(x_.position), static_cast<float>(y_.position)};
  }

 private:
  struct Axis {
    double position = 0.0;
    double velocity = 0.0;
  };
  struct Step {  // x' = A x + B u for one axis over one interval
    double a00 = 1, a01 = 0, a10 = 0, a11 = 1, b0 = 0, b1 = 0;
  };
  static Step discretize(double omega, double zeta, double dt);
  static void apply(const Step& step, Axis& axis, double command) noexcept;
  hal::GalvoSample next_command(bool triggers) noexcept;

  const FaultInjector& faults_;
  Step full_{};
  Step half_{};
  bool ideal_ = false;  // the mirrors are where commanded, at once

  // FIFO: head_ written by push(), tail_ by advance().
  std::vector<hal::GalvoSample> buffer_;
  std::uint64_t capacity_ = 0;
  std::atomic<std::uint64_t> head_{0};
  std::atomic<std::uint64_t> tail_{0};
  std::atomic<std::uint64_t> drop_until_{0};  // park(): advance() drops everything before this

  std::atomic<bool> streaming_{false};
  std::atomic<bool> parked_{true};
  std::atomic<std::uint32_t> lead_pending_{0};
  std::atomic<float> park_x_{-1.0f};
  std::atomic<float> park_y_{-1.0f};
  std::atomic<std::uint32_t> lead_samples_{0};

  // Counters: samples_written_ by push(); the others by advance().
  std::atomic<std::uint64_t> samples_written_{0};
  std::atomic<std::uint64_t> samples_output_{0};
  std::atomic<std::uint64_t> underruns_{0};
  std::atomic<std::uint64_t> output_base_{0};
  std::atomic<std::uint64_t> underrun_base_{0};
  mutable std::atomic<std::uint32_t> faults_seen_{0};  // sticky kGalvo* bits

  // advance()'s own state.
  Axis x_;
  Axis y_;
  hal::GalvoSample command_{-1.0f, -1.0f};
  bool dry_ = false;
  std::uint32_t skipping_ = 0;
};

}  // namespace ioct::sim
