// The low-rate lines on a GPIO chip through libgpiod (the v1.6 API Debian 12 ships):
// laser emission and the watchdog heartbeat as outputs, laser ready, sweep trigger present,
// k-clock valid and the footswitch as inputs with both-edge events carrying kernel timestamps.
//
// Levels are logical: a line wired active_low is requested with libgpiod's active-low flag, so
// "on" is on whatever the wiring. Emission is read back from the line, not from what was last
// written. The safety-path calls (set_laser_emission, laser_emission, read_inputs,
// toggle_watchdog) never throw; a failed line operation is counted in line_errors() and reads
// as "off" / false.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "ioct/hal/lines.hpp"

struct gpiod_chip;
struct gpiod_line;

namespace ioct::hal::gpio {

class GpiodLines final : public Lines {
 public:
  GpiodLines() = default;
  ~GpiodLines() override;

  // Throws ConfigError for a bad config, std::runtime_error naming the chip (and the GPIO chips
  // this machine has) when it cannot be opened, and naming the line's key, offset and current
  // holder when a line cannot be requested.
  void prepare(const LinesConfig& config) override;
  void release() noexcept override;

  void set_laser_emission(bool on) noexcept override;
  bool laser_emission() const noexcept override;
  LineInputs read_inputs() noexcept override;
  void toggle_watchdog() noexcept override;
  // Timestamps are CLOCK_MONOTONIC: the kernel stamps GPIO events with it since Linux 5.7; an
  // older kernel's CLOCK_REALTIME stamps are moved onto CLOCK_MONOTONIC. Throws
  // std::logic_error before prepare(), std::runtime_error when waiting fails.
  std::optional<LineEvent> wait_event(std::chrono::nanoseconds timeout) override;

  std::string_view backend() const noexcept override { return "gpiod"; }
  bool prepared() const noexcept { return chip_ != nullptr; }
  // "gpiochip0 [label], 32 lines" once prepared.
  const std::string& chip_description() const noexcept { return chip_description_; }
  std::uint64_t line_errors() const noexcept {
    return line_errors_.load(std::memory_order_relaxed);
  }

 private:
  static constexpr std::size_t kInputs = 4;
  static constexpr std::size_t kPendingEvents = 64;

  void drain_events(gpiod_line* line, InputLine which);

  gpiod_chip* chip_ = nullptr;
  gpiod_line* emission_ = nullptr;
  gpiod_line* watchdog_ = nullptr;
  std::array<gpiod_line*, kInputs> inputs_{};
  bool watchdog_level_ = false;
  std::string chip_description_;
  std::array<LineEvent, kPendingEvents> pending_{};
  std::size_t pending_count_ = 0;
  mutable std::atomic<std::uint64_t> line_errors_{0};
};

// The GPIO chips this machine has, for messages: "gpiochip0 [pinctrl-bcm2711] (58 lines), ..."
// or a sentence saying there are none and why that may be.
std::string describe_gpio_chips();

}  // namespace ioct::hal::gpio
