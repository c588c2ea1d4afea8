// Numerical dispersion compensation: a mismatch of glass or water between the sample and the
// reference arm adds a phase error to the fringes that grows nonlinearly with wavenumber and
// blurs every layer axially. Multiplying each (background-free, windowed) spectrum by the
// opposite phase before the FFT restores the axial resolution.
//
// Phase model over the k-linear sweep, t = 2 j / (N - 1) - 1 in [-1, 1] for sample j of N:
//     phi(t) = c2 t^2 + c3 t^3   (radians at the sweep's ends; linear and constant terms only
//                                 shift or rotate the A-scan, so they are left out)
// A fringe at depth z whose positive-frequency part carries exp(+i phi) is corrected by
// multiplying the spectrum with exp(-i phi). With c2 = c3 = 0 nothing is done.
//
// Once multiplied by a complex phase the spectrum is no longer real, so its FFT is no longer
// Hermitian-symmetric: the chain then does a complex-to-complex FFT of N points and keeps the
// positive depths (bins 0 to N/2 - 1), where the corrected fringe sits; the mirror term at
// negative depths is dispersed twice and discarded. Without dispersion the cheaper real-to-complex
// FFT is used. ioct-dispersion estimates c2 and c3 from the data (dispersion_estimator.hpp).
#pragma once

#include <complex>
#include <cstdint>
#include <vector>

namespace ioct::gpu {

struct DispersionConfig {
  double c2 = 0.0;  // radians of quadratic phase at the sweep's ends
  double c3 = 0.0;  // radians of cubic phase at the sweep's ends

  bool enabled() const noexcept { return c2 != 0.0 || c3 != 0.0; }
  // Throws ConfigError("dispersion_c2" / "dispersion_c3"): finite, |c| <= 10000 rad.
  void validate() const;
};

// phi(t) at sample j of `samples` (see above).
double dispersion_phase(const DispersionConfig& config, std::uint32_t samples,
                        std::uint32_t j) noexcept;

// exp(-i phi) at every sample: the factor the spectrum is multiplied by. Empty when disabled.
std::vector<std::complex<float>> dispersion_correction(const DispersionConfig& config,
                                                       std::uint32_t samples);

}  // namespace ioct::gpu
