#include "ioct/gpu/filters/gaussian_taps.hpp"

#include <cmath>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu::filters {

std::array<double, 5> gaussian_taps_exact(double sigma) {
  require_real_in_range("gaussian_sigma", sigma, 0.2, 10.0);
  std::array<double, 5> taps{};
  double sum = 0.0;
  for (int i = -GaussianTaps::kRadius; i <= GaussianTaps::kRadius; ++i) {
    taps[i + 2] = std::exp(-double(i * i) / (2.0 * sigma * sigma));
    sum += taps[i + 2];
  }
  for (double& tap : taps) tap /= sum;
  return taps;
}

GaussianTaps make_gaussian_taps(double sigma) {
  const std::array<double, 5> exact = gaussian_taps_exact(sigma);
  const auto fixed = [](double tap) {
    return static_cast<std::uint32_t>(std::lround(tap * GaussianTaps::kOne));
  };
  GaussianTaps result;
  const std::uint32_t outer = fixed(exact[0]);
  const std::uint32_t inner = fixed(exact[1]);
  // The centre takes what rounding left over, so the taps sum to exactly kOne and stay
  // symmetric; a constant region passes unchanged.
  result.taps = {outer, inner, GaussianTaps::kOne - 2 * (outer + inner), inner, outer};
  return result;
}

}  // namespace ioct::gpu::filters
