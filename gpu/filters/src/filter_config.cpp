#include "ioct/gpu/filters/filter_config.hpp"

#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu::filters {

void VolumeFilterConfig::validate() const {
  require_real_in_range("gaussian_sigma", gaussian_sigma, 0.2, 10.0);
}

VolumeFilterConfig filter_by_name(std::string_view key, std::string_view name) {
  VolumeFilterConfig config;
  if (name == "median-gauss") return config;
  if (name == "median-bscan") {
    config.median_window = MedianWindow::bscan_3x3;
    config.gaussian = false;
    return config;
  }
  if (name == "none") {
    config.median = false;
    config.gaussian = false;
    return config;
  }
  throw ConfigError(std::string(key), "'" + std::string(name) + "'",
                    "must be median-gauss (3x3x3 median + 5x5 Gaussian), median-bscan (3x3 median "
                    "per B-scan) or none");
}

std::string_view filter_name(const VolumeFilterConfig& config) noexcept {
  const bool volume_median = config.median_window == MedianWindow::volume_3x3x3;
  if (config.median && volume_median && config.gaussian) return "median-gauss";
  if (config.median && !volume_median && !config.gaussian) return "median-bscan";
  if (!config.median && !config.gaussian) return "none";
  if (!config.median) return "gauss";
  if (volume_median) return "median";
  return "median-bscan+gauss";
}

}  // namespace ioct::gpu::filters
