#include "ioct/hal/digitizer_config.hpp"

#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::hal {

std::string_view to_string(ClockSource source) noexcept {
  switch (source) {
    case ClockSource::external_k_clock:
      return "external_k_clock";
    case ClockSource::internal:
      return "internal";
  }
  return "unknown";
}

std::string_view to_string(TriggerSource source) noexcept {
  switch (source) {
    case TriggerSource::sweep_input:
      return "sweep_input";
    case TriggerSource::software:
      return "software";
  }
  return "unknown";
}

void DigitizerConfig::validate() const {
  require_integer_in_range("digitizer.samples_per_ascan", samples_per_ascan, 16, 16384);
  if (samples_per_ascan % 2 != 0) {
    throw ConfigError("digitizer.samples_per_ascan", format_value(std::uint64_t{samples_per_ascan}),
                      "must be even (a real FFT of N samples gives N/2 depth bins)");
  }
  require_integer_in_range("digitizer.ascans_per_bscan", ascans_per_bscan, 1, 65536);
  require_integer_in_range("digitizer.flyback_sweeps", flyback_sweeps, 0, 65536);
  require_integer_in_range("digitizer.bscans_per_group", bscans_per_group, 1, 1024);
  if (clock_source != ClockSource::external_k_clock && clock_source != ClockSource::internal) {
    throw ConfigError("digitizer.clock_source",
                      format_value(std::int64_t{static_cast<int>(clock_source)}),
                      "must be external_k_clock or internal");
  }
  require_real_in_range("digitizer.ascan_rate_hz", ascan_rate_hz, 1.0, 10e6);
  require_integer_in_range("digitizer.sample_bits", sample_bits, 8, 16);
  if (trigger.source != TriggerSource::sweep_input && trigger.source != TriggerSource::software) {
    throw ConfigError("digitizer.trigger.source",
                      format_value(std::int64_t{static_cast<int>(trigger.source)}),
                      "must be sweep_input or software");
  }
  require_real_in_range("digitizer.trigger.level_volts", trigger.level_volts, -5.0, 5.0);
  require_integer_in_range("digitizer.trigger.delay_samples", trigger.delay_samples, 0, 65536);
  require_integer_in_range("digitizer.timeout_ms", timeout_ms, 1, 60'000);
  // Bounds one group so that sizes in words and bytes stay far from any overflow.
  constexpr std::uint64_t kMaxGroupSamples = std::uint64_t{1} << 31;
  if (samples_per_group() > kMaxGroupSamples) {
    throw ConfigError("digitizer.samples_per_group", format_value(samples_per_group()),
                      "samples_per_ascan x ascans_per_bscan x bscans_per_group must be at most " +
                          format_value(kMaxGroupSamples));
  }
}

}  // namespace ioct::hal
