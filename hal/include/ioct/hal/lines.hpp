// The low-rate digital lines around the laser and the operator:
//   out: laser emission enable, external watchdog heartbeat;
//   in:  laser ready, sweep trigger present, k-clock valid, footswitch.
// Emission is driven and read back, so "enabled" is something the acquisition verifies, not
// assumes. Input edges come with kernel timestamps for the housekeeping thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace ioct::hal {

enum class InputLine : std::uint8_t {
  laser_ready,
  sweep_trigger_present,
  k_clock_valid,
  footswitch
};
enum class OutputLine : std::uint8_t { laser_emission, watchdog };

std::string_view to_string(InputLine line) noexcept;
std::string_view to_string(OutputLine line) noexcept;

struct LineInputs {
  bool laser_ready = false;
  bool sweep_trigger_present = false;
  bool k_clock_valid = false;
  bool footswitch = false;
  friend bool operator==(const LineInputs&, const LineInputs&) = default;
};

struct LineEvent {
  InputLine line = InputLine::laser_ready;
  bool rising = false;             // logical level after the edge (active_low already applied)
  std::uint64_t timestamp_ns = 0;  // CLOCK_MONOTONIC, from the kernel where the backend has it
};

// Where each line is wired: a GPIO chip and line offsets (the simulator ignores them).
struct LineWiring {
  std::uint32_t offset = 0;
  bool active_low = false;
  friend bool operator==(const LineWiring&, const LineWiring&) = default;
};

struct LinesConfig {
  std::string chip = "gpiochip0";  // name or path of the GPIO chip
  std::string consumer = "ioct-rt";
  LineWiring laser_emission{0, false};
  LineWiring watchdog{1, false};
  LineWiring laser_ready{2, false};
  LineWiring sweep_trigger_present{3, false};
  LineWiring k_clock_valid{4, false};
  LineWiring footswitch{5, true};

  // Throws ConfigError naming the first bad key ("lines.<key>"), e.g. two lines on one offset.
  void validate() const;
};

class Lines {
 public:
  Lines() = default;
  Lines(const Lines&) = delete;
  Lines& operator=(const Lines&) = delete;
  virtual ~Lines() = default;

  // Requests the lines (outputs start inactive: emission off). Throws ConfigError for a bad
  // config and std::runtime_error naming the chip or line that cannot be had.
  virtual void prepare(const LinesConfig& config) = 0;
  // Releases the lines, emission off first. Harmless when not prepared.
  virtual void release() noexcept = 0;

  // Drives the emission enable line; never blocks long, never throws (safety path).
  virtual void set_laser_emission(bool on) noexcept = 0;
  // The emission line's level as read back from the hardware.
  virtual bool laser_emission() const noexcept = 0;
  virtual LineInputs read_inputs() noexcept = 0;
  // Toggles the external watchdog's heartbeat line; it trips when the toggling stops.
  virtual void toggle_watchdog() noexcept = 0;
  // The next input edge, waiting at most `timeout`; for the housekeeping thread.
  virtual std::optional<LineEvent> wait_event(std::chrono::nanoseconds timeout) = 0;

  virtual std::string_view backend() const noexcept = 0;
};

}  // namespace ioct::hal
