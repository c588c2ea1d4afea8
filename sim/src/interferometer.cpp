#include "ioct/sim/interferometer.hpp"

#include "ioct/common/config_error.hpp"

namespace ioct::sim {

void InterferometerConfig::validate() const {
  ioct::require_real_in_range("interferometer.dispersion_c2", dispersion_c2, -10000.0, 10000.0);
  ioct::require_real_in_range("interferometer.dispersion_c3", dispersion_c3, -10000.0, 10000.0);
}

double InterferometerConfig::dispersion_phase(double k_index,
                                              std::uint32_t samples) const noexcept {
  const double t = 2.0 * k_index / static_cast<double>(samples - 1) - 1.0;
  return (dispersion_c2 + dispersion_c3 * t) * t * t;
}

}  // namespace ioct::sim
