// The bench's calibration target: a flat mirror (optionally tilted) at a known depth. Its
// reflection has no speckle and the physical phase 2 k_min z, so a tilted mirror sweeps one
// clean reflector across depth within a B-scan (roll-off, dispersion and galvo tests), and a
// level one is removed by mean-spectrum background subtraction, as on a real bench.
#pragma once

#include <cstdint>

#include "ioct/sim/sample_model.hpp"

namespace ioct::sim {

struct MirrorConfig {
  double field_half_width_mm = 3.0;
  double depth_fraction = 0.3;   // depth of the mirror at the field centre, share of the axis
  double tilt_x_fraction = 0.0;  // depth change from the centre to x = +1, share of the axis
  double tilt_y_fraction = 0.0;
  double reflectivity = 1.0;

  // Throws ioct::ConfigError ("mirror.<key>").
  void validate() const;
};

class MirrorModel final : public SampleModel {
 public:
  // k_min_rad_per_um: the sweep's first wavenumber (the reflection's phase is 2 k_min z).
  MirrorModel(const MirrorConfig& config, double axial_pixel_um, double k_min_rad_per_um,
              std::uint32_t depth_bins);

  SamplePreset preset() const noexcept override { return SamplePreset::mirror; }
  double field_half_width_mm() const noexcept override { return config_.field_half_width_mm; }
  ColumnTruth draw(hal::BeamPosition beam, std::uint64_t lateral_key,
                   DepthProfile& profile) const noexcept override;
  ColumnTruth layers(hal::BeamPosition) const noexcept override { return {}; }

  // The mirror's depth under `beam`, px.
  float depth_px(hal::BeamPosition beam) const noexcept;
  const MirrorConfig& config() const noexcept { return config_; }

 private:
  MirrorConfig config_;
  double axial_pixel_um_;
  double k_min_;
  double depth_bins_;
};

}  // namespace ioct::sim
