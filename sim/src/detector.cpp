#include "ioct/sim/detector.hpp"

#include <cmath>
#include <numbers>

#include "ioct/common/config_error.hpp"

namespace ioct::sim {

void DetectorConfig::validate() const {
  ioct::require_real_in_range("detector.adc_offset_counts", adc_offset_counts, 0.0, 4095.0);
  ioct::require_real_in_range("detector.reference_dc_counts", reference_dc_counts, 0.0, 4095.0);
  ioct::require_real_in_range("detector.fringe_counts", fringe_counts, 0.0, 2048.0);
  ioct::require_real_in_range("detector.fixed_pattern_counts", fixed_pattern_counts, 0.0, 512.0);
  ioct::require_real_in_range("detector.read_noise_counts", read_noise_counts, 0.0, 512.0);
  ioct::require_real_in_range("detector.shot_noise_counts", shot_noise_counts, 0.0, 512.0);
  ioct::require_real_in_range("detector.rin_counts", rin_counts, 0.0, 512.0);
  ioct::require_real_in_range("detector.sweep_power_jitter", sweep_power_jitter, 0.0, 0.2);
}

double DetectorConfig::count_scale(std::uint32_t sample_bits) noexcept {
  return std::ldexp(1.0, static_cast<int>(sample_bits) - 12);
}

std::vector<float> DetectorConfig::light_background(std::span<const float> envelope,
                                                    std::span<const double> k_index,
                                                    std::uint32_t sample_bits) const {
  const double scale = count_scale(sample_bits);
  const double samples = static_cast<double>(envelope.size());
  const double depth_bins = 0.5 * samples;
  // Two reflections inside the optics: fixed depths, every A-scan alike.
  const double line_depth[2] = {0.013 * depth_bins, 0.081 * depth_bins};
  const double line_weight[2] = {1.0, 0.5};
  std::vector<float> row(envelope.size());
  for (std::size_t i = 0; i < envelope.size(); ++i) {
    double fringe = 0.0;
    for (int line = 0; line < 2; ++line) {
      fringe += line_weight[line] *
                std::cos(2.0 * std::numbers::pi * k_index[i] * line_depth[line] / samples);
    }
    row[i] = static_cast<float>(scale * envelope[i] *
                                (reference_dc_counts + fixed_pattern_counts * fringe));
  }
  return row;
}

std::vector<float> DetectorConfig::noise_sigma(std::span<const float> envelope,
                                               std::uint32_t sample_bits) const {
  const double scale = count_scale(sample_bits);
  std::vector<float> row(envelope.size());
  for (std::size_t i = 0; i < envelope.size(); ++i) {
    const double light = envelope[i];
    const double variance = read_noise_counts * read_noise_counts +
                            shot_noise_counts * shot_noise_counts * light +
                            rin_counts * rin_counts * light * light;
    row[i] = static_cast<float>(scale * std::sqrt(variance));
  }
  return row;
}

}  // namespace ioct::sim
