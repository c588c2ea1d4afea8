// Precomputed fringes, so a spectrum costs a few multiply-adds per sample and reflector instead
// of a cosine.
//
// A reflector at depth z (in bins of the processed depth axis) adds, at k-linear sample i of N,
//     amplitude * envelope[i] * cos(2 pi i z / N),
// whose real FFT peaks at bin z. z is resolved to 1/kDepthFractions of a bin: z = bin + f/Q, and
//     cos(a + b) = cos a cos b - sin a sin b
// splits the fringe into a row for the whole bins (N/2 rows of cos and sin) and a row for the
// fraction (Q rows of envelope * cos and envelope * sin), all float and contiguous in i.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace ioct::sim {

// A depth as the tables resolve it: bin + fraction / FringeTables::kDepthFractions.
struct TableDepth {
  std::uint32_t bin = 0;
  std::uint32_t fraction = 0;
};

class FringeTables {
 public:
  static constexpr std::uint32_t kDepthFractions = 16;
  // Largest N the tables are built for: they take N * N * 4 bytes (7.6 MB at 1376, 64 MiB here).
  static constexpr std::uint32_t kMaxSamples = 4096;

  // N = envelope.size(), even and at most kMaxSamples.
  explicit FringeTables(std::span<const float> envelope);

  std::uint32_t samples() const noexcept { return samples_; }
  std::uint32_t depth_bins() const noexcept { return samples_ / 2; }

  // Whether a reflector at `depth_px` can be drawn: [0, depth_bins - 1].
  bool drawable(float depth_px) const noexcept {
    return depth_px >= 0.0f && depth_px <= static_cast<float>(depth_bins() - 1);
  }
  // The nearest depth the tables resolve; `depth_px` must be drawable().
  static TableDepth resolve(float depth_px) noexcept;
  static float depth_px(TableDepth depth) noexcept {
    return static_cast<float>(depth.bin) +
           static_cast<float>(depth.fraction) / static_cast<float>(kDepthFractions);
  }

  // acc[i] += amplitude * envelope[i] * cos(2 pi i depth / N) for i in [0, N).
  void add_fringe(float* acc, TableDepth depth, float amplitude) const noexcept;
  // Two fringes in one pass (the accumulator is read and written once).
  void add_fringe_pair(float* acc, TableDepth depth0, float amplitude0, TableDepth depth1,
                       float amplitude1) const noexcept;

 private:
  std::uint32_t samples_ = 0;
  std::vector<float> bin_cos_;       // [bin][i] cos(2 pi i bin / N)
  std::vector<float> bin_sin_;       // [bin][i] sin(2 pi i bin / N)
  std::vector<float> fraction_cos_;  // [fraction][i] envelope[i] cos(2 pi i (fraction/Q) / N)
  std::vector<float> fraction_sin_;  // [fraction][i] envelope[i] sin(2 pi i (fraction/Q) / N)
};

}  // namespace ioct::sim
