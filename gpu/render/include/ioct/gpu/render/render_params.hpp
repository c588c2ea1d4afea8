// A RenderConfig baked for one volume and one frame: plain numbers and pointers that the CPU
// reference and the CUDA kernels read alike (a kernel argument). Made by bake_params().
#pragma once

#include <cstdint>

#include "ioct/gpu/render/host_device.hpp"

namespace ioct::gpu::render {

inline constexpr int kTransferLutSize = 256;  // RGBA per entry, linear between entries
inline constexpr int kLabLutIntensities = 256;
inline constexpr int kLabLutDepths = 256;  // delta* in [0, 1]; RGBA per entry, bilinear

enum class PixelKind : std::int32_t {
  basic = 0,
  enhanced = 1,
  layer_aware = 2,
  axial_colorization = 3,
  la_mip_composite = 4,
  bscan_slice = 5,
  en_face_slice = 6,
};

// One eye's orthographic camera, in voxel coordinates (x: A-scan, y: B-scan, z: depth px) where
// the ray is marched, and in world coordinates where the shading's vectors live.
struct EyeParams {
  Vec3 origin;       // voxel position of image-plane point (0, 0), one bounding radius in front
  Vec3 right;        // voxel displacement per world unit along the image's x
  Vec3 up;           // ... along the image's y
  Vec3 dir;          // ... along the view direction
  Vec3 view_world;   // view direction (from the eye into the scene), world, unit
  Vec3 light_world;  // towards the light, world, unit
  Vec3 half_world;   // Phong's H: normalize(light + towards the eye)
  Vec3 light_voxel;  // voxel displacement per world unit towards the light
  float step;        // world length between samples
  float depth_cue_offset;  // dv = (t - offset) * scale: 0 at the nearest corner, 1 the farthest
  float depth_cue_scale;
};

struct CompositeLayout {
  std::int32_t x0, y0;  // top-left of the en face panel
  std::int32_t en_face_w, en_face_h;
  std::int32_t depth_extent;  // height of the panel below, width of the one to the right
};

struct RenderParams {
  PixelKind kind = PixelKind::enhanced;
  std::int32_t width = 0;  // one eye
  std::int32_t height = 0;
  std::int32_t eyes = 1;
  std::int32_t dim_a = 0, dim_b = 0, dim_d = 0;
  float half_width = 1, half_height = 1;  // image plane, world units
  float pan_x = 0, pan_y = 0;
  Vec3 gradient_scale{1, 1, 1};  // voxel-index differences to world-direction gradient
  EyeParams eye[2]{};
  float early_termination = 0.975f;
  float background[3] = {0, 0, 0};

  // enhanced / basic / axial
  std::int32_t use_threshold = 1, edge = 1, feature = 1, depth_cues = 1, phong = 1;
  float threshold = 0.35f;
  float kg1 = 0, kg2 = 1, kf1 = 0, kf2 = 1, kd1 = 0, kd2 = 1, kd3 = 0, kp1 = 1, kp2 = 0, kp3 = 0,
        kp4 = 1;
  Vec3 c_b{0, 0, 1};

  // layer-aware
  float i_min = 0.3f, i_max = 0.9f, alpha_max = 0.5f;
  std::int32_t shadow_steps = 0;
  float d_rpe_px = 50;

  // slices
  float slice_bscan = 0;
  float slice_depth = 0;
  std::int32_t slice_relative_to_rpe = 0;
  CompositeLayout layout{};
  float plane_scale_x = 1, plane_scale_y = 1;  // slices: output px -> volume px
  float plane_x0 = 0, plane_y0 = 0;

  // Tables: host pointers for the CPU renderer, device pointers for CUDA.
  const float* transfer_lut = nullptr;  // kTransferLutSize x RGBA
  const float* lab_lut = nullptr;       // [delta*][I] x RGBA
  const float* reference_px = nullptr;  // [bscan][ascan]: the RPE (or the axial plane), px
  // The mean retinal thickness measured where the pixels are computed (the CUDA renderer keeps
  // its layer reference on the device), px; null: d_rpe_px is the whole answer.
  const float* measured_d_rpe_px = nullptr;
};

// d_rpe as the pixels use it: the measured thickness when there is one above 1 px, else the
// baked d_rpe_px (the configured value, the host reference's thickness, or the default).
IOCT_RENDER_HD float d_rpe(const RenderParams& p) {
  if (p.measured_d_rpe_px != nullptr && *p.measured_d_rpe_px > 1.0f) return *p.measured_d_rpe_px;
  return p.d_rpe_px;
}

}  // namespace ioct::gpu::render
