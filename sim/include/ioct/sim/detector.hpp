// The balanced detector and ADC: what every spectrum carries besides the sample's fringes.
//
// Levels are given in counts of a 12-bit ADC; other resolutions scale them by 2^(bits - 12).
// The light-dependent terms follow the source's spectral envelope at each sample:
//   ADC offset + envelope * (residual reference DC + fixed-pattern fringes)   the background
//   + fringes of the sample (fringe_counts for reflectivity 1 at the envelope peak)
//   + noise: read noise, shot noise ~ sqrt(envelope), white RIN ~ envelope, and a per-sweep
//     power fluctuation (sweep_power_jitter) that scales reference DC and fringes alike.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace ioct::sim {

struct DetectorConfig {
  double adc_offset_counts = 2048.0;   // balanced detection leaves the signal about mid-scale
  double reference_dc_counts = 300.0;  // residual reference spectrum at the envelope peak
  double fringe_counts = 60.0;         // fringe amplitude of a reflectivity-1 interface at the peak
  double fixed_pattern_counts = 6.0;   // strongest coherent artefact (optics reflections)
  double read_noise_counts = 2.5;      // electronic noise, standard deviation
  double shot_noise_counts = 3.5;      // shot noise at the envelope peak (std dev)
  double rin_counts = 1.0;             // white relative-intensity noise at the envelope peak
  double sweep_power_jitter = 0.002;   // relative std dev of each sweep's power

  // Throws ioct::ConfigError ("detector.<key>").
  void validate() const;

  // Counts per 12-bit count for an ADC of `sample_bits`.
  static double count_scale(std::uint32_t sample_bits) noexcept;

  // The light-dependent background at each sample, without the ADC offset: residual reference
  // DC and two fixed-pattern fringes (reflections inside the optics at 1.3% and 8.1% of the
  // depth axis), in counts of `sample_bits`. `k_index` is each sample's position on the k-linear
  // grid of `envelope.size()` samples.
  std::vector<float> light_background(std::span<const float> envelope,
                                      std::span<const double> k_index,
                                      std::uint32_t sample_bits) const;
  // Standard deviation of the additive noise at each sample.
  std::vector<float> noise_sigma(std::span<const float> envelope, std::uint32_t sample_bits) const;
};

}  // namespace ioct::sim
