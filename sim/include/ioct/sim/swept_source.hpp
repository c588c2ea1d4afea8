// The swept laser source: its sweep in wavenumber, its spectral shape and its coherence, which
// sets the sensitivity roll-off with depth.
//
// The sweep runs from k_min (the long-wavelength end) to k_max. A k-clocked record samples it at
// k_min + i (k_max - k_min) / N, i in [0, N): evenly in k, increasing with i. One depth px of a
// plain N-point FFT of such a record is pi / (k_max - k_min) of optical path (axial_pixel_um()).
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

namespace ioct::sim {

enum class SpectralShape {
  gaussian,        // Gaussian in k of envelope_fwhm_nm
  super_gaussian,  // exp(-ln2 |2 (k - k_c) / fwhm|^order): flatter top, steeper edges
  tabulated,       // measured spectrum: points (wavelength, power), linear between them
};

std::string_view to_string(SpectralShape shape) noexcept;

struct SpectrumPoint {
  double wavelength_nm = 0.0;
  double power = 0.0;  // relative; the table is scaled to a peak of 1
};

struct SweptSourceConfig {
  double center_wavelength_nm = 1060.0;
  double sweep_bandwidth_nm = 100.0;  // wavelength span the sweep covers
  SpectralShape shape = SpectralShape::gaussian;
  double envelope_fwhm_nm = 70.0;        // full width at half maximum (gaussian, super_gaussian)
  double super_gaussian_order = 4.0;     // 2 is a Gaussian
  std::vector<SpectrumPoint> tabulated;  // shape tabulated: increasing wavelengths
  // Optical path (in air, single pass) at which the fringe amplitude has fallen to one half
  // (-6 dB): the source's finite coherence. Gaussian in depth. 0 turns roll-off off.
  double rolloff_6db_depth_mm = 3.9;

  // Throws ioct::ConfigError ("source.<key>").
  void validate() const;

  // Wavenumbers of the sweep's ends, rad/um.
  double k_min() const noexcept;
  double k_max() const noexcept;
  // Optical path length (in air, single pass) that one depth px of an N-sample k-linear FFT
  // spans: pi / (k_max - k_min), independent of N. 1060 nm / 100 nm gives 5.62 um.
  double axial_pixel_um() const noexcept;

  // Relative power at wavenumber k (rad/um), peak 1.
  double power_at_k(double k) const noexcept;
  // Spectral envelope at each of `samples` k-linear samples, peak 1 at the centre wavelength.
  std::vector<float> envelope(std::uint32_t samples) const;
  // Fringe amplitude factor of a reflector `depth_mm` of optical path deep: 2^-(d / d6)^2.
  double rolloff_at_mm(double depth_mm) const noexcept;
};

}  // namespace ioct::sim
