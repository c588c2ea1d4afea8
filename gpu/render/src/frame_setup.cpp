#include "ioct/gpu/render/frame_setup.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/render/lab_color.hpp"

namespace ioct::gpu::render {

namespace {

Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3 normalized(Vec3 v) {
  return (1.0f / length(v)) * v;
}

PixelKind kind_of(RenderMode mode) {
  switch (mode) {
    case RenderMode::basic:
      return PixelKind::basic;
    case RenderMode::enhanced:
      return PixelKind::enhanced;
    case RenderMode::layer_aware:
      return PixelKind::layer_aware;
    case RenderMode::axial_colorization:
      return PixelKind::axial_colorization;
    case RenderMode::la_mip_composite:
      return PixelKind::la_mip_composite;
    case RenderMode::bscan_slice:
      return PixelKind::bscan_slice;
    case RenderMode::en_face_slice:
      return PixelKind::en_face_slice;
  }
  return PixelKind::enhanced;
}

// d_rpe in px: the configured one, else the reference's mean thickness, else 250 um of depth.
float d_rpe_px(const RenderConfig& config, float mean_thickness_px) {
  if (config.layer_aware.colors.d_rpe_px > 0.0) {
    return static_cast<float>(config.layer_aware.colors.d_rpe_px);
  }
  if (mean_thickness_px > 1.0f) return mean_thickness_px;
  return static_cast<float>(kDefaultRetinaThicknessUm / config.spacing.depth);
}

}  // namespace

std::uint32_t output_width(const RenderParams& params) {
  return static_cast<std::uint32_t>(params.width * params.eyes);
}

RenderTables bake_tables(const RenderConfig& config) {
  RenderTables tables;
  tables.transfer_lut = bake_transfer_lut(config.enhanced.transfer);
  const bool colorize = config.mode != RenderMode::layer_aware || config.layer_aware.colorize;
  tables.lab_lut = bake_lab_lut(config.layer_aware.colors, colorize);
  return tables;
}

RenderParams bake_params(const RenderConfig& config, VolumeDims dims, float mean_thickness_px) {
  config.validate();
  if (dims.bscans == 0 || dims.ascans == 0 || dims.depth == 0) {
    throw std::invalid_argument("cannot render an empty volume (" + std::to_string(dims.bscans) +
                                " x " + std::to_string(dims.ascans) + " x " +
                                std::to_string(dims.depth) + ")");
  }
  RenderParams p;
  p.kind = kind_of(config.mode);
  const ViewConfig& view = config.view;
  p.width = static_cast<std::int32_t>(view.output_width);
  p.height = static_cast<std::int32_t>(view.output_height);
  p.eyes = view.stereo && is_volume_mode(config.mode) ? 2 : 1;
  p.dim_a = static_cast<std::int32_t>(dims.ascans);
  p.dim_b = static_cast<std::int32_t>(dims.bscans);
  p.dim_d = static_cast<std::int32_t>(dims.depth);
  for (int c = 0; c < 3; ++c) p.background[c] = static_cast<float>(config.background[c]);

  // World: the largest physical extent is 1; voxel size per axis in world units.
  const double ext_a = dims.ascans * config.spacing.ascan;
  const double ext_b = dims.bscans * config.spacing.bscan;
  const double ext_d = dims.depth * config.spacing.depth;
  const double largest = std::max({ext_a, ext_b, ext_d});
  const float vx = static_cast<float>(config.spacing.ascan / largest);
  const float vy = static_cast<float>(config.spacing.bscan / largest);
  const float vz = static_cast<float>(config.spacing.depth / largest);
  const float vmin = std::min({vx, vy, vz});
  p.gradient_scale = {vmin / vx, vmin / vy, -vmin / vz};
  const float dim_a = static_cast<float>(p.dim_a), dim_b = static_cast<float>(p.dim_b),
              dim_d = static_cast<float>(p.dim_d);
  const Vec3 half{0.5f * vx * dim_a, 0.5f * vy * dim_b, 0.5f * vz * dim_d};
  const float radius = length(half);
  const auto to_voxel_dir = [&](Vec3 w) { return Vec3{w.x / vx, w.y / vy, -w.z / vz}; };
  const auto to_voxel_pos = [&](Vec3 w) {
    return Vec3{w.x / vx + 0.5f * (dim_a - 1.0f), w.y / vy + 0.5f * (dim_b - 1.0f),
                -w.z / vz + 0.5f * (dim_d - 1.0f)};
  };
  p.half_height = static_cast<float>(radius / view.zoom);
  p.half_width = p.half_height * static_cast<float>(view.output_width) / view.output_height;
  p.pan_x = static_cast<float>(view.pan_x);
  p.pan_y = static_cast<float>(view.pan_y);

  constexpr double kDeg = std::numbers::pi / 180.0;
  const double phi = view.elevation_deg * kDeg;
  for (int eye = 0; eye < p.eyes; ++eye) {
    double azimuth = view.azimuth_deg;
    if (p.eyes == 2) azimuth += (eye == 0 ? -0.5 : 0.5) * view.stereo_angle_deg;
    const double theta = azimuth * kDeg;
    const Vec3 towards_eye{static_cast<float>(std::cos(phi) * std::sin(theta)),
                           static_cast<float>(-std::cos(phi) * std::cos(theta)),
                           static_cast<float>(std::sin(phi))};
    const Vec3 f = -1.0f * towards_eye;
    const Vec3 r{static_cast<float>(std::cos(theta)), static_cast<float>(std::sin(theta)), 0.0f};
    const Vec3 u = cross(r, f);
    EyeParams& e = p.eye[eye];
    e.origin = to_voxel_pos(-(radius + 1.0f) * f);
    e.right = to_voxel_dir(r);
    e.up = to_voxel_dir(u);
    e.dir = to_voxel_dir(f);
    e.view_world = f;
    const auto& l = view.light_direction;
    e.light_world = normalized(static_cast<float>(l[0]) * r + static_cast<float>(l[1]) * u +
                               static_cast<float>(l[2]) * towards_eye);
    e.half_world = normalized(e.light_world + towards_eye);
    e.light_voxel = to_voxel_dir(e.light_world);
    const float per_world =
        std::max({std::fabs(f.x) / vx, std::fabs(f.y) / vy, std::fabs(f.z) / vz});
    e.step = static_cast<float>(config.step_voxels) / per_world;
    const float projected =
        std::fabs(f.x) * half.x + std::fabs(f.y) * half.y + std::fabs(f.z) * half.z;
    e.depth_cue_offset = radius + 1.0f - projected;
    e.depth_cue_scale = 1.0f / (2.0f * projected);
  }

  p.early_termination = static_cast<float>(config.mode == RenderMode::layer_aware
                                               ? config.layer_aware.early_termination
                                               : config.early_termination);
  const EnhancedConfig& en = config.enhanced;
  p.use_threshold = en.use_threshold;
  p.threshold = static_cast<float>(en.threshold);
  p.edge = en.edge_enhancement;
  p.feature = en.feature_enhancement;
  p.depth_cues = en.depth_cues;
  // Axial colorization: shadow rays, when asked for, take Phong's place (Weiss Fig. 4 B4).
  p.phong = config.mode == RenderMode::axial_colorization
                ? config.axial.phong && config.axial.shadow_steps == 0
                : en.phong;
  p.kg1 = static_cast<float>(en.kg1);
  p.kg2 = static_cast<float>(en.kg2);
  p.kf1 = static_cast<float>(en.kf1);
  p.kf2 = static_cast<float>(en.kf2);
  p.kd1 = static_cast<float>(en.kd1);
  p.kd2 = static_cast<float>(en.kd2);
  p.kd3 = static_cast<float>(en.kd3);
  p.kp1 = static_cast<float>(en.kp1);
  p.kp2 = static_cast<float>(en.kp2);
  p.kp3 = static_cast<float>(en.kp3);
  p.kp4 = static_cast<float>(en.kp4);
  p.c_b = {static_cast<float>(en.c_b[0]), static_cast<float>(en.c_b[1]),
           static_cast<float>(en.c_b[2])};
  const LayerAwareConfig& la = config.layer_aware;
  p.i_min = static_cast<float>(la.i_min);
  p.i_max = static_cast<float>(la.i_max);
  p.alpha_max = static_cast<float>(la.alpha_max);
  p.shadow_steps = static_cast<std::int32_t>(
      config.mode == RenderMode::axial_colorization ? config.axial.shadow_steps : la.shadow_steps);
  p.d_rpe_px = d_rpe_px(config, mean_thickness_px);

  // Planar modes: the volume's physical aspect, letterboxed into the output.
  const double w = view.output_width;
  const double h = view.output_height;
  const auto letterbox = [&](double ext_x, double ext_y, double nx, double ny) {
    const double k = std::min(w / ext_x, h / ext_y);
    const double pw = std::max(1.0, ext_x * k);
    const double ph = std::max(1.0, ext_y * k);
    p.plane_x0 = static_cast<float>(0.5 * (w - pw));
    p.plane_y0 = static_cast<float>(0.5 * (h - ph));
    p.plane_scale_x = static_cast<float>(nx / pw);
    p.plane_scale_y = static_cast<float>(ny / ph);
  };
  if (config.mode == RenderMode::bscan_slice) {
    letterbox(ext_a, ext_d, dims.ascans, dims.depth);
    const std::int64_t b = config.slice.bscan < 0 ? dims.bscans / 2 : config.slice.bscan;
    if (b >= static_cast<std::int64_t>(dims.bscans)) {
      throw ConfigError("render.slice.bscan", format_value(std::int64_t{b}),
                        "must be below the volume's " + std::to_string(dims.bscans) + " B-scans");
    }
    p.slice_bscan = static_cast<float>(b);
  } else if (config.mode == RenderMode::en_face_slice) {
    letterbox(ext_a, ext_b, dims.ascans, dims.bscans);
    p.slice_relative_to_rpe = config.slice.en_face_relative_to_rpe;
    p.slice_depth = static_cast<float>(config.slice.en_face_depth_px);
    if (!config.slice.en_face_relative_to_rpe && config.slice.en_face_depth_px < 0.0) {
      p.slice_depth = 0.5f * static_cast<float>(dims.depth - 1);
    }
  } else if (config.mode == RenderMode::la_mip_composite) {
    const double k = std::min(w / (ext_a + ext_d), h / (ext_b + ext_d));
    CompositeLayout& l = p.layout;
    l.en_face_w = std::max(1, static_cast<int>(std::lround(k * ext_a)));
    l.en_face_h = std::max(1, static_cast<int>(std::lround(k * ext_b)));
    l.depth_extent = std::max(1, static_cast<int>(std::lround(k * ext_d)));
    l.x0 = (p.width - l.en_face_w - l.depth_extent) / 2;
    l.y0 = (p.height - l.en_face_h - l.depth_extent) / 2;
  }
  return p;
}

}  // namespace ioct::gpu::render
