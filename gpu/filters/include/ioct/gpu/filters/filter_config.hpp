// What the volume filters do: the first paper's 3x3x3 median (edge-preserving de-noising) followed
// by a 5x5 Gaussian in the plane of each B-scan (smoothing), either of which can be switched off.
#pragma once

namespace ioct::gpu::filters {

struct VolumeFilterConfig {
  bool median = true;
  bool gaussian = true;
  // Standard deviation of the Gaussian in pixels, the same along A-scans and along depth. The
  // 5x5 window spans +-2 sigma at the default 1.0 (the weights are renormalised over the window:
  // 0.054, 0.244, 0.403, 0.244, 0.054), enough to smooth speckle grain of 1-2 px without
  // blurring the retinal layers, which are 5-20 px thick at the default geometry.
  double gaussian_sigma = 1.0;

  // Throws ConfigError: gaussian_sigma in [0.2, 10] (below 0.2 the outer taps round to 0 and the
  // filter is the identity; above 10 it is a 5x5 box).
  void validate() const;
};

}  // namespace ioct::gpu::filters
