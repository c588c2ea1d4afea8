// What the beam looks at: a sample model draws the complex reflectivity under a beam position
// into a DepthProfile and says where its reference layers are.
//
// Depths are px of the processed depth axis (samples / 2 of them); one px is the source's axial
// pixel of optical path (SweptSourceConfig::axial_pixel_um()). Lateral positions are scan units:
// [-1, 1] spans the field, field_half_width_mm() on each side of the centre.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string_view>

#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/depth_profile.hpp"

namespace ioct::sim {

enum class SamplePreset {
  retina,            // layered, curved retina with a foveal pit (RetinaConfig)
  anterior_segment,  // cornea, anterior chamber, iris, lens (AnteriorSegmentConfig)
  mirror,            // a flat (optionally tilted) mirror: the bench's calibration target
};

std::string_view to_string(SamplePreset preset) noexcept;

// Where the ground-truth layers are in one A-scan, as drawn (on the profile's grid); NaN where a
// layer is absent or outside the depth axis.
struct ColumnTruth {
  float ilm_px = std::numeric_limits<float>::quiet_NaN();
  float rpe_px = std::numeric_limits<float>::quiet_NaN();
};

class SampleModel {
 public:
  virtual ~SampleModel() = default;

  virtual SamplePreset preset() const noexcept = 0;
  virtual double field_half_width_mm() const noexcept = 0;

  // Draws the sample under `beam` into `profile`, whose column has been begun (and may carry an
  // instrument's occlusion). `lateral_key` identifies the tissue under the beam: the same key
  // gives the same speckle. Returns where the truth layers were drawn.
  virtual ColumnTruth draw(hal::BeamPosition beam, std::uint64_t lateral_key,
                           DepthProfile& profile) const noexcept = 0;
  // Where the truth layers lie under `beam` (continuous depths, not on a grid).
  virtual ColumnTruth layers(hal::BeamPosition beam) const noexcept = 0;
};

}  // namespace ioct::sim
