// Where in the sweep each recorded sample lies, and the calibration that maps it back to k.
//
// k-linear grid: sample j of N sits at k_j = k_min + j (k_max - k_min) / N. A k-clocked record
// (ClockSource::external_k_clock) is sampled on that grid. A record on the digitizer's own clock
// (ClockSource::internal) is linear in time, and the source sweeps linearly in wavelength, so
// its samples are evenly spaced in lambda between the k-linear grid's first and last points:
//     lambda_i = lambda(k_0) + i (lambda(k_{N-1}) - lambda(k_0)) / (N - 1).
// Both records span the same k_0 .. k_{N-1}, so after resampling the depth axis is the same.
//
// The calibration follows the processing chain's convention (gpu/ resampling.hpp): output
// k-linear sample j of N is read at raw sample position
//     x(j) = (N - 1) * (c0 + c1 t + c2 t^2 + ...),   t = j / (N - 1),
// so {0, 1} is the identity (the k-clock). For the lambda-linear sweep the coefficients are a
// least-squares fit of degree kCalibrationDegree to the exact map.
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/hal/digitizer_config.hpp"
#include "ioct/sim/swept_source.hpp"

namespace ioct::sim {

inline constexpr std::uint32_t kCalibrationDegree = 7;  // 8 coefficients

struct KCalibration {
  std::vector<double> coefficients{0.0, 1.0};  // c0, c1, ... of x(t) / (N - 1), see above
  double max_error_samples = 0.0;              // largest |fit - exact| over the sweep, samples
  double k_first_rad_per_um = 0.0;             // k of k-linear sample 0
  double k_step_rad_per_um = 0.0;              // k-linear grid step

  // Raw position x(j) of k-linear sample j of `samples`.
  double raw_position(std::uint32_t samples, double j) const noexcept;
};

struct SpectralSampling {
  // k-linear index (fractional) of each raw sample: k_i = k_min + k_index[i] * step.
  std::vector<double> k_index;
  // Wavelength of each raw sample, nm.
  std::vector<double> wavelength_nm;
  KCalibration calibration;
  bool k_linear = true;
};

// The sampling of a record of `samples` from `source` on `clock`.
SpectralSampling spectral_sampling(const SweptSourceConfig& source, hal::ClockSource clock,
                                   std::uint32_t samples);

}  // namespace ioct::sim
