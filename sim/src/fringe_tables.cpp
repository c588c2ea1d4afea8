#include "ioct/sim/fringe_tables.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace ioct::sim {

FringeTables::FringeTables(std::span<const float> envelope)
    : samples_(static_cast<std::uint32_t>(envelope.size())) {
  if (samples_ < 2 || samples_ % 2 != 0 || samples_ > kMaxSamples) {
    throw std::invalid_argument("fringe tables: " + std::to_string(envelope.size()) +
                                " samples; need an even count in [2, " +
                                std::to_string(kMaxSamples) + "]");
  }
  const std::size_t n = samples_;
  bin_cos_.resize(depth_bins() * n);
  bin_sin_.resize(depth_bins() * n);
  for (std::size_t bin = 0; bin < depth_bins(); ++bin) {
    for (std::size_t i = 0; i < n; ++i) {
      // The phase is reduced exactly in integers before it becomes a float angle.
      const double phase =
          2.0 * std::numbers::pi * static_cast<double>((i * bin) % n) / static_cast<double>(n);
      bin_cos_[bin * n + i] = static_cast<float>(std::cos(phase));
      bin_sin_[bin * n + i] = static_cast<float>(std::sin(phase));
    }
  }
  fraction_cos_.resize(kDepthFractions * n);
  fraction_sin_.resize(kDepthFractions * n);
  for (std::size_t f = 0; f < kDepthFractions; ++f) {
    for (std::size_t i = 0; i < n; ++i) {
      const double phase = 2.0 * std::numbers::pi * static_cast<double>(i) *
                           (static_cast<double>(f) / kDepthFractions) / static_cast<double>(n);
      fraction_cos_[f * n + i] = static_cast<float>(envelope[i] * std::cos(phase));
      fraction_sin_[f * n + i] = static_cast<float>(envelope[i] * std::sin(phase));
    }
  }
}

TableDepth FringeTables::resolve(float depth_px) noexcept {
  const auto steps = static_cast<std::uint32_t>(std::lround(depth_px * kDepthFractions));
  return {steps / kDepthFractions, steps % kDepthFractions};
}

void FringeTables::add_fringe(float* __restrict acc, TableDepth depth,
                              float amplitude) const noexcept {
  const std::size_t n = samples_;
  const float* __restrict c = bin_cos_.data() + depth.bin * n;
  const float* __restrict s = bin_sin_.data() + depth.bin * n;
  const float* __restrict fc = fraction_cos_.data() + depth.fraction * n;
  const float* __restrict fs = fraction_sin_.data() + depth.fraction * n;
  for (std::size_t i = 0; i < n; ++i) {
    acc[i] += amplitude * (c[i] * fc[i] - s[i] * fs[i]);
  }
}

void FringeTables::add_fringe_pair(float* __restrict acc, TableDepth depth0, float amplitude0,
                                   TableDepth depth1, float amplitude1) const noexcept {
  const std::size_t n = samples_;
  const float* __restrict c0 = bin_cos_.data() + depth0.bin * n;
  const float* __restrict s0 = bin_sin_.data() + depth0.bin * n;
  const float* __restrict fc0 = fraction_cos_.data() + depth0.fraction * n;
  const float* __restrict fs0 = fraction_sin_.data() + depth0.fraction * n;
  const float* __restrict c1 = bin_cos_.data() + depth1.bin * n;
  const float* __restrict s1 = bin_sin_.data() + depth1.bin * n;
  const float* __restrict fc1 = fraction_cos_.data() + depth1.fraction * n;
  const float* __restrict fs1 = fraction_sin_.data() + depth1.fraction * n;
  for (std::size_t i = 0; i < n; ++i) {
    acc[i] += amplitude0 * (c0[i] * fc0[i] - s0[i] * fs0[i]) +
              amplitude1 * (c1[i] * fc1[i] - s1[i] * fs1[i]);
  }
}

}  // namespace ioct::sim
