// The swept laser source as the k-clocked digitizer sees it: samples evenly spaced in wavenumber
// across the sweep, weighted by a Gaussian spectral envelope.
#pragma once

#include <cstdint>
#include <vector>

namespace ioct::sim {

struct SweptSourceConfig {
  double center_wavelength_nm = 1060.0;
  double sweep_bandwidth_nm = 100.0;  // wavelength span the k-clocked samples cover
  double envelope_fwhm_nm = 70.0;     // full width at half maximum of the Gaussian envelope

  // Throws ioct::ConfigError ("source.<key>").
  void validate() const;

  // Optical path length (in air, single pass) that one depth bin of an N-sample FFT spans:
  // pi / (k_max - k_min), independent of N. 1060 nm / 100 nm gives 5.62 um.
  double axial_pixel_um() const noexcept;

  // Spectral envelope at each of `samples` k-linear samples, peak 1 at the centre wavelength.
  std::vector<float> envelope(std::uint32_t samples) const;
};

}  // namespace ioct::sim
