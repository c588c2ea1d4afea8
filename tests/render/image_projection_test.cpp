// Where a volume point appears in a render: the inverse of the ray set-up. A point on the ray of a
// pixel projects back to that pixel's centre, for each eye of a stereo pair and from several
// views; the volume's centre sits in the middle of an unpanned image; planar modes place nothing.
#include "ioct/gpu/render/image_projection.hpp"

#include <gtest/gtest.h>

#include "ioct/gpu/render/frame_setup.hpp"
#include "ioct/gpu/render/render_config.hpp"

namespace ioct::gpu::render {
namespace {

RenderParams params_for(const RenderConfig& config) {
  return bake_params(config, VolumeDims{32, 128, 256}, 0.0f);
}

TEST(ImageProjection, APointOnAPixelsRayProjectsBackToThatPixel) {
  RenderConfig config;
  config.view.output_width = 320;
  config.view.output_height = 240;
  for (const double azimuth : {0.0, 30.0, 135.0}) {
    for (const bool stereo : {false, true}) {
      config.view.azimuth_deg = azimuth;
      config.view.stereo = stereo;
      const RenderParams p = params_for(config);
      for (int eye = 0; eye < p.eyes; ++eye) {
        const EyeParams& e = p.eye[eye];
        for (const auto [x, y] : {std::pair{10, 20}, std::pair{160, 120}, std::pair{300, 230}}) {
          // render_ray's ray through pixel (x, y), 5 world units along it.
          const float sx = ((x + 0.5f) / p.width * 2.0f - 1.0f) * p.half_width + p.pan_x;
          const float sy = (1.0f - (y + 0.5f) / p.height * 2.0f) * p.half_height + p.pan_y;
          const Vec3 point = e.origin + sx * e.right + sy * e.up + 5.0f * e.dir;
          const auto at = project_voxel(p, point, eye);
          ASSERT_TRUE(at.has_value()) << azimuth << " eye " << eye << " (" << x << ", " << y << ")";
          EXPECT_NEAR(at->x, x + 0.5f + eye * p.width, 1e-2f) << azimuth << " eye " << eye;
          EXPECT_NEAR(at->y, y + 0.5f, 1e-2f) << azimuth << " eye " << eye;
        }
      }
      EXPECT_FALSE(project_voxel(p, Vec3{64, 16, 128}, p.eyes).has_value()) << "no such eye";
    }
  }
}

TEST(ImageProjection, TheVolumesCentreIsInTheMiddleAndPlanarModesPlaceNothing) {
  RenderConfig config;
  config.view.output_width = 320;
  config.view.output_height = 240;
  const RenderParams p = params_for(config);
  const auto centre = project_voxel(p, Vec3{64.0f, 16.0f, 128.0f}, 0);
  ASSERT_TRUE(centre.has_value());
  EXPECT_NEAR(centre->x, 160.0f, 3.0f);
  EXPECT_NEAR(centre->y, 120.0f, 3.0f);
  EXPECT_FALSE(project_voxel(p, Vec3{64.0f, 16.0f, 1e6f}, 0).has_value()) << "off the image";
  config.mode = RenderMode::la_mip_composite;
  EXPECT_FALSE(project_voxel(params_for(config), Vec3{64.0f, 16.0f, 128.0f}, 0).has_value());
}

}  // namespace
}  // namespace ioct::gpu::render
