#include "ioct/sim/retina_model.hpp"

#include <cmath>

#include "ioct/common/config_error.hpp"

namespace ioct::sim {
namespace {

// The layer above each interface: its thickness (um, parafovea) and whether it belongs to the
// inner retina that the foveal pit removes. Reflectivities follow the usual appearance of a
// 1 um swept-source B-scan: RPE brightest, then IS/OS and ILM, plexiform boundaries weaker.
struct InterfaceShape {
  double thickness_above_um;
  bool inner;
  double reflectivity;
};
constexpr std::array<InterfaceShape, kRetinalInterfaces> kShapes{{
    {0.0, false, 0.8},    // ILM: the vitreous above
    {30.0, true, 0.45},   // NFL/GCL below a 30 um NFL
    {75.0, true, 0.35},   // IPL/INL below GCL + IPL
    {60.0, true, 0.4},    // OPL/ONL below INL + OPL
    {90.0, false, 0.75},  // IS/OS below ONL + inner segments
    {40.0, false, 1.0},   // RPE below the outer segments
    {0.0, false, 0.25},   // choroid/sclera: placed below the RPE, see kChoroidThicknessUm
}};
constexpr double kChoroidThicknessUm = 220.0;

}  // namespace

std::string_view to_string(RetinalInterface interface) noexcept {
  switch (interface) {
    case RetinalInterface::ilm:
      return "ILM";
    case RetinalInterface::nfl_gcl:
      return "NFL/GCL";
    case RetinalInterface::ipl_inl:
      return "IPL/INL";
    case RetinalInterface::opl_onl:
      return "OPL/ONL";
    case RetinalInterface::is_os:
      return "IS/OS";
    case RetinalInterface::rpe:
      return "RPE";
    case RetinalInterface::choroid:
      return "choroid";
  }
  return "unknown";
}

void RetinaConfig::validate() const {
  ioct::require_real_in_range("retina.field_half_width_mm", field_half_width_mm, 0.1, 20.0);
  ioct::require_real_in_range("retina.rpe_depth_fraction", rpe_depth_fraction, 0.0, 1.0);
  ioct::require_real_in_range("retina.curvature_fraction", curvature_fraction, -0.5, 0.5);
  ioct::require_real_in_range("retina.tilt_x_fraction", tilt_x_fraction, -0.5, 0.5);
  ioct::require_real_in_range("retina.tilt_y_fraction", tilt_y_fraction, -0.5, 0.5);
  ioct::require_real_in_range("retina.fovea_x", fovea_x, -2.0, 2.0);
  ioct::require_real_in_range("retina.fovea_y", fovea_y, -2.0, 2.0);
  ioct::require_real_in_range("retina.fovea_radius_mm", fovea_radius_mm, 0.05, 5.0);
  ioct::require_real_in_range("retina.foveal_pit_depth", foveal_pit_depth, 0.0, 1.0);
  ioct::require_real_in_range("retina.tissue_index", tissue_index, 1.0, 2.0);
  ioct::require_real_in_range("retina.speckle_contrast", speckle_contrast, 0.0, 1.0);
}

RetinaModel::RetinaModel(const RetinaConfig& config, double axial_pixel_um,
                         std::uint32_t depth_bins)
    : config_(config),
      um_to_px_(config.tissue_index / axial_pixel_um),
      depth_bins_(static_cast<double>(depth_bins)) {}

RetinaColumn RetinaModel::column(hal::BeamPosition beam) const noexcept {
  const double x = beam.x;
  const double y = beam.y;
  const double rpe =
      depth_bins_ * (config_.rpe_depth_fraction - config_.curvature_fraction * (x * x + y * y) +
                     config_.tilt_x_fraction * x + config_.tilt_y_fraction * y);
  const double dx_mm = (x - config_.fovea_x) * config_.field_half_width_mm;
  const double dy_mm = (y - config_.fovea_y) * config_.field_half_width_mm;
  const double sigma = config_.fovea_radius_mm;
  const double pit =
      config_.foveal_pit_depth * std::exp(-0.5 * (dx_mm * dx_mm + dy_mm * dy_mm) / (sigma * sigma));
  const double inner_scale = 1.0 - pit;

  RetinaColumn column{};
  const auto rpe_index = static_cast<std::size_t>(RetinalInterface::rpe);
  // Up from the RPE, layer by layer.
  double depth = rpe;
  for (std::size_t i = rpe_index + 1; i-- > 0;) {
    const InterfaceShape& shape = kShapes[i];
    // Inside the pit an inner layer thins, and the interface below it fades with it: no tissue,
    // no boundary.
    const double scale = shape.inner ? inner_scale : 1.0;
    column[i] = {static_cast<float>(depth), static_cast<float>(shape.reflectivity * scale)};
    depth -= shape.thickness_above_um * scale * um_to_px_;
  }
  const auto choroid = static_cast<std::size_t>(RetinalInterface::choroid);
  column[choroid] = {static_cast<float>(rpe + kChoroidThicknessUm * um_to_px_),
                     static_cast<float>(kShapes[choroid].reflectivity)};
  return column;
}

}  // namespace ioct::sim
