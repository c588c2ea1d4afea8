#include "ioct/gpu/live_stages/render_filter.hpp"

namespace ioct::gpu::live {

bool renders_from_bscan_median(render::RenderMode mode) noexcept {
  switch (mode) {
    case render::RenderMode::layer_aware:
    case render::RenderMode::la_mip_composite:
    case render::RenderMode::axial_colorization:
      return true;
    case render::RenderMode::basic:
    case render::RenderMode::enhanced:
    case render::RenderMode::bscan_slice:
    case render::RenderMode::en_face_slice:
      return false;
  }
  return false;
}

filters::VolumeFilterConfig render_filter_for(
    render::RenderMode mode, const filters::VolumeFilterConfig& segmentation_filter) {
  if (!renders_from_bscan_median(mode)) return segmentation_filter;
  return filters::filter_by_name("stages.filter", "median-bscan");
}

}  // namespace ioct::gpu::live
