// Order statistics of u8 values by their histogram: the B-scan's background level and the
// typical contrasts, defined so that the CPU (one pass) and CUDA (shared-memory atomics) agree.
#pragma once

#include <cstdint>

#include "ioct/gpu/cuda/host_device_function.hpp"

namespace ioct::gpu::segmentation::detail {

inline constexpr int kHistogramBins = 256;

// The smallest value v whose cumulative count reaches numerator / denominator of `count`
// (count * numerator <= cumulative * denominator); 0 for no values.
IOCT_HD int histogram_quantile(const std::uint32_t* histogram, std::uint32_t count,
                               std::uint32_t numerator, std::uint32_t denominator) {
  if (count == 0) return 0;
  std::uint64_t cumulative = 0;
  for (int v = 0; v < kHistogramBins; ++v) {
    cumulative += histogram[v];
    if (cumulative * denominator >= std::uint64_t{count} * numerator) return v;
  }
  return kHistogramBins - 1;
}

// The background of a B-scan: the 30th percentile of every kFloorSampleStride-th px (of the
// B-scan's px in memory order). Most of a B-scan is vitreous or below the choroid, so this is a
// level of the empty image whatever the u8 mapping; a sample of 1 px in 16 is plenty for it.
inline constexpr std::uint32_t kFloorNumerator = 3;
inline constexpr std::uint32_t kFloorDenominator = 10;
inline constexpr std::uint32_t kFloorSampleStride = 16;

IOCT_HD int clamp_u8(int v) {
  return v < 0 ? 0 : (v > 255 ? 255 : v);
}

}  // namespace ioct::gpu::segmentation::detail
