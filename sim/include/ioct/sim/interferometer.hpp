// The interferometer between source and detector: what the two arms do to the fringes besides
// the sample. Here the dispersion mismatch between the arms (glass, water), which adds a phase
// that grows nonlinearly with wavenumber and blurs every layer axially.
//
// Convention (the processing chain's, gpu/ dispersion.hpp): over the k-linear sweep,
//     t = 2 j / (N - 1) - 1 in [-1, 1] for k-linear sample j of N,
//     phi(t) = c2 t^2 + c3 t^3   (radians at the sweep's ends),
// and the positive-depth part of every fringe carries exp(+i phi). Multiplying the spectrum by
// exp(-i phi) with the same c2 and c3 undoes it exactly.
#pragma once

#include <cstdint>

namespace ioct::sim {

struct InterferometerConfig {
  double dispersion_c2 = 0.0;  // rad of quadratic phase at the sweep's ends
  double dispersion_c3 = 0.0;  // rad of cubic phase at the sweep's ends

  // Throws ioct::ConfigError ("interferometer.<key>").
  void validate() const;
  bool dispersive() const noexcept { return dispersion_c2 != 0.0 || dispersion_c3 != 0.0; }
  // phi at (fractional) k-linear index `k_index` of a sweep of `samples`.
  double dispersion_phase(double k_index, std::uint32_t samples) const noexcept;
};

}  // namespace ioct::sim
