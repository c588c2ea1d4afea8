// The balanced detector and ADC: what every spectrum carries besides the sample's fringes.
//
// Levels are given in counts of a 12-bit ADC; other resolutions scale them by 2^(bits - 12).
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
  double shot_noise_counts = 3.5;      // shot and intensity noise at the envelope peak (std dev)

  // Throws ioct::ConfigError ("detector.<key>").
  void validate() const;

  // Counts per 12-bit count for an ADC of `sample_bits`.
  static double count_scale(std::uint32_t sample_bits) noexcept;

  // The part of every spectrum that does not depend on the sample: ADC offset, residual
  // reference DC and the fixed-pattern lines (artefacts at fixed depths 1.3% and 8.1% of the
  // depth axis), in counts of `sample_bits`.
  std::vector<float> background(std::span<const float> envelope, std::uint32_t sample_bits) const;
  // Standard deviation of the additive noise at each sample: read noise plus shot noise that
  // grows with the square root of the light on the detector.
  std::vector<float> noise_sigma(std::span<const float> envelope, std::uint32_t sample_bits) const;
};

}  // namespace ioct::sim
