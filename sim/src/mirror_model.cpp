#include "ioct/sim/mirror_model.hpp"

#include <cmath>
#include <numbers>

#include "ioct/common/config_error.hpp"

namespace ioct::sim {

void MirrorConfig::validate() const {
  ioct::require_real_in_range("mirror.field_half_width_mm", field_half_width_mm, 0.1, 20.0);
  ioct::require_real_in_range("mirror.depth_fraction", depth_fraction, 0.0, 1.0);
  ioct::require_real_in_range("mirror.tilt_x_fraction", tilt_x_fraction, -1.0, 1.0);
  ioct::require_real_in_range("mirror.tilt_y_fraction", tilt_y_fraction, -1.0, 1.0);
  ioct::require_real_in_range("mirror.reflectivity", reflectivity, 0.0, 100.0);
}

MirrorModel::MirrorModel(const MirrorConfig& config, double axial_pixel_um, double k_min_rad_per_um,
                         std::uint32_t depth_bins)
    : config_(config),
      axial_pixel_um_(axial_pixel_um),
      k_min_(k_min_rad_per_um),
      depth_bins_(depth_bins) {}

float MirrorModel::depth_px(hal::BeamPosition beam) const noexcept {
  return static_cast<float>(depth_bins_ *
                            (config_.depth_fraction + config_.tilt_x_fraction * beam.x +
                             config_.tilt_y_fraction * beam.y));
}

ColumnTruth MirrorModel::draw(hal::BeamPosition beam, std::uint64_t,
                              DepthProfile& profile) const noexcept {
  const float depth = depth_px(beam);
  const double z_um = profile.drawn_depth(depth) * axial_pixel_um_;
  const double phase = std::fmod(2.0 * k_min_ * z_um, 2.0 * std::numbers::pi);
  profile.add_reflector_with_phase(depth, static_cast<float>(config_.reflectivity),
                                   static_cast<float>(phase));
  return {};
}

}  // namespace ioct::sim
