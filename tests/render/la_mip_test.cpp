// Layer-Adjusted MIP (Weiss et al. 2019, Sec. 3.3) on a synthetic curved layer: projected along
// curves parallel to the layer, the layer collapses onto one row, where a straight MIP would
// smear it over its whole sag.
#include <gtest/gtest.h>

#include <cmath>

#include "analytic_volumes.hpp"
#include "ioct/gpu/render/cpu_renderer.hpp"
#include "ioct/gpu/render/frame_setup.hpp"

namespace {

using namespace ioct::gpu;
using namespace ioct::gpu::render;
using ioct::render_test::curved_layer_depth;
using ioct::render_test::make_curved_layer;

struct Composite {
  RgbaImage image;
  CompositeLayout layout;
};

Composite render_composite(const ioct::render_test::VolumeWithSurfaces& v) {
  RenderConfig config;
  config.mode = RenderMode::la_mip_composite;
  config.spacing = {1.0, 1.0, 1.0};
  config.view.output_width = 2 * (v.volume.ascans() + v.volume.depth());
  config.view.output_height = 2 * (v.volume.bscans() + v.volume.depth());
  config.cpu_threads = 2;
  CpuRenderer renderer(2);
  renderer.set_volume(v.volume, &v.surfaces);
  Composite c;
  renderer.render(config, c.image);
  c.layout = bake_params(config, {v.volume.bscans(), v.volume.ascans(), v.volume.depth()},
                         renderer.reference().mean_thickness_px)
                 .layout;
  return c;
}

double luminance(const RgbaImage& image, int x, int y) {
  const auto* p = image.pixel(static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y));
  return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
}

TEST(LaMip, FlattensACurvedLayerOntoOneRow) {
  const auto v = make_curved_layer(32, 48, 64);
  const Composite c = render_composite(v);
  const CompositeLayout& l = c.layout;
  ASSERT_EQ(l.en_face_w, 96);
  ASSERT_EQ(l.depth_extent, 128);
  // Panel below the en face view: columns are A-scans, rows depth (2 output px per px).
  int columns = 0;
  for (int px = 4; px < l.en_face_w - 4; ++px) {
    const std::uint32_t a = static_cast<std::uint32_t>(px / 2);
    double row_sum = 0.0;
    int bright_rows = 0;
    for (int row = 0; row < l.depth_extent; ++row) {
      const double lum = luminance(c.image, l.x0 + px, l.y0 + l.en_face_h + row);
      if (lum > 200.0) {
        row_sum += row;
        ++bright_rows;
      }
    }
    ASSERT_GT(bright_rows, 0) << "A-scan " << a;
    const double centre_row = row_sum / bright_rows;
    // The layer sits at the RPE depth of the middle B-scan of this A-scan's column.
    const double expected_depth =
        0.5 * (curved_layer_depth(15, a, 32, 48, 64) + curved_layer_depth(16, a, 32, 48, 64));
    EXPECT_NEAR((centre_row + 0.5) / 2.0 - 0.5, expected_depth, 0.75) << "A-scan " << a;
    EXPECT_LE(bright_rows, 8) << "A-scan " << a;  // the 2 px plateau, 2 output px per px
    ++columns;
  }
  EXPECT_GT(columns, 80);
  // The same along the A-scans (panel to the right: columns depth, rows B-scans).
  for (int py = 4; py < l.en_face_h - 4; py += 3) {
    const std::uint32_t b = static_cast<std::uint32_t>(py / 2);
    double col_sum = 0.0;
    int bright = 0;
    for (int col = 0; col < l.depth_extent; ++col) {
      if (luminance(c.image, l.x0 + l.en_face_w + col, l.y0 + py) > 200.0) {
        col_sum += col;
        ++bright;
      }
    }
    ASSERT_GT(bright, 0) << "B-scan " << b;
    const double best_col = col_sum / bright;
    const double expected_depth =
        0.5 * (curved_layer_depth(b, 23, 32, 48, 64) + curved_layer_depth(b, 24, 32, 48, 64));
    EXPECT_NEAR((best_col + 0.5) / 2.0 - 0.5, expected_depth, 0.75) << "B-scan " << b;
  }
}

TEST(LaMip, ColoursTheLayerByItsDepthBelowTheRpe) {
  const auto v = make_curved_layer(32, 48, 64);
  const Composite c = render_composite(v);
  const CompositeLayout& l = c.layout;
  // En face: every pixel's brightest voxel is on the layer, i.e. at the RPE (delta* = 1/3):
  // the same colour everywhere, however deep the layer lies.
  const auto* centre = c.image.pixel(l.x0 + l.en_face_w / 2, l.y0 + l.en_face_h / 2);
  const auto* corner = c.image.pixel(l.x0 + 5, l.y0 + 5);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(centre[ch], corner[ch], 3) << "channel " << ch;
  // Rows above the layer in the LA-MIP panel are bluer than rows below it.
  const int x = l.x0 + l.en_face_w / 2;
  const int layer_row =
      l.y0 + l.en_face_h + static_cast<int>(2 * curved_layer_depth(16, 24, 32, 48, 64));
  const auto* above = c.image.pixel(x, layer_row - 30);
  const auto* below = c.image.pixel(x, layer_row + 30);
  EXPECT_GT(above[2] - above[0], below[2] - below[0]);
}

}  // namespace
