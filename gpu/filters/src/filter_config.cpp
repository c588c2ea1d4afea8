#include "ioct/gpu/filters/filter_config.hpp"

#include "ioct/common/config_error.hpp"

namespace ioct::gpu::filters {

void VolumeFilterConfig::validate() const {
  require_real_in_range("gaussian_sigma", gaussian_sigma, 0.2, 10.0);
}

}  // namespace ioct::gpu::filters
