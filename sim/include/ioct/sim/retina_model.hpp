// A layered, curved retina seen through the scanner: for a beam position, the depth and
// reflectivity of each reflecting interface.
//
// Depths are in bins of the processed depth axis (px; one bin is the source's axial pixel of
// optical path). The RPE follows a gentle bowl (the eye's curvature) with a tilt; the layers above
// it have physical thicknesses (times the tissue's group index), and the inner layers (NFL to OPL)
// thin out into the foveal pit.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "ioct/hal/raster_scan.hpp"

namespace ioct::sim {

enum class RetinalInterface : std::uint32_t {
  ilm,      // inner limiting membrane: vitreous / nerve fibre layer
  nfl_gcl,  // nerve fibre layer / ganglion cell layer
  ipl_inl,  // inner plexiform / inner nuclear layer
  opl_onl,  // outer plexiform / outer nuclear layer
  is_os,    // photoreceptor inner / outer segment junction
  rpe,      // retinal pigment epithelium
  choroid,  // choroid / sclera
};
inline constexpr std::size_t kRetinalInterfaces = 7;

std::string_view to_string(RetinalInterface interface) noexcept;

struct RetinaConfig {
  double field_half_width_mm = 3.0;  // retina under scan units +-1
  // Depths relative to the depth axis, so the retina sits alike at any samples_per_ascan.
  double rpe_depth_fraction = 0.62;  // RPE depth at the field centre
  double curvature_fraction = 0.05;  // how much shallower the RPE lies at radius 1 (scan units)
  double tilt_x_fraction = 0.012;    // RPE depth change from the centre to x = +1
  double tilt_y_fraction = -0.008;   // ... and to y = +1
  double fovea_x = 0.06;             // foveal centre, scan units
  double fovea_y = -0.04;
  double fovea_radius_mm = 0.55;  // width (sigma) of the pit
  double foveal_pit_depth = 0.9;  // share of the inner retina missing at the pit's centre
  double tissue_index = 1.38;     // group index that turns thickness into optical path
  double speckle_contrast = 0.5;  // 0: every A-scan sees an interface alike; 1: full Rayleigh

  // Throws ioct::ConfigError ("retina.<key>").
  void validate() const;
};

struct InterfaceSample {
  float depth_px = 0.0f;
  float reflectivity = 0.0f;  // fringe amplitude relative to the brightest interface (RPE = 1)
};

using RetinaColumn = std::array<InterfaceSample, kRetinalInterfaces>;

class RetinaModel {
 public:
  // axial_pixel_um: optical path per depth bin (SweptSourceConfig::axial_pixel_um());
  // depth_bins: length of the processed depth axis (samples_per_ascan / 2).
  RetinaModel(const RetinaConfig& config, double axial_pixel_um, std::uint32_t depth_bins);

  // The interfaces under the beam, top (ILM) to bottom (choroid), without speckle.
  RetinaColumn column(hal::BeamPosition beam) const noexcept;

  const RetinaConfig& config() const noexcept { return config_; }

 private:
  RetinaConfig config_;
  double um_to_px_ = 0.0;  // physical micrometres of tissue to depth bins
  double depth_bins_ = 0.0;
};

}  // namespace ioct::sim
