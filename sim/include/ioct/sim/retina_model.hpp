// A layered, curved retina seen through the scanner.
//
// Eleven layers from the vitreous down: NFL, GCL, IPL, INL, OPL, ONL, inner segments, outer
// segments, RPE, choroid, sclera, with thin bright lines at the ILM, ELM, IS/OS (ellipsoid zone),
// the interdigitation zone and the RPE. Every layer scatters (speckle of its own brightness and
// attenuation), so the layers look textured, not only their boundaries. The RPE follows a gentle
// bowl (the eye's curvature) with a tilt; the layers above it have physical thicknesses (times the
// tissue's group index); the inner layers thin out into the foveal pit while the outer nuclear
// layer and the outer segments thicken there. Optional: a full-thickness macular hole with a
// thickened, cystic cuff, an epiretinal membrane, partly adherent, partly lifted, and an optic
// disc, where the retina thins to the nerve head and its surface dips into a cup.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/sample_model.hpp"

namespace ioct::sim {

enum class RetinalLayer : std::uint32_t {
  nfl,      // nerve fibre layer (below the ILM)
  gcl,      // ganglion cell layer
  ipl,      // inner plexiform layer
  inl,      // inner nuclear layer
  opl,      // outer plexiform layer
  onl,      // outer nuclear layer (and Henle fibres)
  is,       // photoreceptor inner segments (below the ELM)
  os,       // outer segments (below the IS/OS line)
  rpe,      // retinal pigment epithelium
  choroid,  // choroid, with dark vessel lumens
  sclera,
};
inline constexpr std::size_t kRetinalLayers = 11;

std::string_view to_string(RetinalLayer layer) noexcept;

struct MacularHoleConfig {
  bool enabled = false;
  double radius_mm = 0.2;        // the hole's radius at the RPE (centred on the fovea)
  double cuff_width_mm = 0.35;   // thickened, cystic rim around it
  double cuff_height_um = 90.0;  // extra thickness at the hole's edge
  double cyst_fraction = 0.45;   // share of the cuff's INL/ONL cells that are fluid-filled
};

struct EpiretinalMembraneConfig {
  bool enabled = false;
  double center_x = -0.35;  // scan units
  double center_y = 0.2;
  double radius_mm = 1.2;
  double thickness_um = 8.0;
  double lift_um = 45.0;     // how far the wrinkles rise above the ILM
  double wrinkle_mm = 0.35;  // wrinkle period
  double reflectivity = 0.55;
};

// The optic nerve head: inside `radius_mm` (the opening in Bruch's membrane) there is no RPE, no
// choroid and no outer retina; nerve fibres fill it from the surface down. Over the `margin_mm`
// outside it the layers below the NFL thin to nothing while the NFL takes their place (the ILM
// stays continuous); inside, the surface dips into a cup of `cup_depth_um` at the centre, with
// cosine-shaped walls out to `cup_radius_mm`.
struct OpticDiscConfig {
  bool enabled = false;
  double center_x = 0.7;  // scan units
  double center_y = 0.0;
  double radius_mm = 0.8;
  double margin_mm = 0.3;
  double cup_radius_mm = 0.55;
  double cup_depth_um = 200.0;
  double nerve_scatter = 0.6;  // the nerve head's scatter, relative to the NFL's
};

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
  // Brightness fluctuation of the thin lines from A-scan to A-scan: 0 none, 1 full Rayleigh
  // speckle. (The layers' scatter is always fully developed speckle.)
  double speckle_contrast = 0.25;
  double scattering_gain = 1.0;  // scales the scatter of every layer against the lines
  // The NFL thickens away from the fovea: towards the optic disc (x > 0) and away from it.
  double nfl_growth_nasal_um_per_mm = 6.0;
  double nfl_growth_temporal_um_per_mm = 2.0;
  MacularHoleConfig macular_hole;
  EpiretinalMembraneConfig membrane;
  OpticDiscConfig disc;

  // Throws ioct::ConfigError ("retina.<key>").
  void validate() const;
};

// The boundaries under one beam position: the top of each layer and the bottom of the last, px.
struct RetinaColumn {
  std::array<float, kRetinalLayers + 1> top{};   // top[i]: top of layer i; top[11]: sclera bottom
  std::array<float, kRetinalLayers> presence{};  // 0 where a layer is absent (pit, hole)
  float ilm_px = 0.0f;                           // NaN inside a macular hole
  float rpe_px = 0.0f;                           // the RPE's bright line, mid-band; NaN in a disc
  float membrane_top_px = 0.0f;                  // NaN without a membrane here
  float membrane_bottom_px = 0.0f;
  float cuff = 0.0f;     // 0..1: how deep into a macular hole's cuff (cysts)
  bool in_disc = false;  // inside the optic disc: nerve head, no RPE
};

class RetinaModel final : public SampleModel {
 public:
  // axial_pixel_um: optical path per depth px; depth_bins: length of the depth axis.
  RetinaModel(const RetinaConfig& config, double axial_pixel_um, std::uint32_t depth_bins);

  SamplePreset preset() const noexcept override { return SamplePreset::retina; }
  double field_half_width_mm() const noexcept override { return config_.field_half_width_mm; }
  ColumnTruth draw(hal::BeamPosition beam, std::uint64_t lateral_key,
                   DepthProfile& profile) const noexcept override;
  ColumnTruth layers(hal::BeamPosition beam) const noexcept override;

  // The layer boundaries under the beam, without speckle.
  RetinaColumn column(hal::BeamPosition beam) const noexcept;
  const RetinaConfig& config() const noexcept { return config_; }
  // Physical micrometres of tissue per depth px.
  double tissue_um_per_px() const noexcept { return 1.0 / um_to_px_; }

 private:
  RetinaConfig config_;
  double um_to_px_ = 0.0;  // physical micrometres of tissue to depth px
  double depth_bins_ = 0.0;
};

}  // namespace ioct::sim
