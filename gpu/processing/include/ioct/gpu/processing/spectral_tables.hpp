// Everything the chain applies per sample, tabulated once per geometry and shared by the CPU and
// CUDA implementations, so both start their FFTs from the same float values:
//
//   spectrum[j] = resampled(raw)[j] * window[j] - windowed_background[j]      (real)
//   spectrum[j] *= correction[j]                       (complex, only with dispersion)
//
// where resampled(v)[j] = sum_t weight[j][t] * v[first[j] + t] (or v[j] without resampling) and
// windowed_background[j] = resampled(background)[j] * window[j]. The window is applied on the
// k-linear samples, after resampling.
#pragma once

#include <complex>
#include <cstdint>
#include <span>
#include <vector>

#include "ioct/gpu/processing/db_scale.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/gpu/processing/resampling.hpp"

namespace ioct::gpu {

struct SpectralTables {
  std::uint32_t samples = 0;
  std::uint32_t depth = 0;  // samples / 2: the positive depths kept
  std::vector<float> window;
  ResamplingTable resampling;                   // taps == 0: none
  std::vector<std::complex<float>> correction;  // exp(-i phi); empty: no dispersion
  DbToU8 scale;                                 // from the window's sum

  bool complex_fft() const noexcept { return !correction.empty(); }
  // The u8 mapping for another dB range (validated; ConfigError).
  void set_db_range(const DbScaleConfig& config);

  // resampled(values)[j], in the order both implementations sum it.
  float resampled(const float* values, std::uint32_t j) const noexcept {
    if (resampling.taps == 0) return values[j];
    const float* w = resampling.weights.data() + std::size_t{j} * resampling.taps;
    const float* v = values + resampling.first[j];
    float sum = w[0] * v[0];
    for (std::uint32_t t = 1; t < resampling.taps; ++t) sum += w[t] * v[t];
    return sum;
  }

  // spectrum[j] before the dispersion correction, from the raw values as float: the one place
  // both the chain and the dispersion estimator compute it.
  float spectrum_value(const float* values, const float* windowed_background,
                       std::uint32_t j) const noexcept {
    return resampled(values, j) * window[j] - windowed_background[j];
  }

  // windowed_background[j] for every j from the background spectrum (raw sample order).
  void windowed_background(std::span<const float> background, std::span<float> out) const;
};

// Validates `config` against the sweep (ConfigError) and tabulates it.
SpectralTables make_spectral_tables(const OctProcessorConfig& config, std::uint32_t samples);

}  // namespace ioct::gpu
