#include "ioct/sim/swept_source.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::sim {
namespace {

double wavenumber_per_um(double wavelength_nm) {
  return 2.0 * std::numbers::pi / (wavelength_nm * 1e-3);
}

}  // namespace

void SweptSourceConfig::validate() const {
  ioct::require_real_in_range("source.center_wavelength_nm", center_wavelength_nm, 400.0, 2000.0);
  ioct::require_real_in_range("source.sweep_bandwidth_nm", sweep_bandwidth_nm, 1.0,
                              0.5 * center_wavelength_nm);
  ioct::require_real_in_range("source.envelope_fwhm_nm", envelope_fwhm_nm, 0.1 * sweep_bandwidth_nm,
                              4.0 * sweep_bandwidth_nm);
}

double SweptSourceConfig::axial_pixel_um() const noexcept {
  const double k_max = wavenumber_per_um(center_wavelength_nm - 0.5 * sweep_bandwidth_nm);
  const double k_min = wavenumber_per_um(center_wavelength_nm + 0.5 * sweep_bandwidth_nm);
  return std::numbers::pi / (k_max - k_min);
}

std::vector<float> SweptSourceConfig::envelope(std::uint32_t samples) const {
  const double k_max = wavenumber_per_um(center_wavelength_nm - 0.5 * sweep_bandwidth_nm);
  const double k_min = wavenumber_per_um(center_wavelength_nm + 0.5 * sweep_bandwidth_nm);
  const double k_step = (k_max - k_min) / samples;  // sample i sits at k_min + i * k_step
  const double k_center = wavenumber_per_um(center_wavelength_nm);
  const double k_fwhm = wavenumber_per_um(center_wavelength_nm - 0.5 * envelope_fwhm_nm) -
                        wavenumber_per_um(center_wavelength_nm + 0.5 * envelope_fwhm_nm);
  const double sigma = k_fwhm / (2.0 * std::sqrt(2.0 * std::numbers::ln2));
  std::vector<float> row(samples);
  for (std::uint32_t i = 0; i < samples; ++i) {
    const double dk = k_min + i * k_step - k_center;
    row[i] = static_cast<float>(std::exp(-0.5 * dk * dk / (sigma * sigma)));
  }
  return row;
}

}  // namespace ioct::sim
