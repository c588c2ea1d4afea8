// How far segmented surfaces lie from a reference, per A-scan: mean absolute error, percentiles
// and how many reference A-scans got no surface at all.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace ioct::seg_test {

// What every simulated scene is held to, over every A-scan (px): the ILM and RPE mean and 99th
// percentile errors, and the RPE nowhere further off, shadowed A-scans beside an instrument
// included (a fit there is either right or bridged from fits that are).
inline constexpr double kMaxMeanError = 1.0;
inline constexpr double kMaxP99 = 3.0;
inline constexpr double kMaxRpeError = 8.0;

struct SurfaceErrors {
  std::size_t compared = 0;  // A-scans where both are finite
  std::size_t missing = 0;   // reference finite, surface NaN
  double mean_absolute = 0.0;
  double p99 = 0.0;
  double max = 0.0;
  double median = 0.0;
  std::size_t worst = 0;  // index of the largest error (surface order)

  std::string describe() const;
};

// Over the A-scans where `reference` is finite (and `include`, when given, is true).
SurfaceErrors surface_errors(std::span<const float> surface, std::span<const float> reference,
                             const std::vector<bool>* include = nullptr);

}  // namespace ioct::seg_test
