#include "ioct/sim/anterior_segment_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "ioct/common/config_error.hpp"
#include "ioct/sim/speckle.hpp"

namespace ioct::sim {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Group indices near 1060 nm.
constexpr double kCorneaIndex = 1.376;
constexpr double kAqueousIndex = 1.336;
constexpr double kLensIndex = 1.42;
constexpr double kIrisIndex = 1.40;

constexpr double kEpitheliumUm = 50.0;
constexpr double kBowmanUm = 12.0;
// Amplitudes relative to a reflectivity-1 reflector; scatter per px.
constexpr float kSurfaceLine = 0.25f;
constexpr float kSurfaceReflex = 3.0f;     // added at normal incidence
constexpr double kReflexWidthRad = 0.035;  // about 2 degrees
constexpr float kBowmanLine = 0.25f;
constexpr float kEndotheliumLine = 0.35f;
constexpr float kEndotheliumReflex = 0.8f;
constexpr float kIrisLine = 0.35f;
constexpr float kLensLine = 0.3f;
constexpr float kLensReflex = 0.8f;
constexpr float kEpitheliumScatter = 0.12f;
constexpr float kStromaScatter = 0.05f;
constexpr float kIrisScatter = 0.6f;
constexpr float kLensScatter = 0.025f;
constexpr double kStromaAttenuationPerMm = 0.3;
constexpr double kIrisAttenuationPerMm = 12.0;  // pigment: nothing gets through
constexpr double kLensAttenuationPerMm = 0.2;

// Sag of a sphere of radius `r_sphere` at distance `r` from its axis; NaN beyond its edge.
double sag(double r_sphere, double r) noexcept {
  return r < r_sphere ? r_sphere - std::sqrt(r_sphere * r_sphere - r * r)
                      : std::numeric_limits<double>::quiet_NaN();
}

enum Line : std::uint64_t { surface = 11, bowman, endothelium, iris_front, lens };

}  // namespace

void AnteriorSegmentConfig::validate() const {
  ioct::require_real_in_range("anterior.field_half_width_mm", field_half_width_mm, 0.1, 20.0);
  ioct::require_real_in_range("anterior.apex_depth_fraction", apex_depth_fraction, 0.0, 0.9);
  ioct::require_real_in_range("anterior.apex_x", apex_x, -2.0, 2.0);
  ioct::require_real_in_range("anterior.apex_y", apex_y, -2.0, 2.0);
  ioct::require_real_in_range("anterior.cornea_anterior_radius_mm", cornea_anterior_radius_mm, 4.0,
                              20.0);
  ioct::require_real_in_range("anterior.cornea_posterior_radius_mm", cornea_posterior_radius_mm,
                              3.0, 20.0);
  ioct::require_real_in_range("anterior.cornea_thickness_um", cornea_thickness_um, 100.0, 1500.0);
  ioct::require_real_in_range("anterior.chamber_depth_mm", chamber_depth_mm,
                              cornea_thickness_um * 1e-3 + 0.1, 6.0);
  ioct::require_real_in_range("anterior.pupil_radius_mm", pupil_radius_mm, 0.5, 5.0);
  ioct::require_real_in_range("anterior.iris_root_radius_mm", iris_root_radius_mm,
                              pupil_radius_mm + 0.5, 8.0);
  ioct::require_real_in_range("anterior.iris_thickness_um", iris_thickness_um, 50.0, 1000.0);
  ioct::require_real_in_range("anterior.lens_anterior_radius_mm", lens_anterior_radius_mm, 5.0,
                              30.0);
  ioct::require_real_in_range("anterior.speckle_contrast", speckle_contrast, 0.0, 1.0);
}

AnteriorSegmentModel::AnteriorSegmentModel(const AnteriorSegmentConfig& config,
                                           double axial_pixel_um, std::uint32_t depth_bins)
    : config_(config), px_per_mm_(1e3 / axial_pixel_um), depth_bins_(depth_bins) {}

AnteriorColumn AnteriorSegmentModel::column(hal::BeamPosition beam) const noexcept {
  const double dx = (beam.x - config_.apex_x) * config_.field_half_width_mm;
  const double dy = (beam.y - config_.apex_y) * config_.field_half_width_mm;
  const double r = std::sqrt(dx * dx + dy * dy);
  const double apex_px = config_.apex_depth_fraction * depth_bins_;
  AnteriorColumn c{kNaN, kNaN, kNaN, kNaN, kNaN, kNaN, 0.0f};

  const double front = sag(config_.cornea_anterior_radius_mm, r);
  const double back =
      config_.cornea_thickness_um * 1e-3 + sag(config_.cornea_posterior_radius_mm, r);
  if (!std::isfinite(front) || !std::isfinite(back) || back <= front) return c;
  // Optical path from the apex plane, along the vertical beam.
  const double front_px = apex_px + front * px_per_mm_;
  const auto in_cornea = [&](double z) {
    return front_px + (z - front) * kCorneaIndex * px_per_mm_;
  };
  const double back_px = in_cornea(back);
  const auto in_chamber = [&](double z) {
    return back_px + (z - back) * kAqueousIndex * px_per_mm_;
  };
  c.epithelium_px = static_cast<float>(front_px);
  c.bowman_px = static_cast<float>(in_cornea(front + (kEpitheliumUm + 0.5 * kBowmanUm) * 1e-3));
  c.endothelium_px = static_cast<float>(back_px);
  c.surface_tilt_rad =
      static_cast<float>(std::asin(std::min(1.0, r / config_.cornea_anterior_radius_mm)));

  const double lens = config_.chamber_depth_mm + sag(config_.lens_anterior_radius_mm, r);
  const double pupil = config_.pupil_radius_mm;
  if (r > pupil && r < config_.iris_root_radius_mm) {
    // The iris rests on the lens at the pupil and bows slightly forward towards its root; it is
    // thin at the pupil margin and at the root.
    const double s = (r - pupil) / (config_.iris_root_radius_mm - pupil);
    const double lens_at_pupil =
        config_.chamber_depth_mm + sag(config_.lens_anterior_radius_mm, pupil);
    const double thickness =
        config_.iris_thickness_um * 1e-3 * (0.5 + 0.5 * std::sin(std::numbers::pi * std::sqrt(s)));
    const double iris_back = lens_at_pupil + 0.15 * s - 0.1 * std::sin(std::numbers::pi * s);
    const double iris_front = iris_back - thickness;
    if (iris_front > back) {  // in front of the cornea's back surface: the angle closes it
      c.iris_front_px = static_cast<float>(in_chamber(iris_front));
      c.iris_back_px = static_cast<float>(c.iris_front_px + thickness * kIrisIndex * px_per_mm_);
    }
  }
  if (std::isfinite(lens) && lens > back) c.lens_px = static_cast<float>(in_chamber(lens));
  return c;
}

ColumnTruth AnteriorSegmentModel::draw(hal::BeamPosition beam, std::uint64_t lateral_key,
                                       DepthProfile& profile) const noexcept {
  const AnteriorColumn c = column(beam);
  if (!std::isfinite(c.epithelium_px)) return {};
  const float contrast = static_cast<float>(config_.speckle_contrast);
  const auto line = [&](float depth, float amplitude, Line id) {
    const std::uint64_t key = lateral_key ^ (id * 0xD6E8FEB86659FD93ull);
    profile.add_reflector(depth, amplitude * speckle_amplitude(key, contrast), key);
  };
  const float px_um = static_cast<float>(1e3 / px_per_mm_);  // optical um per px
  const auto attenuation_px = [&](double per_mm, double index) {
    return static_cast<float>(per_mm * 1e-3 * px_um / index);
  };
  profile.set_texture_origin(c.epithelium_px);
  const float tilt = c.surface_tilt_rad;
  const float reflex =
      static_cast<float>(std::exp(-(tilt * tilt) / (kReflexWidthRad * kReflexWidthRad)));

  line(c.epithelium_px, kSurfaceLine + kSurfaceReflex * reflex, surface);
  const float epithelium_end =
      c.epithelium_px + static_cast<float>(kEpitheliumUm * kCorneaIndex) / px_um;
  profile.add_scatter(c.epithelium_px, epithelium_end, kEpitheliumScatter,
                      attenuation_px(kStromaAttenuationPerMm, kCorneaIndex));
  line(c.bowman_px, kBowmanLine, bowman);
  const float stroma_mu = attenuation_px(kStromaAttenuationPerMm, kCorneaIndex);
  profile.add_scatter(epithelium_end, c.endothelium_px, kStromaScatter, stroma_mu);
  const float through_cornea = std::exp(-stroma_mu * (c.endothelium_px - c.epithelium_px));
  line(c.endothelium_px, (kEndotheliumLine + kEndotheliumReflex * reflex) * through_cornea,
       endothelium);

  float transmitted = through_cornea;
  if (std::isfinite(c.iris_front_px)) {
    const float mu = attenuation_px(kIrisAttenuationPerMm, kIrisIndex);
    line(c.iris_front_px, kIrisLine * transmitted, iris_front);
    profile.add_scatter(c.iris_front_px, c.iris_back_px, kIrisScatter * transmitted, mu);
    transmitted *= std::exp(-mu * (c.iris_back_px - c.iris_front_px));
  }
  if (std::isfinite(c.lens_px)) {
    // The lens lies under the iris too, where the iris's shadow hides it.
    const float lens_tilt = static_cast<float>(std::asin(
        std::min(1.0, std::hypot((beam.x - config_.apex_x), (beam.y - config_.apex_y)) *
                          config_.field_half_width_mm / config_.lens_anterior_radius_mm)));
    const float lens_reflex = static_cast<float>(
        std::exp(-(lens_tilt * lens_tilt) / (kReflexWidthRad * kReflexWidthRad)));
    line(c.lens_px, (kLensLine + kLensReflex * lens_reflex) * transmitted, lens);
    profile.add_scatter(c.lens_px, profile.depth_bins(), kLensScatter * transmitted,
                        attenuation_px(kLensAttenuationPerMm, kLensIndex));
  }
  return {};
}

}  // namespace ioct::sim
