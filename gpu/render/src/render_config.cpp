#include "ioct/gpu/render/render_config.hpp"

#include <cmath>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu::render {

namespace {

std::string key_of(std::string_view prefix, std::string_view name) {
  return std::string(prefix) + "." + std::string(name);
}

void require_finite(std::string_view key, double value) {
  if (!std::isfinite(value))
    throw ConfigError(std::string(key), format_value(value), "must be finite");
}

void require_at_least(std::string_view key, double value, double lo) {
  require_finite(key, value);
  if (value < lo) {
    throw ConfigError(std::string(key), format_value(value),
                      "must be at least " + format_value(lo));
  }
}

void require_positive(std::string_view key, double value) {
  require_finite(key, value);
  if (value <= 0.0) throw ConfigError(std::string(key), format_value(value), "must be positive");
}

void require_unit_color(std::string_view key, const std::array<double, 3>& rgb) {
  for (int c = 0; c < 3; ++c) {
    require_real_in_range(std::string(key) + "[" + std::to_string(c) + "]", rgb[c], 0.0, 1.0);
  }
}

}  // namespace

std::string_view to_string(RenderMode mode) noexcept {
  switch (mode) {
    case RenderMode::basic:
      return "basic";
    case RenderMode::enhanced:
      return "enhanced";
    case RenderMode::layer_aware:
      return "layer-aware";
    case RenderMode::axial_colorization:
      return "axial-colorization";
    case RenderMode::la_mip_composite:
      return "la-mip";
    case RenderMode::bscan_slice:
      return "bscan";
    case RenderMode::en_face_slice:
      return "en-face";
  }
  return "?";
}

RenderMode parse_render_mode(std::string_view name, std::string_view key) {
  for (const RenderMode m : {RenderMode::basic, RenderMode::enhanced, RenderMode::layer_aware,
                             RenderMode::axial_colorization, RenderMode::la_mip_composite,
                             RenderMode::bscan_slice, RenderMode::en_face_slice}) {
    if (name == to_string(m)) return m;
  }
  throw ConfigError(std::string(key), "'" + std::string(name) + "'",
                    "must be basic, enhanced, layer-aware, axial-colorization, la-mip, bscan or "
                    "en-face");
}

bool is_volume_mode(RenderMode mode) noexcept {
  return mode == RenderMode::basic || mode == RenderMode::enhanced ||
         mode == RenderMode::layer_aware || mode == RenderMode::axial_colorization;
}

std::string_view to_string(Preset preset) noexcept {
  return preset == Preset::retina ? "retina" : "anterior";
}

Preset parse_preset(std::string_view name) {
  if (name == "retina") return Preset::retina;
  if (name == "anterior") return Preset::anterior;
  throw ConfigError("render.preset", "'" + std::string(name) + "'", "must be retina or anterior");
}

EnhancedConfig enhanced_preset(Preset preset) {
  EnhancedConfig config;
  if (preset == Preset::anterior) {
    config.kg1 /= 10.0;
    config.kf1 /= 10.0;
  }
  return config;
}

void ViewConfig::validate() const {
  const std::string p = "render.view";
  require_real_in_range(key_of(p, "azimuth_deg"), azimuth_deg, -36000.0, 36000.0);
  require_real_in_range(key_of(p, "elevation_deg"), elevation_deg, -90.0, 90.0);
  require_real_in_range(key_of(p, "zoom"), zoom, 0.01, 100.0);
  require_real_in_range(key_of(p, "pan_x"), pan_x, -10.0, 10.0);
  require_real_in_range(key_of(p, "pan_y"), pan_y, -10.0, 10.0);
  require_real_in_range(key_of(p, "stereo_angle_deg"), stereo_angle_deg, 0.0, 45.0);
  require_integer_in_range(key_of(p, "output_width"), output_width, 1, 8192);
  require_integer_in_range(key_of(p, "output_height"), output_height, 1, 8192);
  double norm = 0.0;
  for (int i = 0; i < 3; ++i) {
    require_finite(key_of(p, "light_direction[" + std::to_string(i) + "]"), light_direction[i]);
    norm += light_direction[i] * light_direction[i];
  }
  if (norm < 1e-12) {
    throw ConfigError(key_of(p, "light_direction"), "(0, 0, 0)", "must not be the zero vector");
  }
  require_real_in_range(key_of(p, "rotation_deg_per_s"), rotation_deg_per_s, -3600.0, 3600.0);
}

void VoxelSpacing::validate() const {
  require_positive("render.spacing.ascan", ascan);
  require_positive("render.spacing.bscan", bscan);
  require_positive("render.spacing.depth", depth);
}

void TransferFunctions::validate(std::string_view key) const {
  const std::string p(key);
  if (color.empty()) throw ConfigError(p + ".color", "[]", "needs at least one point");
  if (opacity.empty()) throw ConfigError(p + ".opacity", "[]", "needs at least one point");
  const std::string at_most = "must have at most " + std::to_string(kMaxTransferPoints) + " points";
  if (color.size() > kMaxTransferPoints) {
    throw ConfigError(p + ".color", std::to_string(color.size()) + " points", at_most);
  }
  if (opacity.size() > kMaxTransferPoints) {
    throw ConfigError(p + ".opacity", std::to_string(opacity.size()) + " points", at_most);
  }
  require_real_in_range(p + ".window[0]", window[0], 0.0, 1.0);
  require_real_in_range(p + ".window[1]", window[1], 0.0, 1.0);
  if (!(window[1] > window[0])) {
    throw ConfigError(p + ".window[1]", format_value(window[1]),
                      "must be above window[0] (" + format_value(window[0]) + ")");
  }
  for (std::size_t i = 0; i < color.size(); ++i) {
    const std::string k = p + ".color[" + std::to_string(i) + "]";
    require_real_in_range(k + ".intensity", color[i].intensity, 0.0, 1.0);
    if (i > 0 && color[i].intensity < color[i - 1].intensity) {
      throw ConfigError(k + ".intensity", format_value(color[i].intensity),
                        "must not be below the previous point's");
    }
    require_unit_color(k + ".rgb", color[i].rgb);
  }
  for (std::size_t i = 0; i < opacity.size(); ++i) {
    const std::string k = p + ".opacity[" + std::to_string(i) + "]";
    require_real_in_range(k + ".intensity", opacity[i].intensity, 0.0, 1.0);
    if (i > 0 && opacity[i].intensity < opacity[i - 1].intensity) {
      throw ConfigError(k + ".intensity", format_value(opacity[i].intensity),
                        "must not be below the previous point's");
    }
    require_real_in_range(k + ".alpha", opacity[i].alpha, 0.0, 1.0);
  }
}

void EnhancedConfig::validate() const {
  const std::string p = "render.enhanced";
  require_real_in_range(key_of(p, "threshold"), threshold, 0.0, 1.0);
  require_at_least(key_of(p, "kg1"), kg1, 0.0);
  require_positive(key_of(p, "kg2"), kg2);
  require_at_least(key_of(p, "kf1"), kf1, 0.0);
  require_positive(key_of(p, "kf2"), kf2);
  require_real_in_range(key_of(p, "kd1"), kd1, 0.0, 1.0);
  require_positive(key_of(p, "kd2"), kd2);
  require_real_in_range(key_of(p, "kd3"), kd3, 0.0, 1.0);
  require_unit_color(key_of(p, "c_b"), c_b);
  require_at_least(key_of(p, "kp1"), kp1, 0.0);
  require_at_least(key_of(p, "kp2"), kp2, 0.0);
  require_at_least(key_of(p, "kp3"), kp3, 0.0);
  require_positive(key_of(p, "kp4"), kp4);
  transfer.validate(key_of(p, "transfer"));
}

void LabColorMap::validate(std::string_view key) const {
  const std::string p(key);
  for (int i = 0; i < 2; ++i) {
    require_real_in_range(p + ".c0[" + std::to_string(i) + "]", c0[i], -2.0, 2.0);
    require_real_in_range(p + ".c1[" + std::to_string(i) + "]", c1[i], -2.0, 2.0);
  }
  require_real_in_range(p + ".ab_scale", ab_scale, 0.0, 200.0);
  require_real_in_range(p + ".d_rpe_px", d_rpe_px, 0.0, 100000.0);
}

void LayerAwareConfig::validate() const {
  const std::string p = "render.layer_aware";
  require_real_in_range(key_of(p, "i_min"), i_min, 0.0, 1.0);
  require_real_in_range(key_of(p, "i_max"), i_max, 0.0, 1.0);
  if (!(i_max > i_min)) {
    throw ConfigError(key_of(p, "i_max"), format_value(i_max),
                      "must be above i_min (" + format_value(i_min) + ")");
  }
  require_real_in_range(key_of(p, "alpha_max"), alpha_max, 0.0, 1.0);
  require_integer_in_range(key_of(p, "shadow_steps"), shadow_steps, 0, kMaxShadowSteps);
  require_real_in_range(key_of(p, "early_termination"), early_termination, 0.01, 1.0);
  colors.validate(key_of(p, "colors"));
}

void AxialColorizationConfig::validate() const {
  const std::string p = "render.axial";
  require_integer_in_range(key_of(p, "shadow_steps"), shadow_steps, 0, kMaxShadowSteps);
}

void SliceConfig::validate() const {
  if (bscan < -1) {
    throw ConfigError("render.slice.bscan", format_value(std::int64_t{bscan}),
                      "must be -1 (centre) or a B-scan index");
  }
  require_finite("render.slice.en_face_depth_px", en_face_depth_px);
}

void RenderConfig::validate() const {
  view.validate();
  spacing.validate();
  require_real_in_range("render.step_voxels", step_voxels, 0.05, 8.0);
  require_real_in_range("render.early_termination", early_termination, 0.01, 1.0);
  enhanced.validate();
  layer_aware.validate();
  axial.validate();
  slice.validate();
  require_unit_color("render.background", background);
  require_integer_in_range("render.cpu_threads", cpu_threads, 0, 256);
}

}  // namespace ioct::gpu::render
