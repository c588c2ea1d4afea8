#include "ioct/hal/gpio/gpiod_lines.hpp"

#include <gpiod.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::hal::gpio {
namespace {

constexpr InputLine kInputOrder[] = {InputLine::laser_ready, InputLine::sweep_trigger_present,
                                     InputLine::k_clock_valid, InputLine::footswitch};

std::uint64_t distance(std::uint64_t a, std::uint64_t b) noexcept {
  return a > b ? a - b : b - a;
}

// Kernels before 5.7 stamp v1 line events with CLOCK_REALTIME: whichever clock the stamp is
// nearer to is the one it was taken on.
std::uint64_t monotonic_stamp(const timespec& ts) noexcept {
  const std::uint64_t stamp = static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u +
                              static_cast<std::uint64_t>(ts.tv_nsec);
  const std::uint64_t monotonic = monotonic_ns();
  const std::uint64_t realtime = clock_ns(CLOCK_REALTIME);
  if (distance(stamp, realtime) < distance(stamp, monotonic) && realtime > monotonic) {
    const std::uint64_t offset = realtime - monotonic;
    return stamp > offset ? stamp - offset : 0;
  }
  return stamp;
}

std::string in_quotes(std::string_view text) {
  return "\"" + std::string(text) + "\"";
}

struct Wired {
  const char* key;
  const LineWiring* wiring;
};

}  // namespace

std::string describe_gpio_chips() {
  std::vector<std::string> chips;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("gpiochip", 0) != 0) continue;
    std::string text = name;
    if (gpiod_chip* chip = gpiod_chip_open(entry.path().c_str()); chip != nullptr) {
      text += " [" + std::string(gpiod_chip_label(chip)) + "] (" +
              std::to_string(gpiod_chip_num_lines(chip)) + " lines)";
      gpiod_chip_close(chip);
    } else {
      text += " (cannot be opened: " + std::string(std::strerror(errno)) + ")";
    }
    chips.push_back(text);
  }
  if (chips.empty()) {
    return "this machine has no GPIO chips (no /dev/gpiochip*: the kernel lacks GPIO character "
           "devices or no GPIO driver is loaded)";
  }
  std::sort(chips.begin(), chips.end());
  std::string text = "GPIO chips here: ";
  for (std::size_t i = 0; i < chips.size(); ++i) text += (i != 0 ? ", " : "") + chips[i];
  return text;
}

GpiodLines::~GpiodLines() {
  release();
}

void GpiodLines::prepare(const LinesConfig& config) {
  config.validate();
  release();

  errno = 0;
  gpiod_chip* chip = gpiod_chip_open_lookup(config.chip.c_str());
  if (chip == nullptr) {
    const int error = errno;
    throw std::runtime_error("lines.chip = " + in_quotes(config.chip) +
                             ": cannot open this GPIO chip (" +
                             (error != 0 ? std::string(std::strerror(error)) : "not found") +
                             "); " + describe_gpio_chips());
  }
  chip_ = chip;
  const unsigned int lines = gpiod_chip_num_lines(chip);
  chip_description_ = std::string(gpiod_chip_name(chip)) + " [" + gpiod_chip_label(chip) + "], " +
                      std::to_string(lines) + " lines";

  const Wired outputs[] = {{"lines.laser_emission", &config.laser_emission},
                           {"lines.watchdog", &config.watchdog}};
  const Wired inputs[] = {{"lines.laser_ready", &config.laser_ready},
                          {"lines.sweep_trigger_present", &config.sweep_trigger_present},
                          {"lines.k_clock_valid", &config.k_clock_valid},
                          {"lines.footswitch", &config.footswitch}};

  auto fail = [&](const Wired& wired, gpiod_line* line, const char* what, int error) {
    std::string text = std::string(wired.key) +
                       ".offset = " + std::to_string(wired.wiring->offset) + " on " +
                       chip_description_ + ": " + what;
    if (error != 0) text += " (" + std::string(std::strerror(error)) + ")";
    if (line != nullptr && gpiod_line_update(line) == 0 && gpiod_line_is_used(line)) {
      const char* holder = gpiod_line_consumer(line);
      text += "; it is held by " + in_quotes(holder != nullptr ? holder : "the kernel");
    }
    release();
    throw std::runtime_error(text);
  };
  auto get = [&](const Wired& wired) {
    if (wired.wiring->offset >= lines) {
      fail(wired, nullptr,
           ("the chip has lines 0.." + std::to_string(lines == 0 ? 0 : lines - 1)).c_str(), 0);
    }
    gpiod_line* line = gpiod_chip_get_line(chip, wired.wiring->offset);
    if (line == nullptr) fail(wired, nullptr, "cannot get the line", errno);
    return line;
  };
  auto flags = [](const LineWiring& wiring) {
    return wiring.active_low ? static_cast<int>(GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW) : 0;
  };

  for (std::size_t i = 0; i < 2; ++i) {
    gpiod_line* line = get(outputs[i]);
    // Outputs start inactive: emission off, heartbeat low.
    if (gpiod_line_request_output_flags(line, config.consumer.c_str(), flags(*outputs[i].wiring),
                                        0) != 0) {
      fail(outputs[i], line, "cannot request the line as an output", errno);
    }
    if (i == 0) emission_ = line;
    if (i == 1) watchdog_ = line;
  }
  for (std::size_t i = 0; i < kInputs; ++i) {
    gpiod_line* line = get(inputs[i]);
    if (gpiod_line_request_both_edges_events_flags(line, config.consumer.c_str(),
                                                   flags(*inputs[i].wiring)) != 0) {
      fail(inputs[i], line, "cannot request the line as an input with edge events", errno);
    }
    inputs_[i] = line;
  }
  watchdog_level_ = false;
  pending_count_ = 0;
  line_errors_.store(0, std::memory_order_relaxed);
}

void GpiodLines::release() noexcept {
  if (chip_ == nullptr) return;
  if (emission_ != nullptr && gpiod_line_set_value(emission_, 0) != 0) {
    line_errors_.fetch_add(1, std::memory_order_relaxed);
  }
  // Closing the chip releases every line requested from it.
  gpiod_chip_close(chip_);
  chip_ = nullptr;
  emission_ = nullptr;
  watchdog_ = nullptr;
  inputs_.fill(nullptr);
  pending_count_ = 0;
  chip_description_.clear();
}

void GpiodLines::set_laser_emission(bool on) noexcept {
  if (emission_ == nullptr) return;
  if (gpiod_line_set_value(emission_, on ? 1 : 0) != 0) {
    line_errors_.fetch_add(1, std::memory_order_relaxed);
  }
}

bool GpiodLines::laser_emission() const noexcept {
  if (emission_ == nullptr) return false;
  const int value = gpiod_line_get_value(emission_);
  if (value < 0) {
    line_errors_.fetch_add(1, std::memory_order_relaxed);
    return false;  // unverified reads as off
  }
  return value == 1;
}

LineInputs GpiodLines::read_inputs() noexcept {
  LineInputs state;
  bool* fields[kInputs] = {&state.laser_ready, &state.sweep_trigger_present, &state.k_clock_valid,
                           &state.footswitch};
  for (std::size_t i = 0; i < kInputs; ++i) {
    if (inputs_[i] == nullptr) continue;
    const int value = gpiod_line_get_value(inputs_[i]);
    if (value < 0) {
      line_errors_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    *fields[i] = value == 1;
  }
  return state;
}

void GpiodLines::toggle_watchdog() noexcept {
  if (watchdog_ == nullptr) return;
  watchdog_level_ = !watchdog_level_;
  if (gpiod_line_set_value(watchdog_, watchdog_level_ ? 1 : 0) != 0) {
    line_errors_.fetch_add(1, std::memory_order_relaxed);
  }
}

void GpiodLines::drain_events(gpiod_line* line, InputLine which) {
  gpiod_line_event events[16];
  const int n = gpiod_line_event_read_multiple(line, events, 16);
  if (n < 0) {
    throw std::runtime_error("lines." + std::string(to_string(which)) + " on " + chip_description_ +
                             ": reading its edge events failed (" + std::strerror(errno) + ")");
  }
  for (int i = 0; i < n && pending_count_ < kPendingEvents; ++i) {
    pending_[pending_count_++] = {which, events[i].event_type == GPIOD_LINE_EVENT_RISING_EDGE,
                                  monotonic_stamp(events[i].ts)};
  }
}

std::optional<LineEvent> GpiodLines::wait_event(std::chrono::nanoseconds timeout) {
  if (chip_ == nullptr) throw std::logic_error("lines: wait_event() before prepare()");
  if (pending_count_ == 0) {
    gpiod_line_bulk bulk;
    gpiod_line_bulk_init(&bulk);
    for (gpiod_line* line : inputs_) gpiod_line_bulk_add(&bulk, line);
    const auto ns = std::max<std::chrono::nanoseconds::rep>(timeout.count(), 0);
    const timespec wait{static_cast<time_t>(ns / 1'000'000'000),
                        static_cast<long>(ns % 1'000'000'000)};
    gpiod_line_bulk ready;
    gpiod_line_bulk_init(&ready);
    const int r = gpiod_line_event_wait_bulk(&bulk, &wait, &ready);
    if (r < 0) {
      throw std::runtime_error("lines: waiting for input edges on " + chip_description_ +
                               " failed (" + std::strerror(errno) + ")");
    }
    if (r == 0) return std::nullopt;
    for (unsigned int i = 0; i < gpiod_line_bulk_num_lines(&ready); ++i) {
      gpiod_line* line = gpiod_line_bulk_get_line(&ready, i);
      for (std::size_t k = 0; k < kInputs; ++k) {
        if (inputs_[k] == line) drain_events(line, kInputOrder[k]);
      }
    }
    // Edges of different lines in the order they happened.
    std::sort(
        pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(pending_count_),
        [](const LineEvent& a, const LineEvent& b) { return a.timestamp_ns > b.timestamp_ns; });
  }
  if (pending_count_ == 0) return std::nullopt;
  return pending_[--pending_count_];  // sorted latest first: the earliest is at the end
}

}  // namespace ioct::hal::gpio
