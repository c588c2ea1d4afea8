// The anterior segment seen from above: cornea (epithelium, Bowman's layer, stroma, Descemet's
// membrane and endothelium), the clear anterior chamber, the iris (opaque: it shadows the lens
// behind it) and the lens within the pupil.
//
// Surfaces are spheres about the corneal apex; depths below the apex are physical mm converted to
// optical path along the vertical beam with each medium's group index (air above the cornea).
// The corneal and lens surfaces reflect specularly near the apex (the bright central reflex of
// real anterior-segment OCT). No refraction is modelled. The default depth axis (3.86 mm of
// optical path at 1376 samples) reaches the lens at the centre only for a shallow chamber; use
// 2752 samples for the full chamber.
#pragma once

#include <cstdint>

#include "ioct/sim/sample_model.hpp"

namespace ioct::sim {

struct AnteriorSegmentConfig {
  double field_half_width_mm = 5.0;
  double apex_depth_fraction = 0.05;  // corneal apex on the depth axis
  double apex_x = 0.0;                // scan units
  double apex_y = 0.0;
  double cornea_anterior_radius_mm = 7.8;
  double cornea_posterior_radius_mm = 6.5;
  double cornea_thickness_um = 540.0;
  double chamber_depth_mm = 2.6;  // corneal apex (epithelium) to the lens
  double pupil_radius_mm = 2.0;
  double iris_root_radius_mm = 5.6;
  double iris_thickness_um = 400.0;
  double lens_anterior_radius_mm = 10.0;
  double speckle_contrast = 0.3;

  // Throws ioct::ConfigError ("anterior.<key>").
  void validate() const;
};

// Where the surfaces lie under one beam position (px; NaN where absent).
struct AnteriorColumn {
  float epithelium_px;  // anterior corneal surface
  float bowman_px;
  float endothelium_px;  // posterior corneal surface
  float iris_front_px;
  float iris_back_px;
  float lens_px;           // anterior lens capsule
  float surface_tilt_rad;  // angle of the corneal surface's normal to the beam
};

class AnteriorSegmentModel final : public SampleModel {
 public:
  AnteriorSegmentModel(const AnteriorSegmentConfig& config, double axial_pixel_um,
                       std::uint32_t depth_bins);

  SamplePreset preset() const noexcept override { return SamplePreset::anterior_segment; }
  double field_half_width_mm() const noexcept override { return config_.field_half_width_mm; }
  ColumnTruth draw(hal::BeamPosition beam, std::uint64_t lateral_key,
                   DepthProfile& profile) const noexcept override;
  // No retina: ILM and RPE are NaN.
  ColumnTruth layers(hal::BeamPosition) const noexcept override { return {}; }

  AnteriorColumn column(hal::BeamPosition beam) const noexcept;
  const AnteriorSegmentConfig& config() const noexcept { return config_; }

 private:
  AnteriorSegmentConfig config_;
  double px_per_mm_ = 0.0;  // depth px per mm of optical path
  double depth_bins_ = 0.0;
};

}  // namespace ioct::sim
