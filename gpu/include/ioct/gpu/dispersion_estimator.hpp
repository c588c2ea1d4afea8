// Automatic dispersion estimation: the c2, c3 (dispersion.hpp) that make the A-scans of a group
// sharpest.
//
// Sharpness metric: for each A-scan, the intensities I_d = |X_d|^2 of the positive depths
// (skipping the first `skip_depth` bins, where what is left of the background sits) give
//     S = sum_d I_d^2 / (sum_d I_d)^2
// (the inverse participation ratio: 1 / the number of bins the energy is spread over), and the
// metric is the mean of S over the A-scans used. A dispersed layer spreads its energy over many
// bins; compensated, the same energy gathers in a few, and S rises. Noise-only A-scans score
// about alike for every c2, c3, so the brightest A-scans of the group are used.
//
// Search: a grid over c2 (c3 = 0), then over c3, then a coordinate search that halves its step
// around the best point until the step is below `tolerance`. The metric is evaluated on the
// CPU (FFTW complex transforms of the chosen A-scans), about 2 ms per evaluation for 256
// A-scans of 1376 samples.
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/oct_processor.hpp"

namespace ioct::gpu {

struct DispersionSearch {
  double c2_limit = 200.0;  // c2 searched in [-c2_limit, c2_limit] radians
  double c3_limit = 100.0;  // c3 searched in [-c3_limit, c3_limit] radians
  std::uint32_t grid_points = 41;
  double tolerance = 0.02;       // radians: the final step of the coordinate search
  std::uint32_t ascans = 256;    // brightest A-scans used
  std::uint32_t skip_depth = 8;  // bins next to zero delay left out of the metric

  // Throws ConfigError naming the key.
  void validate() const;
};

struct DispersionEstimate {
  double c2 = 0.0;
  double c3 = 0.0;
  double sharpness = 0.0;                // metric at (c2, c3)
  double sharpness_uncompensated = 0.0;  // metric at (0, 0)
  std::uint32_t ascans_used = 0;
  std::uint32_t evaluations = 0;
};

class DispersionEstimator {
 public:
  // `processing` gives the background mode, resampling and window to apply first (its
  // dispersion is ignored). Throws ConfigError.
  DispersionEstimator(const OctProcessorConfig& processing, const DispersionSearch& search);

  // Picks the A-scans of `group` (header checked against `geometry`) and prepares their
  // background-free, windowed spectra. Throws std::invalid_argument for a group the chain
  // rejects and ConfigError for a config that does not fit the geometry.
  void load(const shm::RingGeometry& geometry, const RawGroup& group);

  // The metric at (c2, c3) over the loaded A-scans.
  double sharpness(double c2, double c3);

  // The search. Requires load().
  DispersionEstimate estimate();

 private:
  OctProcessorConfig processing_;
  DispersionSearch search_;
  std::uint32_t samples_ = 0;
  std::uint32_t ascans_ = 0;
  std::vector<float> spectra_;  // [ascan][sample], real
  std::uint32_t evaluations_ = 0;
};

}  // namespace ioct::gpu
