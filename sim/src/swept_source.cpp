#include "ioct/sim/swept_source.hpp"

#include <algorithm>
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

std::string_view to_string(SpectralShape shape) noexcept {
  switch (shape) {
    case SpectralShape::gaussian:
      return "gaussian";
    case SpectralShape::super_gaussian:
      return "super_gaussian";
    case SpectralShape::tabulated:
      return "tabulated";
  }
  return "unknown";
}

void SweptSourceConfig::validate() const {
  ioct::require_real_in_range("source.center_wavelength_nm", center_wavelength_nm, 400.0, 2000.0);
  ioct::require_real_in_range("source.sweep_bandwidth_nm", sweep_bandwidth_nm, 1.0,
                              0.5 * center_wavelength_nm);
  ioct::require_real_in_range("source.rolloff_6db_depth_mm", rolloff_6db_depth_mm, 0.0, 1000.0);
  switch (shape) {
    case SpectralShape::gaussian:
    case SpectralShape::super_gaussian:
      ioct::require_real_in_range("source.envelope_fwhm_nm", envelope_fwhm_nm,
                                  0.1 * sweep_bandwidth_nm, 4.0 * sweep_bandwidth_nm);
      if (shape == SpectralShape::super_gaussian) {
        ioct::require_real_in_range("source.super_gaussian_order", super_gaussian_order, 1.0, 20.0);
      }
      break;
    case SpectralShape::tabulated: {
      if (tabulated.size() < 2) {
        throw ioct::ConfigError("source.tabulated",
                                ioct::format_value(std::uint64_t{tabulated.size()}) + " points",
                                "a tabulated spectrum needs at least 2 points");
      }
      double peak = 0.0;
      for (std::size_t i = 0; i < tabulated.size(); ++i) {
        const std::string key = "source.tabulated[" + std::to_string(i) + "]";
        ioct::require_real_in_range(key + ".wavelength_nm", tabulated[i].wavelength_nm, 100.0,
                                    5000.0);
        ioct::require_real_in_range(key + ".power", tabulated[i].power, 0.0, 1e12);
        if (i > 0 && tabulated[i].wavelength_nm <= tabulated[i - 1].wavelength_nm) {
          throw ioct::ConfigError(key + ".wavelength_nm",
                                  ioct::format_value(tabulated[i].wavelength_nm),
                                  "wavelengths must increase from point to point");
        }
        peak = std::max(peak, tabulated[i].power);
      }
      if (peak <= 0.0) {
        throw ioct::ConfigError("source.tabulated", "all powers 0",
                                "at least one point needs a positive power");
      }
      break;
    }
    default:
      throw ioct::ConfigError("source.shape", ioct::format_value(std::uint64_t(shape)),
                              "must be gaussian, super_gaussian or tabulated");
  }
}

double SweptSourceConfig::k_min() const noexcept {
  return wavenumber_per_um(center_wavelength_nm + 0.5 * sweep_bandwidth_nm);
}

double SweptSourceConfig::k_max() const noexcept {
  return wavenumber_per_um(center_wavelength_nm - 0.5 * sweep_bandwidth_nm);
}

double SweptSourceConfig::axial_pixel_um() const noexcept {
  return std::numbers::pi / (k_max() - k_min());
}

double SweptSourceConfig::power_at_k(double k) const noexcept {
  if (shape == SpectralShape::tabulated) {
    const double wavelength = 2.0 * std::numbers::pi / k * 1e3;
    if (tabulated.empty() || wavelength < tabulated.front().wavelength_nm ||
        wavelength > tabulated.back().wavelength_nm) {
      return 0.0;
    }
    double peak = 0.0;
    for (const SpectrumPoint& point : tabulated) peak = std::max(peak, point.power);
    const auto upper = std::upper_bound(
        tabulated.begin(), tabulated.end(), wavelength,
        [](double w, const SpectrumPoint& point) { return w < point.wavelength_nm; });
    if (upper == tabulated.end()) return tabulated.back().power / peak;
    const auto lower = upper - 1;
    const double f =
        (wavelength - lower->wavelength_nm) / (upper->wavelength_nm - lower->wavelength_nm);
    return ((1.0 - f) * lower->power + f * upper->power) / peak;
  }
  const double k_center = wavenumber_per_um(center_wavelength_nm);
  const double k_fwhm = wavenumber_per_um(center_wavelength_nm - 0.5 * envelope_fwhm_nm) -
                        wavenumber_per_um(center_wavelength_nm + 0.5 * envelope_fwhm_nm);
  const double u = std::abs(2.0 * (k - k_center) / k_fwhm);
  const double order = shape == SpectralShape::gaussian ? 2.0 : super_gaussian_order;
  return std::exp(-std::numbers::ln2 * std::pow(u, order));
}

std::vector<float> SweptSourceConfig::envelope(std::uint32_t samples) const {
  const double k_step = (k_max() - k_min()) / samples;
  std::vector<float> row(samples);
  for (std::uint32_t i = 0; i < samples; ++i) {
    row[i] = static_cast<float>(power_at_k(k_min() + i * k_step));
  }
  return row;
}

double SweptSourceConfig::rolloff_at_mm(double depth_mm) const noexcept {
  if (rolloff_6db_depth_mm <= 0.0) return 1.0;
  const double r = depth_mm / rolloff_6db_depth_mm;
  return std::exp2(-r * r);
}

}  // namespace ioct::sim
