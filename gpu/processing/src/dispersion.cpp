#include "ioct/gpu/processing/dispersion.hpp"

#include <cmath>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

void DispersionConfig::validate() const {
  require_real_in_range("dispersion_c2", c2, -10000.0, 10000.0);
  require_real_in_range("dispersion_c3", c3, -10000.0, 10000.0);
}

double dispersion_phase(const DispersionConfig& config, std::uint32_t samples,
                        std::uint32_t j) noexcept {
  const double t = 2.0 * static_cast<double>(j) / static_cast<double>(samples - 1) - 1.0;
  return (config.c2 + config.c3 * t) * t * t;
}

std::vector<std::complex<float>> dispersion_correction(const DispersionConfig& config,
                                                       std::uint32_t samples) {
  std::vector<std::complex<float>> factor;
  if (!config.enabled()) return factor;
  factor.resize(samples);
  for (std::uint32_t j = 0; j < samples; ++j) {
    const double phi = dispersion_phase(config, samples, j);
    factor[j] = {static_cast<float>(std::cos(phi)), static_cast<float>(-std::sin(phi))};
  }
  return factor;
}

}  // namespace ioct::gpu
