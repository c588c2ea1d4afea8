// What a digitizer records: the geometry of one group of raw spectra and how it is clocked.
#pragma once

#include <cstdint>
#include <string_view>

namespace ioct::hal {

enum class ClockSource {
  external_k_clock,  // sampled on the swept source's k-clock: samples are linear in wavenumber
  internal,          // the digitizer's own clock: samples linear in time, resampled to k downstream
};

std::string_view to_string(ClockSource source) noexcept;

enum class TriggerSource {
  sweep_input,  // the swept source's sweep trigger on the digitizer's trigger input
  software,     // free running on the digitizer's own timing (bench and self-test)
};

std::string_view to_string(TriggerSource source) noexcept;

struct TriggerConfig {
  TriggerSource source = TriggerSource::sweep_input;
  double level_volts = 0.5;         // threshold of the trigger input
  std::uint32_t delay_samples = 0;  // samples skipped after the trigger before recording
  friend bool operator==(const TriggerConfig&, const TriggerConfig&) = default;
};

// One group is bscans_per_group B-scans; each B-scan is ascans_per_bscan recorded sweeps followed
// by flyback_sweeps sweeps that the laser makes while the galvo returns and that are not
// recorded. The sweep counter counts every sweep, recorded or not.
struct DigitizerConfig {
  std::uint32_t samples_per_ascan = 1376;  // samples of one sweep; even, so a real FFT has N/2 bins
  std::uint32_t ascans_per_bscan = 512;    // recorded sweeps per B-scan
  std::uint32_t flyback_sweeps = 26;       // unrecorded sweeps after each B-scan
  std::uint32_t bscans_per_group = 16;     // B-scans delivered per acquire_group()
  ClockSource clock_source = ClockSource::external_k_clock;
  double ascan_rate_hz = 100'000.0;  // sweep rate of the source
  std::uint32_t sample_bits = 12;    // ADC resolution; samples are right-aligned in 16-bit words
  TriggerConfig trigger;
  // No record for this long while running is a stall: acquire_group() returns with kGroupTimeout.
  std::uint32_t timeout_ms = 500;

  // Throws ConfigError naming the first key out of range ("digitizer.<key>").
  void validate() const;

  std::uint64_t sweeps_per_bscan() const noexcept {
    return std::uint64_t{ascans_per_bscan} + flyback_sweeps;
  }
  std::uint64_t sweeps_per_group() const noexcept { return sweeps_per_bscan() * bscans_per_group; }
  std::uint64_t samples_per_bscan() const noexcept {
    return std::uint64_t{samples_per_ascan} * ascans_per_bscan;
  }
  // 16-bit words one acquire_group() fills, layout [bscan][ascan][sample].
  std::uint64_t samples_per_group() const noexcept {
    return samples_per_bscan() * bscans_per_group;
  }
  double sweep_period_ns() const noexcept { return 1e9 / ascan_rate_hz; }
  // Largest value a sample can take: 2^sample_bits - 1.
  std::uint16_t max_sample_value() const noexcept {
    return static_cast<std::uint16_t>((1u << sample_bits) - 1u);
  }

  friend bool operator==(const DigitizerConfig&, const DigitizerConfig&) = default;
};

}  // namespace ioct::hal
