// What the volume filters do: the first paper's 3x3x3 median (edge-preserving de-noising) followed
// by a 5x5 Gaussian in the plane of each B-scan (smoothing), either of which can be switched off;
// or the second paper's 3x3 median within each B-scan and no Gaussian.
#pragma once

#include <cstdint>
#include <string_view>

namespace ioct::gpu::filters {

// The median's neighbourhood: 3x3x3 (A-scans, depth and the neighbouring B-scans; Viehland et al.
// 2016), or 3x3 within each B-scan (Weiss et al. 2019, Sec. 4: "a 3x3 median filter on every
// B-Scan but [no] volumetric Gaussian smoothing", to keep small superficial structure).
enum class MedianWindow : std::uint8_t { volume_3x3x3, bscan_3x3 };

struct VolumeFilterConfig {
  bool median = true;
  MedianWindow median_window = MedianWindow::volume_3x3x3;
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

// The filters by the names the commands take (`--filter`): "median-gauss" (the first paper's, the
// default), "median-bscan" (the second paper's) and "none". ConfigError naming `key` otherwise.
VolumeFilterConfig filter_by_name(std::string_view key, std::string_view name);
// The name of a config's filter: one of the above, or a description of another combination.
std::string_view filter_name(const VolumeFilterConfig& config) noexcept;

}  // namespace ioct::gpu::filters
