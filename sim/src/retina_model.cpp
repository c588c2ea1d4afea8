#include "ioct/sim/retina_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "ioct/common/config_error.hpp"
#include "ioct/sim/random.hpp"
#include "ioct/sim/speckle.hpp"

namespace ioct::sim {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Each layer: parafoveal thickness (um), whether it belongs to the inner retina that the foveal
// pit removes, how much it grows at the foveal centre (share of its thickness), its scatter
// (amplitude per px relative to the RPE line = 1) and its attenuation (amplitude, 1/mm). The
// brightness ranking follows a 1 um swept-source B-scan: NFL, plexiform layers and the RPE
// bright, nuclear layers dark, the choroid textured and fading into the sclera.
struct LayerShape {
  double thickness_um;
  bool inner;
  double fovea_growth;
  double scatter;
  double attenuation_per_mm;
};
constexpr std::array<LayerShape, kRetinalLayers> kLayers{{
    {28.0, true, 0.0, 0.22, 0.5},    // NFL
    {45.0, true, 0.0, 0.09, 0.5},    // GCL
    {38.0, true, 0.0, 0.15, 0.5},    // IPL
    {35.0, true, 0.0, 0.05, 0.5},    // INL
    {28.0, true, 0.0, 0.14, 0.5},    // OPL
    {75.0, false, 0.3, 0.035, 0.5},  // ONL (Henle fibres thicken it at the fovea)
    {28.0, false, 0.1, 0.06, 0.5},   // inner segments
    {32.0, false, 0.3, 0.12, 1.0},   // outer segments (longer cones at the fovea)
    {18.0, false, 0.0, 0.25, 25.0},  // RPE: strongly absorbing melanin
    {220.0, false, 0.0, 0.22, 5.0},  // choroid
    {500.0, false, 0.0, 0.10, 3.0},  // sclera
}};

// Thin bright lines and where they sit. The RPE's line is the brightest reflection of the
// retina (about 1 after the tissue above has attenuated it), then the IS/OS line and the ILM.
constexpr float kIlmLine = 0.45f;
constexpr float kElmLine = 0.12f;             // top of the inner segments
constexpr float kEllipsoidLine = 0.5f;        // IS/OS, top of the outer segments
constexpr float kInterdigitationLine = 0.2f;  // top of the RPE
constexpr float kRpeLine = 1.6f;              // the RPE's centre
constexpr float kMembraneBackLine = 0.25f;
constexpr double kMembraneScatter = 0.35;
constexpr double kMembraneAttenuationPerMm = 2.0;

// Structures larger than speckle (choroidal vessel lumens, cysts) come from smooth value noise
// on a lattice of cells, thresholded: round-ish blobs, the same wherever the beam returns.
constexpr double kVesselCellMm = 0.11;
constexpr double kVesselCellUm = 55.0;  // depth
constexpr double kVesselSlabUm = 14.0;
constexpr double kChoriocapillarisUm = 25.0;  // no large lumens just under Bruch's membrane
constexpr double kVesselThreshold = 0.38;
constexpr float kLumenScatter = 0.12f;
constexpr double kCystCellMm = 0.05;
constexpr double kCystCellUm = 30.0;
constexpr float kCystScatter = 0.05f;
constexpr std::uint64_t kVesselSalt = 0x76657373'656C7321;  // "vessels!"
constexpr std::uint64_t kCystSalt = 0x63797374'73212121;    // "cysts!!!"

double lattice_value(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t salt) noexcept {
  return unit_open_zero(splitmix64(static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
                                   static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                                   static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull ^ salt));
}

double smooth(double t) noexcept {
  return t * t * (3.0 - 2.0 * t);
}

// Smooth noise in [0, 1] at a lateral position (cells of cell_mm) and a depth below a layer's
// top (cells of cell_um).
class ValueNoise {
 public:
  ValueNoise(double x_mm, double y_mm, double cell_mm, std::uint64_t salt) noexcept : salt_(salt) {
    const double gx = x_mm / cell_mm;
    const double gy = y_mm / cell_mm;
    ix_ = static_cast<std::int64_t>(std::floor(gx));
    iy_ = static_cast<std::int64_t>(std::floor(gy));
    fx_ = smooth(gx - static_cast<double>(ix_));
    fy_ = smooth(gy - static_cast<double>(iy_));
  }
  // Depths must not decrease from call to call (two lattice planes are cached).
  double at(double depth_cells) noexcept {
    const auto iz = static_cast<std::int64_t>(std::floor(depth_cells));
    const double fz = smooth(depth_cells - static_cast<double>(iz));
    if (iz != cached_z_) {
      lower_ = iz == cached_z_ + 1 ? upper_ : plane(iz);
      upper_ = plane(iz + 1);
      cached_z_ = iz;
    }
    return lower_ * (1.0 - fz) + upper_ * fz;
  }

 private:
  double plane(std::int64_t z) const noexcept {
    const double v00 = lattice_value(ix_, iy_, z, salt_);
    const double v10 = lattice_value(ix_ + 1, iy_, z, salt_);
    const double v01 = lattice_value(ix_, iy_ + 1, z, salt_);
    const double v11 = lattice_value(ix_ + 1, iy_ + 1, z, salt_);
    return (v00 * (1.0 - fx_) + v10 * fx_) * (1.0 - fy_) + (v01 * (1.0 - fx_) + v11 * fx_) * fy_;
  }
  std::int64_t cached_z_ = std::numeric_limits<std::int64_t>::min();
  double lower_ = 0.0;
  double upper_ = 0.0;
  std::uint64_t salt_;
  std::int64_t ix_, iy_;
  double fx_, fy_;
};

enum Line : std::uint64_t {
  ilm_line = 1,
  elm_line,
  ellipsoid_line,
  iz_line,
  rpe_line,
  erm_front,
  erm_back
};

}  // namespace

std::string_view to_string(RetinalLayer layer) noexcept {
  switch (layer) {
    case RetinalLayer::nfl:
      return "NFL";
    case RetinalLayer::gcl:
      return "GCL";
    case RetinalLayer::ipl:
      return "IPL";
    case RetinalLayer::inl:
      return "INL";
    case RetinalLayer::opl:
      return "OPL";
    case RetinalLayer::onl:
      return "ONL";
    case RetinalLayer::is:
      return "IS";
    case RetinalLayer::os:
      return "OS";
    case RetinalLayer::rpe:
      return "RPE";
    case RetinalLayer::choroid:
      return "choroid";
    case RetinalLayer::sclera:
      return "sclera";
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
  ioct::require_real_in_range("retina.scattering_gain", scattering_gain, 0.0, 10.0);
  ioct::require_real_in_range("retina.nfl_growth_nasal_um_per_mm", nfl_growth_nasal_um_per_mm, 0.0,
                              100.0);
  ioct::require_real_in_range("retina.nfl_growth_temporal_um_per_mm", nfl_growth_temporal_um_per_mm,
                              0.0, 100.0);
  if (macular_hole.enabled) {
    ioct::require_real_in_range("retina.macular_hole.radius_mm", macular_hole.radius_mm, 0.01, 3.0);
    ioct::require_real_in_range("retina.macular_hole.cuff_width_mm", macular_hole.cuff_width_mm,
                                0.0, 3.0);
    ioct::require_real_in_range("retina.macular_hole.cuff_height_um", macular_hole.cuff_height_um,
                                0.0, 500.0);
    ioct::require_real_in_range("retina.macular_hole.cyst_fraction", macular_hole.cyst_fraction,
                                0.0, 1.0);
  }
  if (membrane.enabled) {
    ioct::require_real_in_range("retina.membrane.center_x", membrane.center_x, -2.0, 2.0);
    ioct::require_real_in_range("retina.membrane.center_y", membrane.center_y, -2.0, 2.0);
    ioct::require_real_in_range("retina.membrane.radius_mm", membrane.radius_mm, 0.05, 20.0);
    ioct::require_real_in_range("retina.membrane.thickness_um", membrane.thickness_um, 1.0, 100.0);
    ioct::require_real_in_range("retina.membrane.lift_um", membrane.lift_um, 0.0, 1000.0);
    ioct::require_real_in_range("retina.membrane.wrinkle_mm", membrane.wrinkle_mm, 0.02, 10.0);
    ioct::require_real_in_range("retina.membrane.reflectivity", membrane.reflectivity, 0.0, 10.0);
  }
  if (disc.enabled) {
    ioct::require_real_in_range("retina.disc.center_x", disc.center_x, -2.0, 2.0);
    ioct::require_real_in_range("retina.disc.center_y", disc.center_y, -2.0, 2.0);
    ioct::require_real_in_range("retina.disc.radius_mm", disc.radius_mm, 0.05, 5.0);
    ioct::require_real_in_range("retina.disc.margin_mm", disc.margin_mm, 0.0, 5.0);
    // The cup lies inside the disc: the rim keeps the retina's surface continuous.
    ioct::require_real_in_range("retina.disc.cup_radius_mm", disc.cup_radius_mm, 0.0,
                                disc.radius_mm);
    ioct::require_real_in_range("retina.disc.cup_depth_um", disc.cup_depth_um, 0.0, 1000.0);
    ioct::require_real_in_range("retina.disc.nerve_scatter", disc.nerve_scatter, 0.0, 10.0);
  }
}

RetinaModel::RetinaModel(const RetinaConfig& config, double axial_pixel_um,
                         std::uint32_t depth_bins)
    : config_(config),
      um_to_px_(config.tissue_index / axial_pixel_um),
      depth_bins_(static_cast<double>(depth_bins)) {}

RetinaColumn RetinaModel::column(hal::BeamPosition beam) const noexcept {
  const double x = beam.x;
  const double y = beam.y;
  const double rpe_line =
      depth_bins_ * (config_.rpe_depth_fraction - config_.curvature_fraction * (x * x + y * y) +
                     config_.tilt_x_fraction * x + config_.tilt_y_fraction * y);
  const double dx_mm = (x - config_.fovea_x) * config_.field_half_width_mm;
  const double dy_mm = (y - config_.fovea_y) * config_.field_half_width_mm;
  const double sigma = config_.fovea_radius_mm;
  const double radius_mm = std::sqrt(dx_mm * dx_mm + dy_mm * dy_mm);
  const double pit_profile = std::exp(-0.5 * radius_mm * radius_mm / (sigma * sigma));
  const double pit = config_.foveal_pit_depth * pit_profile;

  // A macular hole removes the neural retina inside its radius and thickens a rim around it.
  bool in_hole = false;
  double cuff = 0.0;
  if (config_.macular_hole.enabled) {
    const MacularHoleConfig& hole = config_.macular_hole;
    if (radius_mm < hole.radius_mm) {
      in_hole = true;
    } else if (hole.cuff_width_mm > 0.0 && radius_mm < hole.radius_mm + hole.cuff_width_mm) {
      cuff = 1.0 - (radius_mm - hole.radius_mm) / hole.cuff_width_mm;
    }
  }
  double neural_um = 0.0;
  for (std::size_t i = 0; i <= static_cast<std::size_t>(RetinalLayer::os); ++i) {
    neural_um += kLayers[i].thickness_um;
  }
  const double cuff_scale = 1.0 + cuff * config_.macular_hole.cuff_height_um / neural_um;

  // The optic disc: the layers below the NFL thin out over its margin (`kept` of them left), and
  // inside it the surface dips into the cup.
  bool in_disc = false;
  double kept = 1.0;
  double cup_um = 0.0;
  if (config_.disc.enabled) {
    const OpticDiscConfig& disc = config_.disc;
    const double ox = (x - disc.center_x) * config_.field_half_width_mm;
    const double oy = (y - disc.center_y) * config_.field_half_width_mm;
    const double r = std::sqrt(ox * ox + oy * oy);
    in_disc = r < disc.radius_mm;
    kept = in_disc ? 0.0
                   : (disc.margin_mm > 0.0
                          ? smooth(std::min(1.0, (r - disc.radius_mm) / disc.margin_mm))
                          : 1.0);
    if (r < disc.cup_radius_mm) {
      cup_um =
          disc.cup_depth_um * 0.5 * (1.0 + std::cos(std::numbers::pi * r / disc.cup_radius_mm));
    }
  }

  RetinaColumn column{};
  const auto rpe = static_cast<std::size_t>(RetinalLayer::rpe);
  const double rpe_top = rpe_line - 0.5 * kLayers[rpe].thickness_um * um_to_px_;
  // Up from the RPE, layer by layer.
  double depth = rpe_top;
  column.top[rpe] = static_cast<float>(rpe_top);
  column.presence[rpe] = 1.0f;
  double thinned_um = 0.0;  // what the disc's margin took from the layers below the NFL
  for (std::size_t i = rpe; i-- > 0;) {
    const LayerShape& shape = kLayers[i];
    double thickness_um = shape.thickness_um;
    if (i == static_cast<std::size_t>(RetinalLayer::nfl)) {
      thickness_um += (dx_mm > 0.0 ? config_.nfl_growth_nasal_um_per_mm
                                   : config_.nfl_growth_temporal_um_per_mm) *
                      std::abs(dx_mm);
    }
    double presence = 1.0;
    if (shape.inner) {
      presence = 1.0 - pit;  // no tissue, no boundary: its lines fade with it
      thickness_um *= presence;
    } else {
      thickness_um *= 1.0 + shape.fovea_growth * pit_profile;
    }
    thickness_um *= cuff_scale;
    if (i == static_cast<std::size_t>(RetinalLayer::nfl)) {
      thickness_um += thinned_um;  // the nerve fibres fill the disc's margin
    } else {
      thinned_um += (1.0 - kept) * thickness_um;
      thickness_um *= kept;
      presence *= kept;
    }
    if (in_hole) {
      thickness_um = 0.0;
      presence = 0.0;
    }
    depth -= thickness_um * um_to_px_;
    column.top[i] = static_cast<float>(depth);
    column.presence[i] = static_cast<float>(presence);
  }
  depth = rpe_top;
  for (std::size_t i = rpe; i < kRetinalLayers; ++i) {
    depth += kLayers[i].thickness_um * um_to_px_;
    column.top[i + 1] = static_cast<float>(depth);
    column.presence[i] = 1.0f;
  }
  column.rpe_px = static_cast<float>(rpe_line);
  if (in_disc) {
    // Nerve fibres from the cup's surface down to the sclera: no RPE, no choroid.
    const auto choroid = static_cast<std::size_t>(RetinalLayer::choroid);
    column.top[0] = static_cast<float>(column.top[0] + cup_um * um_to_px_);
    for (std::size_t i = 1; i <= choroid + 1; ++i) column.top[i] = column.top[choroid + 1];
    column.presence[rpe] = 0.0f;
    column.presence[choroid] = 0.0f;
    column.rpe_px = kNaN;
  }
  column.ilm_px = in_hole ? kNaN : column.top[0];
  column.cuff = static_cast<float>(cuff);
  column.in_disc = in_disc;

  column.membrane_top_px = kNaN;
  column.membrane_bottom_px = kNaN;
  if (config_.membrane.enabled && !in_hole) {
    const EpiretinalMembraneConfig& erm = config_.membrane;
    const double mx = (x - erm.center_x) * config_.field_half_width_mm;
    const double my = (y - erm.center_y) * config_.field_half_width_mm;
    const double d = std::sqrt(mx * mx + my * my);
    if (d < erm.radius_mm) {
      const double two_pi = 2.0 * std::numbers::pi;
      double gap =
          erm.lift_um *
          std::max(0.0, std::sin(two_pi * (0.8 * mx + 0.6 * my) / erm.wrinkle_mm) *
                            std::sin(two_pi * (-0.6 * mx + 0.8 * my) / (1.7 * erm.wrinkle_mm)));
      // The rim curls up off the retina.
      const double rim = 0.75 * erm.radius_mm;
      if (d > rim) {
        const double r = (d - rim) / (erm.radius_mm - rim);
        gap += 1.5 * erm.lift_um * r * r;
      }
      column.membrane_bottom_px = static_cast<float>(column.ilm_px - gap * um_to_px_);
      column.membrane_top_px =
          static_cast<float>(column.membrane_bottom_px - erm.thickness_um * um_to_px_);
    }
  }
  return column;
}

ColumnTruth RetinaModel::layers(hal::BeamPosition beam) const noexcept {
  const RetinaColumn c = column(beam);
  return {c.ilm_px, c.rpe_px};
}

ColumnTruth RetinaModel::draw(hal::BeamPosition beam, std::uint64_t lateral_key,
                              DepthProfile& profile) const noexcept {
  const RetinaColumn c = column(beam);
  const float contrast = static_cast<float>(config_.speckle_contrast);
  const auto line = [&](float depth, float amplitude, Line id) {
    const std::uint64_t key = lateral_key ^ (id * 0xD6E8FEB86659FD93ull);
    profile.add_reflector(depth, amplitude * speckle_amplitude(key, contrast), key);
  };
  const float px_um = static_cast<float>(1.0 / um_to_px_);
  const auto attenuation_px = [&](double per_mm) {
    return static_cast<float>(per_mm * 1e-3 / um_to_px_);
  };
  const float gain = static_cast<float>(config_.scattering_gain);
  const double x_mm = beam.x * config_.field_half_width_mm;
  const double y_mm = beam.y * config_.field_half_width_mm;

  float transmitted = 1.0f;  // amplitude left after the tissue above
  const bool membrane = std::isfinite(c.membrane_top_px);
  profile.set_texture_origin(membrane                  ? c.membrane_top_px
                             : std::isfinite(c.ilm_px) ? c.ilm_px
                                                       : c.top[0]);
  if (membrane) {
    const float mu = attenuation_px(kMembraneAttenuationPerMm);
    line(c.membrane_top_px, static_cast<float>(config_.membrane.reflectivity), erm_front);
    profile.add_scatter(c.membrane_top_px, c.membrane_bottom_px,
                        static_cast<float>(kMembraneScatter) * gain, mu);
    transmitted *= std::exp(-mu * (c.membrane_bottom_px - c.membrane_top_px));
    line(c.membrane_bottom_px, kMembraneBackLine * transmitted, erm_back);
  }
  if (std::isfinite(c.ilm_px)) line(c.ilm_px, kIlmLine * transmitted, ilm_line);

  for (std::size_t i = 0; i < kRetinalLayers; ++i) {
    const float top = c.top[i];
    const float bottom = c.top[i + 1];
    const float presence = c.presence[i];
    const float mu = attenuation_px(kLayers[i].attenuation_per_mm);
    if (presence > 0.0f && bottom > top) {
      const auto layer = static_cast<RetinalLayer>(i);
      if (layer == RetinalLayer::is) line(top, kElmLine * presence * transmitted, elm_line);
      if (layer == RetinalLayer::os) {
        line(top, kEllipsoidLine * presence * transmitted, ellipsoid_line);
      }
      if (layer == RetinalLayer::rpe) line(top, kInterdigitationLine * transmitted, iz_line);
      const float nerve_head = c.in_disc && layer == RetinalLayer::nfl
                                   ? static_cast<float>(config_.disc.nerve_scatter)
                                   : 1.0f;
      const float scatter =
          static_cast<float>(kLayers[i].scatter) * gain * presence * transmitted * nerve_head;
      const bool cystic =
          c.cuff > 0.0f && (layer == RetinalLayer::inl || layer == RetinalLayer::onl);
      if (layer == RetinalLayer::choroid || cystic) {
        // Slabs through the layer, dark where the smooth noise falls below a threshold: vessel
        // lumens in the choroid (none in the choriocapillaris), fluid-filled cysts in a hole's
        // cuff.
        const bool choroid = layer == RetinalLayer::choroid;
        ValueNoise noise(x_mm, y_mm, choroid ? kVesselCellMm : kCystCellMm,
                         choroid ? kVesselSalt : kCystSalt);
        const double cell_um = choroid ? kVesselCellUm : kCystCellUm;
        const float slab_px = static_cast<float>(kVesselSlabUm) / px_um;
        for (float from = top; from < bottom; from += slab_px) {
          const float to = std::min(bottom, from + slab_px);
          const double depth_um = (0.5 * (from + to) - top) * px_um;
          const double threshold = choroid
                                       ? (depth_um < kChoriocapillarisUm ? 0.0 : kVesselThreshold)
                                       : config_.macular_hole.cyst_fraction * c.cuff;
          const bool dark = noise.at(depth_um / cell_um) < threshold;
          const float a = scatter * std::exp(-mu * (from - top)) *
                          (dark ? (choroid ? kLumenScatter : kCystScatter) : 1.0f);
          profile.add_scatter(from, to, a, mu);
        }
      } else {
        profile.add_scatter(top, bottom, scatter, mu);
      }
      if (layer == RetinalLayer::rpe) {
        line(c.rpe_px, kRpeLine * transmitted * std::exp(-mu * (c.rpe_px - top)), rpe_line);
      }
    }
    if (bottom > top) transmitted *= std::exp(-mu * (bottom - top));
  }

  ColumnTruth truth;
  if (std::isfinite(c.ilm_px) && profile.drawable(c.ilm_px)) {
    truth.ilm_px = profile.drawn_depth(c.ilm_px);
  }
  if (std::isfinite(c.rpe_px) && profile.drawable(c.rpe_px))
    truth.rpe_px = profile.drawn_depth(c.rpe_px);
  return truth;
}

}  // namespace ioct::sim
