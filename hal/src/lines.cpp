#include "ioct/hal/lines.hpp"

#include <array>
#include <string>
#include <utility>

#include "ioct/common/config_error.hpp"

namespace ioct::hal {

std::string_view to_string(InputLine line) noexcept {
  switch (line) {
    case InputLine::laser_ready:
      return "laser_ready";
    case InputLine::sweep_trigger_present:
      return "sweep_trigger_present";
    case InputLine::k_clock_valid:
      return "k_clock_valid";
    case InputLine::footswitch:
      return "footswitch";
  }
  return "unknown";
}

std::string_view to_string(OutputLine line) noexcept {
  switch (line) {
    case OutputLine::laser_emission:
      return "laser_emission";
    case OutputLine::watchdog:
      return "watchdog";
  }
  return "unknown";
}

void LinesConfig::validate() const {
  if (chip.empty()) throw ConfigError("lines.chip", "\"\"", "must name a GPIO chip");
  const std::array<std::pair<const char*, const LineWiring*>, 6> wired{{
      {"lines.laser_emission.offset", &laser_emission},
      {"lines.watchdog.offset", &watchdog},
      {"lines.laser_ready.offset", &laser_ready},
      {"lines.sweep_trigger_present.offset", &sweep_trigger_present},
      {"lines.k_clock_valid.offset", &k_clock_valid},
      {"lines.footswitch.offset", &footswitch},
  }};
  for (std::size_t i = 0; i < wired.size(); ++i) {
    require_integer_in_range(wired[i].first, wired[i].second->offset, 0, 1023);
    for (std::size_t j = 0; j < i; ++j) {
      if (wired[i].second->offset == wired[j].second->offset) {
        throw ConfigError(wired[i].first, format_value(std::uint64_t{wired[i].second->offset}),
                          std::string("is already used by ") + wired[j].first);
      }
    }
  }
}

}  // namespace ioct::hal
