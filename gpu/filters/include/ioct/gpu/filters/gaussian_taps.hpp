// The 5-tap Gaussian in fixed point, so that the CPU and CUDA filters give the same u8 bits.
//
// The taps are exp(-i^2 / (2 sigma^2)), i = -2..2, normalised over the window and rounded to
// integers that sum to exactly 4096 (2^12). A B-scan pixel is
//   out = (sum_j t_j sum_i t_i in[a + j][d + i] + 2^23) >> 24
// (the separable sum: integer, so the order of summation does not matter), i.e. the 2-D
// convolution with the outer product of the taps, rounded half up. At most 255 * 2^24 + 2^23 fits
// in 32 bits. Against the exact real-valued Gaussian the result is within 1 u8 step: the taps'
// rounding moves the sum by at most 0.39 of a step for any sigma in [0.2, 10], the final rounding
// by 0.5.
#pragma once

#include <array>
#include <cstdint>

namespace ioct::gpu::filters {

struct GaussianTaps {
  static constexpr int kRadius = 2;
  static constexpr std::uint32_t kOne = 4096;  // sum of the taps
  static constexpr int kShift = 24;            // log2(kOne^2)
  std::array<std::uint32_t, 5> taps{};         // taps[i + 2] for offset i, symmetric
};

// Throws ConfigError for sigma outside [0.2, 10] or not finite.
GaussianTaps make_gaussian_taps(double sigma);

// The real-valued normalised taps the integers approximate (for tests and documentation).
std::array<double, 5> gaussian_taps_exact(double sigma);

}  // namespace ioct::gpu::filters
