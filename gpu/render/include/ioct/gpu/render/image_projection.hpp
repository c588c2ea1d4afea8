// Where a point of the volume appears in a render: the inverse of the ray set-up of
// pixel_shader.hpp's render_ray (an orthographic camera per eye), for marking a place (the
// instrument's tip) over the picture. Volume modes only: the planar modes (slices, LA-MIP
// composite) have no camera.
#pragma once

#include <optional>

#include "ioct/gpu/render/render_params.hpp"

namespace ioct::gpu::render {

struct ImagePoint {
  float x = 0.0f, y = 0.0f;  // output image px (eye 1's to the right of eye 0's), centres at +0.5
};

// `voxel`: x A-scan, y B-scan, z depth px. Nothing when `params` is a planar mode, the camera is
// degenerate, `eye` is not rendered, or the point falls outside the eye's image.
std::optional<ImagePoint> project_voxel(const RenderParams& params, Vec3 voxel, int eye);

}  // namespace ioct::gpu::render
