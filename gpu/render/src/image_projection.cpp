#include "ioct/gpu/render/image_projection.hpp"

#include <cmath>

namespace ioct::gpu::render {
namespace {

float det3(Vec3 a, Vec3 b, Vec3 c) {
  return a.x * (b.y * c.z - b.z * c.y) - b.x * (a.y * c.z - a.z * c.y) +
         c.x * (a.y * b.z - a.z * b.y);
}

}  // namespace

std::optional<ImagePoint> project_voxel(const RenderParams& p, Vec3 voxel, int eye) {
  const bool volume_mode = p.kind == PixelKind::basic || p.kind == PixelKind::enhanced ||
                           p.kind == PixelKind::layer_aware ||
                           p.kind == PixelKind::axial_colorization;
  if (!volume_mode || eye < 0 || eye >= p.eyes || p.width <= 0 || p.height <= 0) return {};
  const EyeParams& e = p.eye[eye];
  // voxel = origin + sx right + sy up + t dir: Cramer's rule for (sx, sy).
  const Vec3 d = voxel - e.origin;
  const float det = det3(e.right, e.up, e.dir);
  if (!(std::abs(det) > 1e-12f)) return {};
  const float sx = det3(d, e.up, e.dir) / det;
  const float sy = det3(e.right, d, e.dir) / det;
  // render_ray: sx = ((x + 0.5) / width * 2 - 1) * half_width + pan_x, and likewise for y.
  const float x = ((sx - p.pan_x) / p.half_width + 1.0f) * 0.5f * static_cast<float>(p.width);
  const float y = (1.0f - (sy - p.pan_y) / p.half_height) * 0.5f * static_cast<float>(p.height);
  if (!(x >= 0.0f && y >= 0.0f && x < static_cast<float>(p.width) &&
        y < static_cast<float>(p.height))) {
    return {};
  }
  return ImagePoint{x + static_cast<float>(eye * p.width), y};
}

}  // namespace ioct::gpu::render
